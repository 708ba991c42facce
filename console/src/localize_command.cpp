#include "vilma/console/localize_command.h"
#include "vilma/console/eval_command.h"

#include <time.h>

#include <algorithm>
#include <array>
#include <chrono>
#include <cmath>
#include <cstdlib>
#include <exception>
#include <filesystem>
#include <iomanip>
#include <opencv2/core/utility.hpp>
#include <sstream>

#include "vilma/console/locmap_command.h"
#include "vilma/core/asl_dataset.h"
#include "vilma/core/error.h"
#include "vilma/core/rig.h"
#include "vilma/core/timing.h"
#include "vilma/eval/alignment_json.h"
#include "vilma/localizer/keyframe_features.h"
#include "vilma/localizer/localizer.h"


namespace vilma::console {
namespace {

namespace fs = std::filesystem;
using localizer::LocalizationStatus;

// Ground truth T_W_I at t (IMU clock): the sample at t, else linear / slerp interpolation
// between the two samples around t when they are at most 51 ms apart (EuRoC's ground truth is
// 200 Hz, or 20 Hz with stamp jitter: gaps of 50.0001 ms, and not on the camera times; the
// simulator writes a sample at every frame time). A missing sample (100 ms) is no ground truth.
bool GroundTruthAt(const std::vector<GroundTruthState>& gt, int64_t t, Transformation* T_W_I) {
  const auto it = std::lower_bound(
      gt.begin(), gt.end(), t, [](const GroundTruthState& g, int64_t tt) { return g.t_ns < tt; });
  if (it == gt.end()) return false;
  if (it->t_ns == t) {
    *T_W_I = Transformation(it->q_W_I, it->p_W_I);
    return true;
  }
  if (it == gt.begin()) return false;
  const GroundTruthState& a = *(it - 1);
  const GroundTruthState& b = *it;
  constexpr int64_t kMaxGapNs = 51'000'000;
  if (b.t_ns - a.t_ns > kMaxGapNs) return false;
  const double s = static_cast<double>(t - a.t_ns) / static_cast<double>(b.t_ns - a.t_ns);
  *T_W_I = Transformation(a.q_W_I.slerp(s, b.q_W_I), (1.0 - s) * a.p_W_I + s * b.p_W_I);
  return true;
}

struct Query {
  std::size_t frame = 0;
  int64_t t_ns = 0;
  LocalizationStatus status = LocalizationStatus::kNoKeypoints;
  int keypoints = 0, raw_matches = 0, matches = 0, inliers = 0, ransac_iterations = 0;
  double rms_px = 0.0;
  Transformation T_G_I;
  bool has_gt = false;
  Transformation T_W_I_gt;
  bool has_error = false;
  double position_error_m = 0.0, rotation_error_deg = 0.0;
  double features_ms = 0.0, features_cpu_ms = 0.0, localize_ms = 0.0, localize_cpu_ms = 0.0;
};

double RotationErrorDeg(const Eigen::Quaterniond& a, const Eigen::Quaterniond& b) {
  return Eigen::AngleAxisd(a.conjugate() * b).angle() * 180.0 / M_PI;
}

// Errors of the localized queries against ground truth after S_W_G = `align`.
void ComputeErrors(const Alignment& align, std::vector<Query>* queries) {
  for (Query& q : *queries) {
    q.has_error = q.has_gt && q.status == LocalizationStatus::kOk;
    if (!q.has_error) continue;
    const Transformation T_W_I = align.Apply(q.T_G_I);
    q.position_error_m = (T_W_I.translation() - q.T_W_I_gt.translation()).norm();
    q.rotation_error_deg = RotationErrorDeg(q.T_W_I_gt.rotation(), T_W_I.rotation());
  }
}

// S_W_G fitted to the localized positions (posyaw / se3), robustly: a least-squares fit to all,
// then one refit to those within max(3 x median error, 0.3 m) of the first fit, so that a few
// wrong localizations (metres off) do not bend it. False if too few localized queries.
bool FitAlignment(AlignmentType type, std::vector<Query>* queries, Alignment* align) {
  std::vector<Eigen::Vector3d> p_W, p_G;
  for (const Query& q : *queries) {
    if (!q.has_gt || q.status != LocalizationStatus::kOk) continue;
    p_W.push_back(q.T_W_I_gt.translation());
    p_G.push_back(q.T_G_I.translation());
  }
  if (p_W.size() < std::max<std::size_t>(MinimumPosesForAlignment(type), 3)) return false;
  *align = AlignPositions(type, p_W, p_G);
  std::vector<double> e(p_W.size());
  for (std::size_t i = 0; i < p_W.size(); ++i) {
    e[i] = (align->Apply(Transformation(Eigen::Quaterniond::Identity(), p_G[i])).translation() -
            p_W[i])
               .norm();
  }
  const double gate = std::max(3.0 * Percentile(e, 0.5), 0.3);
  std::vector<Eigen::Vector3d> p_W_in, p_G_in;
  for (std::size_t i = 0; i < e.size(); ++i) {
    if (e[i] > gate) continue;
    p_W_in.push_back(p_W[i]);
    p_G_in.push_back(p_G[i]);
  }
  if (p_W_in.size() >= std::max<std::size_t>(MinimumPosesForAlignment(type), 3)) {
    *align = AlignPositions(type, p_W_in, p_G_in);
  }
  ComputeErrors(*align, queries);
  return true;
}

std::string FormatCsv(const std::vector<Query>& queries) {
  std::ostringstream s;
  s << "frame,t_ns,status,keypoints,raw_matches,matches,inliers,ransac_iterations,"
       "rms_reprojection_px,p_G_x,p_G_y,p_G_z,q_G_w,q_G_x,q_G_y,q_G_z,has_ground_truth,"
       "position_error_m,rotation_error_deg,features_ms,features_cpu_ms,localize_ms,"
       "localize_cpu_ms\n";
  s << std::setprecision(9);
  for (const Query& q : queries) {
    const bool ok = q.status == LocalizationStatus::kOk;
    s << q.frame << "," << q.t_ns << "," << localizer::LocalizationStatusName(q.status) << ","
      << q.keypoints << "," << q.raw_matches << "," << q.matches << "," << q.inliers << ","
      << q.ransac_iterations << ",";
    if (ok) {
      const Eigen::Vector3d& p = q.T_G_I.translation();
      const Eigen::Quaterniond& r = q.T_G_I.rotation();
      s << q.rms_px << "," << p.x() << "," << p.y() << "," << p.z() << "," << r.w() << "," << r.x()
        << "," << r.y() << "," << r.z() << ",";
    } else {
      s << ",,,,,,,,";
    }
    s << (q.has_gt ? 1 : 0) << ",";
    if (q.has_error) {
      s << q.position_error_m << "," << q.rotation_error_deg << ",";
    } else {
      s << ",,";
    }
    s << q.features_ms << "," << q.features_cpu_ms << "," << q.localize_ms << ","
      << q.localize_cpu_ms << "\n";
  }
  return s.str();
}

std::string Percent(int n, int d) {
  std::ostringstream s;
  s << n << " / " << d << " (" << std::fixed << std::setprecision(1)
    << (d > 0 ? 100.0 * n / d : 0.0) << " %)";
  return s.str();
}

}  // namespace

LocalizeCommandOptions ParseLocalizeArgs(const std::vector<std::string>& args) {
  LocalizeCommandOptions o;
  for (ArgCursor arg(args); arg.Next();) {
    const std::string& a = arg.name();
    auto next = [&arg] { return arg.Value(); };
    if (a == "--help" || a == "-h") {
      o.help = arg.Flag();
    } else if (a == "--every") {
      o.every = arg.IntValue(1);
    } else if (a == "--camera") {
      o.camera = arg.IntValue(0);
    } else if (a == "--rig") {
      o.rig_path = next();
    } else if (a == "--config") {
      o.config_path = next();
    } else if (a == "--features") {
      o.features_path = next();
    } else if (a == "--out") {
      o.out_path = next();
    } else if (a == "--align") {
      const std::string v = next();
      if (v == "none") {
        o.align = AlignmentType::kNone;
      } else if (v == "posyaw") {
        o.align = AlignmentType::kPosYaw;
      } else if (v == "se3") {
        o.align = AlignmentType::kSe3;
      } else {
        throw UsageError("--align: expected none, posyaw or se3, got '" + v + "'");
      }
    } else if (a == "--align-from") {
      o.align_from_path = next();
    } else if (a == "--quiet") {
      o.quiet = arg.Flag();
    } else if (a.rfind("-", 0) == 0) {
      throw UsageError("unknown option '" + a + "'");
    } else if (o.dataset.empty()) {
      o.dataset = a;
    } else if (o.map.empty()) {
      o.map = a;
    } else {
      throw UsageError("unexpected argument '" + a + "' (one DATASET and one MAP)");
    }
  }
  if (!o.align_from_path.empty() && o.align != AlignmentType::kNone) {
    throw UsageError("--align and --align-from exclude each other");
  }
  if (!o.help) {
    if (o.dataset.empty()) throw UsageError("expected DATASET and MAP");
    if (o.map.empty()) throw UsageError("expected MAP after DATASET");
  }
  return o;
}

void PrintLocalizeHelp(std::ostream& out) {
  out << "usage: vilma localize DATASET MAP [--every N] [--camera C] [--rig RIG.yaml]\n"
         "                      [--config LOCALIZER.yaml] [--features FEATURES.yaml]\n"
         "                      [--align none|posyaw|se3 | --align-from ALIGNMENT.json]\n"
         "                      [--out RESULTS.csv] [--quiet]\n"
         "\n"
         "Offline map check: will MAP localize this recorded session? Every Nth image of\n"
         "camera C of an ASL/EuRoC dataset folder is localized against MAP (a .vlocmap file\n"
         "from 'vilma locmap build' or vilma-locmap-gt, or a VI-map folder, summarized at\n"
         "start) with the query features of vilma-estimatord. Prints one line per query\n"
         "(status, keypoints, matches, inliers, errors) and a summary: status counts, recall\n"
         "within 0.5 m and within 0.3 m and 2 deg, median / p90 errors, query times.\n"
         "Single-threaded and deterministic (timings aside).\n"
         "\n"
         "Errors need the dataset's ground truth (state_groundtruth_estimate0) and a known\n"
         "relation between the map frame G and the ground-truth frame W:\n"
         "  --align none     G = W (default): maps built with ground-truth poses\n"
         "                   (vilma-locmap-gt) or anchored in the ground-truth frame\n"
         "  --align posyaw   G = a VIO odometry frame (a map from 'vilma vio --save-map'):\n"
         "                   yaw + translation fitted to the localized positions (robust\n"
         "                   refit); errors then show consistency, not absolute accuracy\n"
         "  --align se3      as posyaw with a full rotation\n"
         "  --align-from F   a fixed alignment: the alignment_transform of 'vilma eval --json F'\n"
         "                   (e.g. the map's first mission against its ground truth), so that\n"
         "                   errors are absolute and independent of which queries localized\n"
         "\n"
         "options:\n"
         "  --every N        query every Nth frame (default 10, >= 1)\n"
         "  --camera C       camera of the rig and dataset (default 0)\n"
         "  --rig FILE       sensor rig YAML (default: DATASET/rig.yaml if present, else the\n"
         "                   EuRoC sensor.yaml files of DATASET)\n"
         "  --config FILE    localizer options (config/localizer.yaml format; default: the\n"
         "                   built-in defaults; the `map` section applies to VI-map folders)\n"
         "  --features FILE  query keyframe features (strict, every key, like\n"
         "                   config/keyframe_features.yaml; default: vilma-estimatord's\n"
         "                   built-in query profile = config/localization_features.yaml)\n"
         "  --out FILE       CSV, one row per query (written atomically)\n"
         "  --quiet          no per-query lines\n"
         "  -h, --help       this text\n"
         "\n"
         "exit codes: 0 ok (whatever the recall), 1 input error, 2 usage error\n";
}

int RunLocalizeCommand(const std::vector<std::string>& args, std::ostream& out, std::ostream& err) {
  LocalizeCommandOptions o;
  try {
    o = ParseLocalizeArgs(args);
  } catch (const UsageError& e) {
    err << "vilma localize: " << e.what() << "\n(see 'vilma localize --help')\n";
    return kExitUsage;
  }
  if (o.help) {
    PrintLocalizeHelp(out);
    return kExitOk;
  }
  try {
    cv::setNumThreads(1);  // one core, deterministic
    // Options and inputs that are quick to check come first, the map load last.
    const localizer::LocalizerOptions options =
        o.config_path.empty() ? localizer::LocalizerOptions()
                              : localizer::LoadLocalizerOptions(o.config_path);
    const std::string features_path =
        o.features_path.empty() ? std::string("built-in query profile") : o.features_path;
    const localizer::KeyframeFeatureOptions features =
        o.features_path.empty() ? localizer::LocalizationQueryFeatureOptions()
                                : localizer::LoadKeyframeFeatureOptions(o.features_path);
    std::error_code ec;
    if (!fs::is_directory(o.dataset, ec)) {
      throw InputError(FormatInputError(o.dataset, "DATASET", "an ASL dataset folder"));
    }
    SensorRig rig;
    std::string rig_source;
    if (!o.rig_path.empty()) {
      rig = LoadSensorRig(o.rig_path);
      rig_source = o.rig_path;
    } else if (fs::exists(fs::path(o.dataset) / "rig.yaml", ec)) {
      rig_source = (fs::path(o.dataset) / "rig.yaml").string();
      rig = LoadSensorRig(rig_source);
    } else {
      rig = ImportEurocRig(o.dataset);
      rig_source = o.dataset + " (EuRoC sensor.yaml)";
    }
    const AslDataset dataset = AslDataset::Open(o.dataset);
    const std::size_t cam = static_cast<std::size_t>(o.camera);
    if (cam >= dataset.cameras().size()) {
      throw InputError(FormatInputError(o.dataset, "cam" + std::to_string(o.camera),
                                        "a camera folder with that index (--camera)"));
    }
    if (cam >= rig.cameras.size()) {
      throw InputError(FormatInputError(rig_source, "cameras[" + std::to_string(o.camera) + "]",
                                        "the camera given by --camera"));
    }
    const auto& frames = dataset.cameras()[cam].frames;
    if (frames.empty()) {
      throw InputError(
          FormatInputError(o.dataset, "cam" + std::to_string(o.camera) + "/data.csv", "images"));
    }
    const Camera& camera = rig.cameras[cam].camera;
    const Transformation& T_I_C = rig.cameras[cam].T_I_C;
    const int64_t offset_ns = rig.cameras[cam].time_offset_ns;

    std::string map_description;
    const std::shared_ptr<const localizer::LocalizationMap> map =
        LoadOrBuildLocalizationMap(o.map, options.map, &map_description);
    const bool stored_projection = map->projection.rows() > 0;
    const localizer::Localizer loc(map, options);
    const localizer::FeatureExtractor extractor(features);

    out << std::fixed << std::setprecision(1) << "vilma localize: " << o.dataset << " cam"
        << o.camera << " (rig " << rig_source << ")\n"
        << "  map        " << o.map << ": " << map_description << "; " << map->num_landmarks()
        << " landmarks, " << map->num_descriptors() << " descriptors; projection "
        << (stored_projection
                ? "stored"
                : "trained at load in " +
                      std::to_string(static_cast<int>(loc.projection_train_ms())) + " ms")
        << ", index " << loc.index_build_ms() << " ms\n"
        << "  features   " << features_path << " (" << features.detector.num_levels << " levels, "
        << features.detector.max_keypoints << " keypoints at most)\n"
        << "  queries    every " << o.every << (o.every == 1 ? " frame" : " frames") << " of "
        << frames.size() << "\n";
    if (!o.quiet) {
      out << "  frame      t[s]  status                     kpts   raw match  inl   e_p[m] e_R[deg]"
             "  feat_ms   loc_ms\n";
    }

    std::vector<Query> queries;
    std::vector<Eigen::Vector2d> uv;
    const auto& gt = dataset.ground_truth();
    for (std::size_t i = 0; i < frames.size(); i += static_cast<std::size_t>(o.every)) {
      Query q;
      q.frame = i;
      q.t_ns = frames[i].t_ns;
      q.has_gt = GroundTruthAt(gt, frames[i].t_ns + offset_ns, &q.T_W_I_gt);
      const cv::Mat image = AslDataset::LoadImage(frames[i].image_path);
      if (image.cols != camera.width() || image.rows != camera.height()) {
        throw InputError(FormatInputError(frames[i].image_path, "size",
                                          std::to_string(camera.width()) + "x" +
                                              std::to_string(camera.height()) +
                                              " as the rig's camera " + std::to_string(o.camera)));
      }
      auto t0 = std::chrono::steady_clock::now();
      const double cpu0 = ThreadCpuMs();
      const localizer::KeyframeFeatures f = extractor.Extract(image);
      q.features_cpu_ms = ThreadCpuMs() - cpu0;
      q.features_ms = MsSince(t0);
      uv.clear();
      for (const cv::KeyPoint& k : f.keypoints) uv.emplace_back(k.pt.x, k.pt.y);
      q.keypoints = f.size();
      t0 = std::chrono::steady_clock::now();
      const localizer::LocalizationResult r = loc.Localize(
          camera, T_I_C, uv, f.keypoints.empty() ? nullptr : f.descriptors.ptr<uint8_t>());
      q.localize_ms = MsSince(t0);
      q.localize_cpu_ms = r.match_cpu_ms + r.pose_cpu_ms;
      q.status = r.status;
      q.raw_matches = r.num_raw_matches;
      q.matches = static_cast<int>(r.matches.size());
      q.inliers = static_cast<int>(r.inliers.size());
      q.ransac_iterations = r.ransac_iterations;
      q.rms_px = r.rms_reprojection_px;
      q.T_G_I = r.T_G_I;
      queries.push_back(q);
    }

    // Errors (after the whole run: a fitted alignment needs every result).
    int with_gt = 0;
    for (const Query& q : queries) with_gt += q.has_gt ? 1 : 0;
    Alignment align;  // identity
    bool errors_valid = with_gt > 0;
    std::string align_note = "none (map frame G = ground-truth frame W)";
    if (errors_valid && !o.align_from_path.empty()) {
      align = ReadAlignmentJson(o.align_from_path);
      align_note = "fixed, from " + o.align_from_path;
      ComputeErrors(align, &queries);
    } else if (errors_valid && o.align != AlignmentType::kNone) {
      if (FitAlignment(o.align, &queries, &align)) {
        const Eigen::Vector3d& t = align.T_G_E.translation();
        std::ostringstream s;
        s << std::fixed << std::setprecision(3) << AlignmentTypeName(o.align)
          << " fitted to the localized positions: translation (" << t.x() << ", " << t.y() << ", "
          << t.z() << ") m, rotation "
          << Eigen::AngleAxisd(align.T_G_E.rotation()).angle() * 180.0 / M_PI << " deg";
        align_note = s.str();
      } else {
        errors_valid = false;
        align_note = "not enough localized queries with ground truth to fit " +
                     std::string(AlignmentTypeName(o.align));
      }
    } else if (errors_valid) {
      ComputeErrors(align, &queries);
    }

    if (!o.quiet) {
      for (const Query& q : queries) {
        out << std::setw(7) << q.frame << std::setw(10) << std::setprecision(3)
            << static_cast<double>(q.t_ns - frames.front().t_ns) * 1e-9 << "  " << std::left
            << std::setw(24) << localizer::LocalizationStatusName(q.status) << std::right
            << std::setw(6) << q.keypoints << std::setw(6) << q.raw_matches << std::setw(6)
            << q.matches << std::setw(5) << q.inliers;
        if (q.has_error && errors_valid) {
          out << std::setw(9) << q.position_error_m << std::setw(9) << std::setprecision(2)
              << q.rotation_error_deg;
        } else {
          out << std::setw(9) << "-" << std::setw(9) << "-";
        }
        out << std::setprecision(1) << std::setw(9) << q.features_ms << std::setw(9)
            << q.localize_ms << "\n";
      }
    }

    // Summary.
    const int n = static_cast<int>(queries.size());
    std::array<int, static_cast<int>(LocalizationStatus::kNumStatuses)> counts{};
    std::vector<double> e_p, e_r, feat_ms, feat_cpu_ms, loc_ms, loc_cpu_ms;
    int ok = 0, within_05 = 0, within_03_2 = 0;
    for (const Query& q : queries) {
      ++counts[static_cast<int>(q.status)];
      feat_ms.push_back(q.features_ms);
      feat_cpu_ms.push_back(q.features_cpu_ms);
      loc_ms.push_back(q.localize_ms);
      loc_cpu_ms.push_back(q.localize_cpu_ms);
      if (q.status == LocalizationStatus::kOk) ++ok;
      if (!q.has_error || !errors_valid) continue;
      e_p.push_back(q.position_error_m);
      e_r.push_back(q.rotation_error_deg);
      if (q.position_error_m <= 0.5) ++within_05;
      if (q.position_error_m <= 0.3 && q.rotation_error_deg <= 2.0) ++within_03_2;
    }
    out << std::setprecision(2) << "summary: " << n << " queries\n  status     ";
    bool first = true;
    for (int s = 0; s < static_cast<int>(LocalizationStatus::kNumStatuses); ++s) {
      if (counts[static_cast<std::size_t>(s)] == 0) continue;
      out << (first ? "" : ", ")
          << localizer::LocalizationStatusName(static_cast<LocalizationStatus>(s)) << " "
          << counts[static_cast<std::size_t>(s)];
      first = false;
    }
    out << "\n  localized  " << Percent(ok, n) << "\n";
    if (with_gt == 0) {
      out << "  errors     none: " << o.dataset << " has no ground truth"
          << " (mav0/state_groundtruth_estimate0/data.csv)\n";
    } else {
      out << "  alignment  " << align_note << "\n";
      if (errors_valid) {
        out << "  recall     within 0.5 m: " << Percent(within_05, with_gt)
            << "; within 0.3 m and 2 deg: " << Percent(within_03_2, with_gt)
            << " (of the queries with ground truth)\n"
            << std::setprecision(3) << "  position   median " << Percentile(e_p, 0.5) << " m, p90 "
            << Percentile(e_p, 0.9) << " m (localized queries)\n"
            << std::setprecision(2) << "  rotation   median " << Percentile(e_r, 0.5)
            << " deg, p90 " << Percentile(e_r, 0.9) << " deg\n";
        if (o.align == AlignmentType::kNone && o.align_from_path.empty() && e_p.size() >= 3 &&
            Percentile(e_p, 0.5) > 1.0) {
          out << "  note       the median error is over 1 m: if MAP was built by VIO (vilma vio\n"
                 "             --save-map), its frame G is that run's odometry frame, not the\n"
                 "             dataset's ground-truth frame: try --align posyaw\n";
        }
      }
    }
    // Wall and thread CPU time: on a loaded machine the difference is waiting for a core.
    out << std::setprecision(1) << "  features   p50 " << Percentile(feat_ms, 0.5) << " ms, p90 "
        << Percentile(feat_ms, 0.9) << " ms wall (CPU p50 " << Percentile(feat_cpu_ms, 0.5)
        << " ms, p90 " << Percentile(feat_cpu_ms, 0.9) << " ms)\n"
        << "  Localize   p50 " << Percentile(loc_ms, 0.5) << " ms, p90 " << Percentile(loc_ms, 0.9)
        << " ms wall (CPU p50 " << Percentile(loc_cpu_ms, 0.5) << " ms, p90 "
        << Percentile(loc_cpu_ms, 0.9) << " ms)\n";
    if (!o.out_path.empty()) {
      WriteFileAtomically(o.out_path, FormatCsv(queries));
      out << "  csv        " << o.out_path << " (" << n << " rows)\n";
    }
    return kExitOk;
  } catch (const std::exception& e) {
    err << "vilma localize: error: " << e.what() << "\n";
    return kExitInputError;
  }
}

}  // namespace vilma::console
