// Helpers for tests that use files: the shared real-data slices and temporary folders.
#pragma once

#include <catch2/catch.hpp>
#include <cstdlib>
#include <filesystem>
#include <random>
#include <string>

#include "test_skip.h"

namespace vilma::testing {

// ../shared/data (VILMA_SHARED_DATA_DIR), or "" when absent.
inline std::string SharedDataDir() {
  const std::filesystem::path dir(VILMA_SHARED_DATA_DIR);
  return std::filesystem::is_directory(dir) ? dir.string() : std::string();
}

inline std::string EurocMicroDir() {
  const std::string shared = SharedDataDir();
  return shared.empty() ? shared : shared + "/euroc_V1_01_micro";
}

// Where scripts/make-datasets.sh writes the simulated benchmark sets: $VILMA_CACHE/datasets, else
// $HOME/.cache/vilma/datasets (the same rule as the script). Tests that use them skip when absent.
inline std::string SimulatedDatasetsDir() {
  if (const char* cache = std::getenv("VILMA_CACHE"); cache != nullptr && *cache != '\0') {
    return std::string(cache) + "/datasets";
  }
  const char* home = std::getenv("HOME");
  return std::string(home != nullptr ? home : "") + "/.cache/vilma/datasets";
}

// A fresh, empty temporary folder removed when the object goes out of scope.
class TempDir {
 public:
  TempDir() {
    std::random_device rd;
    path_ = std::filesystem::temp_directory_path() /
            ("vilma_test_" + std::to_string(rd()) + std::to_string(rd()));
    std::filesystem::create_directories(path_);
  }
  ~TempDir() {
    std::error_code ec;
    std::filesystem::remove_all(path_, ec);
  }
  TempDir(const TempDir&) = delete;
  TempDir& operator=(const TempDir&) = delete;
  std::string path() const { return path_.string(); }
  std::string File(const std::string& name) const { return (path_ / name).string(); }

 private:
  std::filesystem::path path_;
};

}  // namespace vilma::testing

// Skips the rest of a test (VILMA_SKIP: reported as skipped) when the shared data is not there.
#define VILMA_REQUIRE_SHARED_DATA(dir)                                                \
  do {                                                                                \
    if ((dir).empty()) {                                                              \
      VILMA_SKIP("../shared/data not found (set VILMA_SHARED_DATA_DIR at cmake)");    \
    }                                                                                 \
  } while (0)
