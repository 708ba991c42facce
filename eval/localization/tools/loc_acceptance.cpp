// vilma-loc-acceptance: precision and recall of the localizer's acceptance on real and simulated
// data (docs/localizer.md, "Acceptance"; scripts/bench-localizer-acceptance.sh runs it on every
// data set). Two kinds of input:
//   kitti KITTI_DIR: the hard cases of kitti_scenarios.h built from one KITTI stereo slice;
//   asl DATASET MAP.vlocmap: frames of an ASL/EuRoC dataset with ground truth (G = W) against a
//     ground-truth map, optionally perturbed like the KITTI cases.
// Prints a markdown row per data set (with --header the table's header first) and, with
// --queries, one line per query.
#include <algorithm>
#include <exception>
#include <filesystem>
#include <iomanip>
#include <iostream>
#include <memory>
#include <opencv2/core/utility.hpp>
#include <sstream>
#include <string>
#include <vector>

#include "vilma/core/arg_cursor.h"
#include "vilma/core/asl_dataset.h"
#include "vilma/core/error.h"
#include "vilma/core/rig.h"
#include "vilma/eval/localization/acceptance_eval.h"
#include "vilma/eval/localization/kitti_scenarios.h"
#include "vilma/eval/localization/residual_calibration.h"
#include "vilma/localizer/feature_options.h"
#include "vilma/localizer/keyframe_features.h"
#include "vilma/localizer/localization_map.h"
#include "vilma/mapping/evaluation/map_evaluation.h"

namespace {

using namespace vilma;
using namespace vilma::localizer;
using namespace vilma::eval;
namespace fs = std::filesystem;

constexpr int kExitOk = 0, kExitInput = 1, kExitUsage = 2;

void PrintHelp(std::ostream& out) {
  out << "usage: vilma-loc-acceptance kitti KITTI_DIR [--scenario NAME]... [--kitti-map MODE]\n"
         "                            [--perturbation-seed N] [common options]\n"
         "       vilma-loc-acceptance header   (the table's header only)\n"
         "       vilma-loc-acceptance landmarks MAP.vlocmap SIM_DATASET\n"
         "       vilma-loc-acceptance asl DATASET MAP.vlocmap [--name NAME] [--every N]\n"
         "                            [--first N] [--camera C] [--rig RIG.yaml]\n"
         "                            [--swap F] [--max-keypoints N] [--box X0,Y0,X1,Y1]\n"
         "                            [--features FEATURES.yaml] [common options]\n"
         "\n"
         "Acceptance benchmark of the localizer: every query has ground truth; an accepted\n"
         "pose (status ok) beyond 0.3 m or 2 deg is WRONG; a query is 'possible' when at\n"
         "least 12 of its matches reproject within 4 px under the ground truth (a correct\n"
         "answer was in the data). Prints a markdown row per data set: queries, possible,\n"
         "accepted, accepted wrong, recall = accepted correct / possible, median error,\n"
         "rejection reasons (docs/localizer.md, \"Acceptance\").\n"
         "\n"
         "kitti: scenarios of one KITTI stereo slice (map built with the ground-truth poses,\n"
         "  as 'vilma localize-kitti'): even-odd, sparse-map, other-part, swapped-50,\n"
         "  swapped-80, few-keypoints, corner, far-landmarks, repeated, repeated-third\n"
         "  (default: all). --kitti-map: the map's stereo points: 'subpixel' (default;\n"
         "  sub-pixel disparity, the nearest view's point), 'tracks' (sub-pixel, landmarks of\n"
         "  several map frames triangulated from all their views) or 'integer' (the\n"
         "  keypoints' disparity, the nearest view's point: the maps before 2026-11-27).\n"
         "  --perturbation-seed N: added to every scenario's query-perturbation seed (other\n"
         "  swapped descriptors; default 0).\n"
         "asl: every Nth frame (--every, default 1) from --first (default 0) of camera C of an\n"
         "  ASL dataset against a .vlocmap whose frame G is the ground truth's W\n"
         "  (vilma-locmap-gt, or 'vilma map-from-poses' + 'vilma locmap build'), with the\n"
         "  query features of vilma-estimatord. Query perturbations: --swap F (this share of\n"
         "  the descriptors swapped between keypoints), --max-keypoints N (the N best),\n"
         "  --box X0,Y0,X1,Y1 (keypoints inside this box, fractions of width and height).\n"
         "  --features FILE: other query features (strict, like config/keyframe_features.yaml;\n"
         "  default: vilma-estimatord's query profile, config/localization_features.yaml).\n"
         "\n"
         "landmarks: the map's landmark covariances against the simulator's true surfaces\n"
         "  (SIM_DATASET's sim.yaml; map in the world frame, e.g. vilma-locmap-gt's): the\n"
         "  landmarks' distances d to their surface along its normal n, whitened by\n"
         "  n^T Sigma_l n: chi2/dof (1 when calibrated), median chi2 (0.455), RMS d and sigma.\n"
         "  The residual column of the asl/kitti rows (right poses: chi2/dof of the inlier\n"
         "  residuals, fitted keypoint sigma and landmark-covariance scale) is the same check\n"
         "  on real data.\n"
         "\n"
         "common options:\n"
         "  --config FILE   localizer options (config/localizer.yaml format; default: built-in)\n"
         "  --name NAME     the data set's name in the table (asl; default: DATASET's folder)\n"
         "  --header        print the table header first\n"
         "  --queries       one line per query before the row: every gate's value (all of\n"
         "                  them with acceptance.measure_all_gates: true in --config) and\n"
         "                  the error of the judged pose, accepted or not\n"
         "  --inliers FRAME if query FRAME is accepted: its position error in the camera\n"
         "                  frame and one line per inlier and per match that agrees with\n"
         "                  the ground truth (errors under both poses, depth, observers,\n"
         "                  landmark sigma), before the row (repeatable)\n"
         "  -h, --help      this text\n"
         "\n"
         "exit codes: 0 ok (whatever the figures), 1 input error, 2 usage error\n";
}

struct Args {
  std::string mode, input, map, name, config, rig, features;
  std::vector<std::string> scenarios;
  int every = 1, first = 0, camera = 0;
  QueryPerturbation perturbation;
  bool header = false, queries = false, help = false;
  std::vector<int> inlier_frames;      // --inliers: match records of these frames when accepted
  std::string kitti_map = "subpixel";  // --kitti-map: integer, subpixel or tracks
  uint64_t perturbation_seed = 0;      // --perturbation-seed: added to the scenarios' seeds
};

Args Parse(const std::vector<std::string>& argv) {
  Args a;
  std::vector<std::string> positional;
  for (ArgCursor arg(argv); arg.Next();) {
    const std::string& n = arg.name();
    if (n == "-h" || n == "--help") {
      a.help = true;
    } else if (n == "--scenario") {
      a.scenarios.push_back(arg.Value());
    } else if (n == "--config") {
      a.config = arg.Value();
    } else if (n == "--rig") {
      a.rig = arg.Value();
    } else if (n == "--features") {
      a.features = arg.Value();
    } else if (n == "--name") {
      a.name = arg.Value();
    } else if (n == "--every") {
      a.every = arg.IntValue(1);
    } else if (n == "--first") {
      a.first = arg.IntValue(0);
    } else if (n == "--camera") {
      a.camera = arg.IntValue(0);
    } else if (n == "--swap") {
      a.perturbation.swap_fraction = arg.DoubleValue();
    } else if (n == "--max-keypoints") {
      a.perturbation.max_keypoints = arg.IntValue(0);
    } else if (n == "--box") {
      const std::string v = arg.Value();
      std::istringstream in(v);
      char c1 = 0, c2 = 0, c3 = 0;
      QueryPerturbation& p = a.perturbation;
      if (!(in >> p.box_min_x >> c1 >> p.box_min_y >> c2 >> p.box_max_x >> c3 >> p.box_max_y) ||
          c1 != ',' || c2 != ',' || c3 != ',' || !in.eof()) {
        throw UsageError("--box: expected X0,Y0,X1,Y1 (fractions), got '" + v + "'");
      }
    } else if (n == "--header") {
      a.header = true;
    } else if (n == "--queries") {
      a.queries = true;
    } else if (n == "--kitti-map") {
      a.kitti_map = arg.Value();
      if (a.kitti_map != "integer" && a.kitti_map != "subpixel" && a.kitti_map != "tracks") {
        throw UsageError("--kitti-map: expected integer, subpixel or tracks, got '" + a.kitti_map +
                         "'");
      }
    } else if (n == "--perturbation-seed") {
      a.perturbation_seed = static_cast<uint64_t>(arg.IntValue(0));
    } else if (n == "--inliers") {
      a.inlier_frames.push_back(arg.IntValue(0));
    } else if (arg.is_option()) {
      throw UsageError("unknown option '" + n + "'");
    } else {
      positional.push_back(arg.word());
    }
  }
  if (a.help) return a;
  if (positional.empty()) throw UsageError("expected 'kitti', 'asl', 'landmarks' or 'header'");
  a.mode = positional[0];
  if (a.mode == "header") {
    if (positional.size() != 1) throw UsageError("header: no arguments");
    return a;
  }
  if (a.mode == "landmarks") {
    if (positional.size() != 3) throw UsageError("landmarks: expected MAP.vlocmap and SIM_DATASET");
    a.map = positional[1];
    a.input = positional[2];
    return a;
  }
  const std::string error = a.perturbation.Validate();
  if (!error.empty()) throw UsageError("query perturbation: " + error);
  if (a.mode == "kitti") {
    if (positional.size() != 2) throw UsageError("kitti: expected one KITTI_DIR");
    if (!a.perturbation.IsIdentity() || a.every != 1 || a.first != 0 || !a.rig.empty() ||
        !a.features.empty()) {
      throw UsageError(
          "kitti: --swap/--max-keypoints/--box/--every/--first/--rig/--features are for asl "
          "(the scenarios define their own)");
    }
    a.input = positional[1];
  } else if (a.mode == "asl") {
    if (positional.size() != 3) throw UsageError("asl: expected DATASET and MAP.vlocmap");
    if (!a.scenarios.empty()) throw UsageError("asl: --scenario is for kitti");
    if (a.kitti_map != "subpixel" || a.perturbation_seed != 0) {
      throw UsageError("asl: --kitti-map and --perturbation-seed are for kitti");
    }
    a.input = positional[1];
    a.map = positional[2];
  } else {
    throw UsageError("expected 'kitti', 'asl', 'landmarks' or 'header', got '" + a.mode + "'");
  }
  return a;
}

// Ground truth T_W_I at t: the sample at t, else interpolated between samples at most 60 ms
// apart (the 20 Hz ground truth of the EuRoC slices has gaps of 50.0001 ms).
bool GroundTruthAt(const std::vector<GroundTruthState>& gt, int64_t t, Transformation* T_W_I) {
  const auto it = std::lower_bound(
      gt.begin(), gt.end(), t, [](const GroundTruthState& g, int64_t tt) { return g.t_ns < tt; });
  if (it == gt.end()) return false;
  if (it->t_ns == t) {
    *T_W_I = Transformation(it->q_W_I, it->p_W_I);
    return true;
  }
  if (it == gt.begin() || it->t_ns - (it - 1)->t_ns > 60'000'000) return false;
  const GroundTruthState& a = *(it - 1);
  const double s = static_cast<double>(t - a.t_ns) / static_cast<double>(it->t_ns - a.t_ns);
  *T_W_I = Interpolate(Transformation(a.q_W_I, a.p_W_I), Transformation(it->q_W_I, it->p_W_I), s);
  return true;
}

void WriteRequestedRecords(const Args& a, const std::vector<AcceptanceQuery>& queries,
                           std::ostream& out) {
  for (const AcceptanceQuery& q : queries) {
    if (q.accepted && std::find(a.inlier_frames.begin(), a.inlier_frames.end(), q.frame) !=
                          a.inlier_frames.end()) {
      WriteMatchRecords(out, q);
    }
  }
}

void RunKitti(const Args& a, const LocalizerOptions& options, std::ostream& out) {
  const KittiSequence seq = LoadKittiSequence(a.input);
  KittiLocalizationOptions kitti;
  kitti.localizer = options;
  kitti.refine_disparity = a.kitti_map != "integer";
  kitti.triangulate_tracks = a.kitti_map == "tracks";
  const std::vector<KittiScenario> all = KittiScenarios(static_cast<int>(seq.size()));
  std::vector<KittiScenario> chosen;
  for (const std::string& name : a.scenarios) {
    const auto it = std::find_if(all.begin(), all.end(),
                                 [&](const KittiScenario& s) { return s.name == name; });
    if (it == all.end()) throw UsageError("--scenario: unknown scenario '" + name + "'");
    chosen.push_back(*it);
  }
  if (chosen.empty()) chosen = all;
  for (KittiScenario& s : chosen) s.perturbation.seed += a.perturbation_seed;
  if (a.header) WriteAcceptanceHeader(out);
  for (const KittiScenario& s : chosen) {
    const std::vector<AcceptanceQuery> q = RunKittiScenario(seq, kitti, s, AcceptanceGates());
    if (a.queries) {
      out << "\n" << s.name << ": " << s.description << "\n";
      WriteAcceptanceQueries(out, q);
    }
    WriteRequestedRecords(a, q, out);
    WriteAcceptanceRow(out, SummarizeAcceptance("kitti " + s.name, q));
    out.flush();
  }
}

void RunAsl(const Args& a, const LocalizerOptions& options, std::ostream& out) {
  // The query features first: a bad --features file fails before any data is read.
  const KeyframeFeatureOptions features = a.features.empty()
                                              ? LocalizationQueryFeatureOptions()
                                              : LoadKeyframeFeatureOptions(a.features);
  std::error_code ec;
  if (!fs::is_directory(a.input, ec)) {
    throw InputError(FormatInputError(a.input, "DATASET", "an ASL dataset folder"));
  }
  std::string rig_source = a.rig;
  SensorRig rig;
  if (!a.rig.empty()) {
    rig = LoadSensorRig(a.rig);
  } else if (fs::exists(fs::path(a.input) / "rig.yaml", ec)) {
    rig_source = (fs::path(a.input) / "rig.yaml").string();
    rig = LoadSensorRig(rig_source);
  } else {
    rig_source = a.input + " (EuRoC sensor.yaml)";
    rig = ImportEurocRig(a.input);
  }
  const AslDataset dataset = AslDataset::Open(a.input);
  const std::size_t cam = static_cast<std::size_t>(a.camera);
  if (cam >= dataset.cameras().size() || cam >= rig.cameras.size()) {
    throw InputError(FormatInputError(a.input, "cam" + std::to_string(a.camera),
                                      "a camera of the dataset and of the rig " + rig_source));
  }
  if (dataset.ground_truth().empty()) {
    throw InputError(FormatInputError(a.input, "state_groundtruth_estimate0/data.csv",
                                      "ground truth (the benchmark judges every query)"));
  }
  const Camera& camera = rig.cameras[cam].camera;
  const Transformation& T_I_C = rig.cameras[cam].T_I_C;
  const auto map = std::make_shared<const LocalizationMap>(LoadLocalizationMap(a.map));
  const Localizer localizer(map, options);
  const FeatureExtractor extractor(features);
  const auto& frames = dataset.cameras()[cam].frames;
  std::vector<AcceptanceQuery> queries;
  for (std::size_t i = static_cast<std::size_t>(a.first); i < frames.size();
       i += static_cast<std::size_t>(a.every)) {
    Transformation T_W_I;
    if (!GroundTruthAt(dataset.ground_truth(), frames[i].t_ns + rig.cameras[cam].time_offset_ns,
                       &T_W_I)) {
      continue;  // no ground truth: cannot be judged
    }
    const cv::Mat image = AslDataset::LoadImage(frames[i].image_path);
    const KeyframeFeatures f = extractor.Extract(image);
    std::vector<Eigen::Vector2d> uv;
    for (const cv::KeyPoint& k : f.keypoints) uv.emplace_back(k.pt.x, k.pt.y);
    std::vector<uint8_t> descriptors;
    if (f.size() > 0) {
      descriptors.assign(f.descriptors.ptr<uint8_t>(),
                         f.descriptors.ptr<uint8_t>() + f.descriptors.total());
    }
    QueryPerturbation p = a.perturbation;
    p.seed += i;
    PerturbQuery(p, camera, &uv, &descriptors, f.descriptors.cols);
    AcceptanceQuery q = EvaluateAcceptanceQuery(localizer, camera, T_I_C, uv, descriptors, T_W_I,
                                                AcceptanceGates());
    q.frame = static_cast<int>(i);
    queries.push_back(q);
  }
  const std::string name = a.name.empty() ? fs::path(a.input).filename().string() : a.name;
  if (a.header) WriteAcceptanceHeader(out);
  if (a.queries) {
    out << "\n" << name << "\n";
    WriteAcceptanceQueries(out, queries);
  }
  WriteRequestedRecords(a, queries, out);
  WriteAcceptanceRow(out, SummarizeAcceptance(name, queries));
}

void RunLandmarks(const Args& a, std::ostream& out) {
  sim::World world;
  if (!mapping::LoadDatasetWorld(a.input, &world)) {
    throw InputError(FormatInputError(a.input, "sim.yaml", "a dataset made by vilma-sim"));
  }
  const LocalizationMap map = LoadLocalizationMap(a.map);
  if (map.p_G_covariance.empty()) {
    throw InputError(FormatInputError(a.map, "landmark covariances", "a map that carries them"));
  }
  const LandmarkSurfaceCheck c = CheckLandmarksAgainstWorld(map, world);
  out << std::fixed << std::setprecision(3) << "landmarks " << c.landmarks << " of "
      << map.num_landmarks() << "  chi2/dof " << c.chi2_per_dof << "  median chi2 " << c.median_chi2
      << " (0.455 if calibrated)  rms distance " << std::setprecision(4) << c.rms_distance_m
      << " m  rms sigma " << c.rms_sigma_m << " m\n";
}

}  // namespace

int main(int argc, char** argv) {
  const std::vector<std::string> argv_list(argv + 1, argv + argc);
  Args a;
  try {
    a = Parse(argv_list);
  } catch (const UsageError& e) {
    std::cerr << "vilma-loc-acceptance: " << e.what() << "\n(see vilma-loc-acceptance --help)\n";
    return kExitUsage;
  }
  if (a.help) {
    PrintHelp(std::cout);
    return kExitOk;
  }
  try {
    cv::setNumThreads(1);  // deterministic, one core
    const LocalizerOptions options =
        a.config.empty() ? LocalizerOptions() : LoadLocalizerOptions(a.config);
    if (a.mode == "header") {
      WriteAcceptanceHeader(std::cout);
    } else if (a.mode == "landmarks") {
      RunLandmarks(a, std::cout);
    } else if (a.mode == "kitti") {
      RunKitti(a, options, std::cout);
    } else {
      RunAsl(a, options, std::cout);
    }
    return kExitOk;
  } catch (const UsageError& e) {
    std::cerr << "vilma-loc-acceptance: " << e.what() << "\n(see vilma-loc-acceptance --help)\n";
    return kExitUsage;
  } catch (const std::exception& e) {
    std::cerr << "vilma-loc-acceptance: error: " << e.what() << "\n";
    return kExitInput;
  }
}
