// `vilma locmap`: localization summary maps (.vlocmap files, docs/localizer.md "Command line").
//
//   vilma locmap build VIMAP_DIR OUT.vlocmap [--config localizer.yaml]
//   vilma locmap info FILE.vlocmap
//
// `build` loads a VI-map folder, keeps its good landmarks (BuildLocalizationMap, the options'
// `map` section), trains the descriptor projection exactly as the Localizer does at load (the
// `projection` section) and stores it in the file, so that vilma-estimatord and `vilma
// localize` load it without training; the file is written atomically. `info` prints what a
// file holds.
#pragma once

#include <memory>
#include <ostream>
#include <string>
#include <vector>

#include "vilma/console/command.h"
#include "vilma/localizer/localizer.h"

namespace vilma::console {

void PrintLocmapHelp(std::ostream& out);

// The whole command; returns kExitOk, kExitInputError or kExitUsage.
int RunLocmapCommand(const std::vector<std::string>& args, std::ostream& out, std::ostream& err);

// The summary `vilma locmap info` prints (counts, projection, bounding box of p_G, descriptors
// and observers per landmark as min / median / max). `file_bytes` < 0: not printed.
void WriteLocalizationMapInfo(std::ostream& out, const localizer::LocalizationMap& map,
                              long long file_bytes);

}  // namespace vilma::console
