// vilma-locmap-gt: a localization map of an ASL dataset (e.g. a vilma-sim session) built by the
// map builder driven by the dataset's GROUND-TRUTH states, so that G = the dataset's world frame
// W (eval/localization/ground_truth_map.h). For tests and benchmarks of LOC mode
// (docs/daemon.md "Localization"): localization errors are then errors against ground truth,
// without any alignment.
#include <iostream>
#include <string>
#include <vector>

#include "vilma/core/arg_cursor.h"
#include "vilma/core/error.h"
#include "vilma/eval/localization/ground_truth_map.h"

namespace {

void Usage(std::ostream& out) {
  out << "usage: vilma-locmap-gt DATASET OUT.vlocmap [--seconds S] [--camera C]\n"
         "                       [--map-config MAP_BUILDER.yaml]\n"
         "Builds a localization map from DATASET (ASL folder with rig.yaml and ground truth):\n"
         "map-builder vertices with the ground-truth states (G = the dataset's world frame),\n"
         "keyframe features of camera C (default 0), the first S seconds (default: all);\n"
         "--map-config: the map builder's options (default: config/map_builder.yaml's values).\n"
         "Exit codes: 0 ok, 1 input error or a map without landmarks, 2 usage error.\n";
}

}  // namespace

int main(int argc, char** argv) {
  using namespace vilma;
  std::string dataset, out;
  eval::GroundTruthMapOptions options;
  std::string map_config;
  const std::vector<std::string> args(argv + 1, argv + argc);  // ArgCursor keeps a reference
  try {
    for (ArgCursor arg(args); arg.Next();) {
      const std::string& a = arg.name();
      if (a == "--help" || a == "-h") {
        Usage(std::cout);
        return 0;
      } else if (a == "--seconds") {
        options.seconds = arg.DoubleValue();
      } else if (a == "--camera") {
        options.camera = arg.IntValue(0);
      } else if (a == "--map-config") {
        map_config = arg.Value();
      } else if (arg.is_option()) {
        throw UsageError("unknown option '" + a + "'");
      } else if (dataset.empty()) {
        dataset = a;
      } else if (out.empty()) {
        out = a;
      } else {
        throw UsageError("unexpected argument '" + a + "' (one DATASET and one OUT.vlocmap)");
      }
    }
    if (dataset.empty() || out.empty()) throw UsageError("expected DATASET and OUT.vlocmap");
    if (!(options.seconds > 0.0)) throw UsageError("--seconds: expected a duration > 0");
  } catch (const UsageError& e) {
    std::cerr << "vilma-locmap-gt: " << e.what() << "\n";
    Usage(std::cerr);
    return 2;
  }
  try {
    if (!map_config.empty()) options.map_builder = mapping::LoadMapBuilderOptions(map_config);
    const eval::GroundTruthMapSummary summary =
        eval::BuildGroundTruthLocalizationMap(dataset, options);
    localizer::SaveLocalizationMap(summary.map, out);
    std::cout << "vilma-locmap-gt: " << summary.BriefReport() << " -> " << out << "\n";
    return summary.map.num_landmarks() > 0 ? 0 : 1;
  } catch (const std::exception& e) {
    std::cerr << "vilma-locmap-gt: error: " << e.what() << "\n";
    return 1;
  }
}
