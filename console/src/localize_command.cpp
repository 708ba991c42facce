#include "vilma/console/localize_command.h"
#include "vilma/console/eval_command.h"

#include <exception>
#include <filesystem>
#include <iomanip>
#include <opencv2/core/utility.hpp>

#include "vilma/core/asl_dataset.h"
#include "vilma/core/error.h"
#include "vilma/core/atomic_file.h"
#include "vilma/core/rig.h"
#include "vilma/eval/localization/dataset_localization.h"
#include "vilma/localizer/keyframe_features.h"
#include "vilma/localizer/localizer.h"
#include "vilma/mapping/locmap/localization_map_file.h"

namespace vilma::console {
namespace {

namespace fs = std::filesystem;

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
    eval::DatasetLocalizationOptions check;
    check.every = o.every;
    check.camera = o.camera;
    check.align = o.align;
    check.align_from_path = o.align_from_path;
    ThrowIfInvalid(check.Validate(), "command line", "");
    eval::CheckDatasetCamera(o.dataset, dataset, rig, rig_source, o.camera);

    const mapping::OpenedLocalizationMap opened =
        mapping::OpenLocalizationMap(o.map, options.map, "MAP");
    const std::string map_description = opened.BriefReport();
    const std::shared_ptr<const localizer::LocalizationMap> map = opened.map;
    const bool stored_projection = map->projection.rows() > 0;
    const localizer::Localizer loc(map, options);
    const localizer::FeatureExtractor extractor(features);
    const std::size_t num_frames = dataset.cameras()[static_cast<std::size_t>(o.camera)].frames.size();

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
        << num_frames << "\n";
    const eval::DatasetLocalizationSummary summary =
        eval::LocalizeDataset(o.dataset, dataset, rig, rig_source, extractor, loc, check);
    if (!o.quiet) out << summary.QueryTable();
    out << summary.FullReport();
    if (!o.out_path.empty()) {
      WriteFileAtomically(o.out_path, summary.Csv());
      out << "  csv        " << o.out_path << " (" << summary.queries << " rows)\n";
    }
    return kExitOk;
  } catch (const std::exception& e) {
    err << "vilma localize: error: " << e.what() << "\n";
    return kExitInputError;
  }
}

}  // namespace vilma::console
