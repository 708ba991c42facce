#include "vilma/console/kitti_command.h"

#include <exception>

#include "vilma/core/error.h"
#include "vilma/eval/localization/kitti_localization.h"

namespace vilma::console {
void PrintKittiHelp(std::ostream& out) {
  out << "usage: vilma localize-kitti KITTI_DIR [--config LOCALIZER.yaml]\n"
         "                            [--features FEATURES.yaml | --indoor-features]\n"
         "\n"
         "Real-image localization check on a KITTI odometry stereo slice (calib.txt,\n"
         "poses.txt, image_l/, image_r/; e.g. ../shared/data/kitti_slices/KITTI_sequence_1):\n"
         "a map is built from the EVEN frames only (BRISK keypoints stereo-matched along the\n"
         "rows, triangulated in the left camera, placed with the ground-truth poses, merged\n"
         "with the previous even frame's landmarks), then every ODD left image is localized\n"
         "against it (descriptor index, covisibility, P3P RANSAC). Prints one row per query\n"
         "and the recall within 0.3 m and 2 deg, median errors and timings.\n"
         "\n"
         "options:\n"
         "  --config FILE       localizer options (config/localizer.yaml format; default:\n"
         "                      its built-in defaults)\n"
         "  --features FILE     keyframe feature options (strict, every key; default: the\n"
         "                      KITTI profile, 16x4 grid, 2000 keypoints, 3 pyramid levels)\n"
         "  --indoor-features   use the 752x480 indoor default feature options instead\n"
         "  -h, --help          this text\n"
         "\n"
         "exit codes: 0 ok (whatever the recall), 1 input error, 2 usage error\n";
}

int RunKittiCommand(const std::vector<std::string>& args, std::ostream& out, std::ostream& err) {
  try {
    std::string directory, config_path, features_path;
    bool indoor = false;
    for (ArgCursor arg(args); arg.Next();) {
      const std::string& a = arg.name();
      if (a == "--help" || a == "-h") {
        arg.Flag();  // "--help=x" is a usage error
        PrintKittiHelp(out);
        return kExitOk;
      } else if (a == "--config") {
        config_path = arg.Value();
      } else if (a == "--features") {
        features_path = arg.Value();
      } else if (a == "--indoor-features") {
        indoor = arg.Flag();
      } else if (arg.is_option()) {
        throw UsageError("unknown option " + arg.word());
      } else if (directory.empty()) {
        directory = a;
      } else {
        throw UsageError("unexpected argument " + a);
      }
    }
    if (directory.empty()) throw UsageError("missing KITTI_DIR");
    if (indoor && !features_path.empty()) {
      throw UsageError("--features and --indoor-features exclude each other");
    }
    eval::KittiLocalizationOptions options;
    if (!config_path.empty()) options.localizer = localizer::LoadLocalizerOptions(config_path);
    if (!features_path.empty()) {
      options.features = localizer::LoadKeyframeFeatureOptions(features_path);
    } else if (indoor) {
      options.features = localizer::KeyframeFeatureOptions();
    }
    const eval::KittiSequence sequence = eval::LoadKittiSequence(directory);
    out << "KITTI " << directory << ": " << sequence.size() << " frames, "
        << sequence.camera.width() << "x" << sequence.camera.height() << ", fx "
        << sequence.camera.fx() << " px, baseline " << sequence.baseline_m << " m\n";
    const eval::KittiLocalizationReport report =
        eval::EvaluateKittiLocalization(sequence, options);
    out << report.FullReport();
    return kExitOk;
  } catch (const UsageError& e) {
    err << "vilma localize-kitti: " << e.what() << "\n\n";
    PrintKittiHelp(err);
    return kExitUsage;
  } catch (const std::exception& e) {
    err << "vilma localize-kitti: error: " << e.what() << "\n";
    return kExitInputError;
  }
}

}  // namespace vilma::console
