// Benchmark of the map builder's track refinement (docs/mapping.md "Track refinement"): CPU
// time per camera keyframe of the inverse compositional solver (the refinement) against the
// forward additive one (its reference, the solver before 2026-11-27 night) on the same tracker
// output, and how far their results lie apart. Hidden (not run by ctest): prints figures, times
// nothing it checks.
//
//   build/bin/vilma_mapping_tests "[.refine-bench]"
//   VILMA_REFINE_BENCH_SET     an ASL set with ground truth (default
//                              ~/.cache/vilma/datasets/room-easy)
//   VILMA_REFINE_BENCH_RIG     its rig (default SET/rig.yaml; EuRoC: config/euroc-rig.yaml)
//   VILMA_REFINE_BENCH_FRAMES  keyframes (cam0 at 10 Hz: every second 20 Hz frame; default 300)
//   VILMA_REFINE_BENCH_REPEAT  interleaved A/B repeats (default 5)
//   VILMA_REFINE_BENCH_METHOD  "affine" (default) or "translation"
//   VILMA_REFINE_BENCH_MAX_ERROR  max_error_grey (default 5, the street's gate)
#include <time.h>

#include <algorithm>
#include <catch2/catch.hpp>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <string>
#include <vector>

#include "test_skip.h"
#include "vilma/core/asl_dataset.h"
#include "vilma/core/rig.h"
#include "vilma/localizer/feature_tracker.h"
#include "vilma/mapping/map_builder_options.h"
#include "vilma/mapping/track_refinement.h"

using namespace vilma;
using namespace vilma::mapping;
namespace fs = std::filesystem;

namespace {

std::string Env(const char* name, const std::string& fallback) {
  const char* v = std::getenv(name);
  return v != nullptr && *v != '\0' ? std::string(v) : fallback;
}

double ThreadCpuSeconds() {
  timespec ts{};
  clock_gettime(CLOCK_THREAD_CPUTIME_ID, &ts);
  return static_cast<double>(ts.tv_sec) + 1e-9 * static_cast<double>(ts.tv_nsec);
}

double Median(std::vector<double> v) {
  std::sort(v.begin(), v.end());
  return v.empty()      ? 0.0
         : v.size() % 2 ? v[v.size() / 2]
                        : 0.5 * (v[v.size() / 2 - 1] + v[v.size() / 2]);
}

double Quantile(std::vector<double> v, double q) {
  if (v.empty()) return 0.0;
  std::sort(v.begin(), v.end());
  return v[std::min(v.size() - 1, static_cast<std::size_t>(q * static_cast<double>(v.size())))];
}

struct Keyframe {
  cv::Mat image;
  std::vector<int64_t> tracker_ids;
  std::vector<Eigen::Vector2d> uv;
};

struct Run {
  double cpu_s = 0.0;
  std::vector<std::vector<Eigen::Vector2d>> uv;
  std::vector<std::vector<int64_t>> ids;
  TrackRefinementStats stats;
};

Run RunRefiner(const std::vector<Keyframe>& keyframes, const TrackRefinementOptions& options,
               TrackRefiner::Solver solver, bool keep) {
  TrackRefiner refiner(options, int64_t{1} << 39);
  refiner.set_solver(solver);
  Run run;
  std::vector<Eigen::Vector2d> uv;
  std::vector<int64_t> ids;
  for (const Keyframe& kf : keyframes) {
    uv = kf.uv;
    const double t0 = ThreadCpuSeconds();
    refiner.Refine(kf.image, kf.tracker_ids, &uv, &ids);
    run.cpu_s += ThreadCpuSeconds() - t0;
    if (keep) {
      run.uv.push_back(uv);
      run.ids.push_back(ids);
    }
  }
  run.stats = refiner.stats();
  return run;
}

}  // namespace

TEST_CASE("track refinement benchmark: inverse compositional against forward additive",
          "[.refine-bench]") {
  const std::string home = Env("HOME", "/root");
  const fs::path set = Env("VILMA_REFINE_BENCH_SET", home + "/.cache/vilma/datasets/room-easy");
  const fs::path rig_file = Env("VILMA_REFINE_BENCH_RIG", (set / "rig.yaml").string());
  if (!fs::exists(set / "mav0") || !fs::exists(rig_file)) {
    VILMA_SKIP_OPTIONAL("no set at " << set << " with the rig " << rig_file
                                     << " (scripts/make-datasets.sh)");
  }
  const int max_keyframes = std::stoi(Env("VILMA_REFINE_BENCH_FRAMES", "300"));
  const int repeat = std::stoi(Env("VILMA_REFINE_BENCH_REPEAT", "5"));
  TrackRefinementOptions options;
  options.method = Env("VILMA_REFINE_BENCH_METHOD", "affine");
  options.max_error_grey = std::stod(Env("VILMA_REFINE_BENCH_MAX_ERROR", "5"));
  REQUIRE(options.Validate().empty());

  // The tracker's output once (as the map builder: cam0 at 10 Hz, the rotation prior from the
  // ground truth instead of the gyroscope).
  const AslDataset ds = AslDataset::Open(set.string());
  const SensorRig rig = LoadSensorRig(rig_file.string());
  const auto& gt = ds.ground_truth();
  REQUIRE(!gt.empty());
  localizer::FeatureTracker tracker(MapBuilderOptions().features);
  const Eigen::Quaterniond q_I_C = rig.cameras[0].T_I_C.rotation();
  std::vector<Keyframe> keyframes;
  Eigen::Quaterniond q_W_Iprev = Eigen::Quaterniond::Identity();
  const auto& frames = ds.cameras()[0].frames;
  for (std::size_t i = 0; i < frames.size() && static_cast<int>(keyframes.size()) < max_keyframes;
       i += 2) {
    const int64_t t = frames[i].t_ns + rig.cameras[0].time_offset_ns;
    auto it = std::lower_bound(gt.begin(), gt.end(), t,
                               [](const GroundTruthState& g, int64_t tt) { return g.t_ns < tt; });
    if (it == gt.end()) break;
    const Eigen::Quaterniond q_W_I = it->q_W_I;
    const Eigen::Quaterniond q_Ia_Ib =
        keyframes.empty() ? Eigen::Quaterniond::Identity() : q_W_Iprev.conjugate() * q_W_I;
    q_W_Iprev = q_W_I;
    const Eigen::Quaterniond q_Ck_Ckm1 = (q_I_C.conjugate() * q_Ia_Ib * q_I_C).conjugate();
    Keyframe kf;
    kf.image = AslDataset::LoadImage(frames[i].image_path);
    const localizer::TrackingResult r = tracker.Track(kf.image, rig.cameras[0].camera, q_Ck_Ckm1);
    kf.tracker_ids = r.track_ids;
    for (const cv::KeyPoint& kp : r.features.keypoints) kf.uv.emplace_back(kp.pt.x, kp.pt.y);
    keyframes.push_back(std::move(kf));
  }
  REQUIRE(keyframes.size() >= 10);
  std::size_t keypoints = 0;
  for (const Keyframe& kf : keyframes) keypoints += kf.uv.size();

  // Interleaved A/B: forward additive, inverse compositional, ...
  std::vector<double> ms_fa, ms_ic;
  Run first_fa, first_ic;
  for (int r = 0; r < repeat; ++r) {
    Run fa = RunRefiner(keyframes, options, TrackRefiner::Solver::kForwardAdditive, r == 0);
    Run ic = RunRefiner(keyframes, options, TrackRefiner::Solver::kInverseCompositional, r == 0);
    const double n = static_cast<double>(keyframes.size());
    ms_fa.push_back(1e3 * fa.cpu_s / n);
    ms_ic.push_back(1e3 * ic.cpu_s / n);
    std::printf(
        "repeat %d: forward additive %.2f ms/keyframe, inverse compositional %.2f "
        "ms/keyframe (CPU time of Refine)\n",
        r + 1, ms_fa.back(), ms_ic.back());
    if (r == 0) {
      first_fa = std::move(fa);
      first_ic = std::move(ic);
    }
  }
  // Agreement: keypoints refined by both or by one only, and the distance between the two
  // solvers' positions where both refined under the same track id.
  std::size_t both = 0, only_fa = 0, only_ic = 0;
  std::vector<double> diff;
  for (std::size_t f = 0; f < keyframes.size(); ++f) {
    for (std::size_t k = 0; k < keyframes[f].uv.size(); ++k) {
      const bool moved_fa = first_fa.uv[f][k] != keyframes[f].uv[k];
      const bool moved_ic = first_ic.uv[f][k] != keyframes[f].uv[k];
      if (moved_fa && moved_ic) {
        ++both;
        // The same track in both (a split in one of them gives the track another reference).
        if (first_fa.ids[f][k] == first_ic.ids[f][k]) {
          diff.push_back((first_fa.uv[f][k] - first_ic.uv[f][k]).norm());
        }
      } else if (moved_fa) {
        ++only_fa;
      } else if (moved_ic) {
        ++only_ic;
      }
    }
  }
  const auto report = [](const char* name, const TrackRefinementStats& s) {
    std::printf("%s: %lld refined, %lld splits, %lld kept (", name,
                static_cast<long long>(s.refined), static_cast<long long>(s.splits),
                static_cast<long long>(s.kept));
    for (int i = 1; i < 8; ++i) {
      std::printf("%s%s %lld", i > 1 ? ", " : "",
                  PatchAlignmentStatusName(static_cast<PatchAlignment::Status>(i)),
                  static_cast<long long>(s.failed_by_status[i]));
    }
    std::printf("), mean |aligned - detected| %.3f px\n",
                s.refined > 0 ? s.shift_sum_px / static_cast<double>(s.refined) : 0.0);
  };
  std::printf(
      "\n%s, method %s, max_error_grey %g: %zu keyframes, %zu keypoints (%.0f per "
      "keyframe), %d repeats\n",
      set.filename().c_str(), options.method.c_str(), options.max_error_grey, keyframes.size(),
      keypoints, static_cast<double>(keypoints) / static_cast<double>(keyframes.size()), repeat);
  std::printf(
      "CPU ms per camera keyframe, median (min..max): forward additive %.2f (%.2f..%.2f), "
      "inverse compositional %.2f (%.2f..%.2f); ratio %.3f\n",
      Median(ms_fa), *std::min_element(ms_fa.begin(), ms_fa.end()),
      *std::max_element(ms_fa.begin(), ms_fa.end()), Median(ms_ic),
      *std::min_element(ms_ic.begin(), ms_ic.end()), *std::max_element(ms_ic.begin(), ms_ic.end()),
      Median(ms_ic) / Median(ms_fa));
  report("forward additive", first_fa.stats);
  report("inverse compositional", first_ic.stats);
  std::printf(
      "refined by both %zu, by forward additive only %zu, by inverse compositional only "
      "%zu; |difference| where both under the same track id (%zu): median %.4f, p90 %.4f, "
      "p99 %.4f, max %.4f px\n",
      both, only_fa, only_ic, diff.size(), Median(diff), Quantile(diff, 0.9), Quantile(diff, 0.99),
      diff.empty() ? 0.0 : *std::max_element(diff.begin(), diff.end()));
  CHECK(both > 0);
}
