// Runs Debian's COLMAP (`colmap model_analyzer`) on an exported model for the export tests and
// the console's export command tests. Tests skip (VILMA_SKIP, tests/test_skip.h) when colmap
// is absent.
#pragma once

#include <unistd.h>

#include <catch2/catch.hpp>
#include <cstdlib>
#include <filesystem>
#include <map>
#include <string>

#include "integration/process_util.h"
#include "mapping_export/data_export_test_util.h"
#include "test_skip.h"

namespace vilma::mapping::testing {

// The colmap executable on PATH, or "" when there is none.
inline std::string FindColmap() {
  const char* path = std::getenv("PATH");
  for (const std::string& dir : Split(path ? path : "", ':')) {
    const std::filesystem::path candidate = std::filesystem::path(dir) / "colmap";
    if (!dir.empty() && ::access(candidate.c_str(), X_OK) == 0) return candidate.string();
  }
  return "";
}

// `colmap model_analyzer --path DIR`'s figures by name ("Cameras", "Images", "Registered
// images", "Points", "Observations", "Mean track length", "Mean reprojection error", ...).
inline std::map<std::string, double> ModelAnalyzer(const std::string& colmap,
                                                   const std::string& dir) {
  const std::string log = dir + ".model_analyzer.out";
  test::ChildProcess analyzer({colmap, "model_analyzer", "--path", dir}, log);
  REQUIRE(analyzer.Wait(120.0) == 0);
  std::map<std::string, double> counts;
  for (const std::string& line : ReadLines(log)) {
    const std::size_t colon = line.find(": ");
    if (colon == std::string::npos) continue;
    std::string number = line.substr(colon + 2);
    if (number.size() > 2 && number.compare(number.size() - 2, 2, "px") == 0) {
      number.resize(number.size() - 2);
    }
    double value;
    if (ParseNumber(number, &value)) counts[line.substr(0, colon)] = value;
  }
  return counts;
}

}  // namespace vilma::mapping::testing
