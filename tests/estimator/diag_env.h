// The environment and the common setup of the hidden VIO diagnostics ("[.diagnostic]" in
// vio_consistency_sim_test.cpp and vio_tracking_truth_sim_test.cpp; docs/estimator.md):
// VILMA_DIAG_SETS (comma-separated set names), VILMA_DIAG_MODES ("mono", "stereo" or both),
// VILMA_DIAG_CONFIG (a filter options YAML; default the built-in profile "default"),
// VILMA_DIAG_OUT (CSV folder; default ~/.cache/vilma/diag), VILMA_DIAG_DATASETS (the folder of
// the sets; default ~/.cache/vilma/datasets).
#pragma once

#include <cstdlib>
#include <filesystem>
#include <sstream>
#include <string>
#include <vector>

#include "vilma/estimator/filter_options.h"
#include "vilma/estimator/vio_pipeline.h"

namespace vilma::estimator::diag {

// The variable's value, or `fallback` when it is unset or empty.
inline std::string EnvOr(const char* name, const std::string& fallback) {
  const char* v = std::getenv(name);
  return v != nullptr && *v != '\0' ? std::string(v) : fallback;
}

inline std::filesystem::path CacheDir() {
  return std::filesystem::path(EnvOr("HOME", "/")) / ".cache/vilma";
}

// VILMA_DIAG_SETS split at commas (default `fallback`).
inline std::vector<std::string> SetNames(const std::string& fallback) {
  std::vector<std::string> names;
  std::stringstream s(EnvOr("VILMA_DIAG_SETS", fallback));
  for (std::string name; std::getline(s, name, ',');) names.push_back(name);
  return names;
}

// Whether VILMA_DIAG_MODES (default `fallback`) asks for the mono or the stereo run.
inline bool WantsMode(bool stereo, const std::string& fallback) {
  return EnvOr("VILMA_DIAG_MODES", fallback).find(stereo ? "stereo" : "mono") != std::string::npos;
}

inline std::filesystem::path DatasetDir(const std::string& name) {
  return std::filesystem::path(
             EnvOr("VILMA_DIAG_DATASETS", (CacheDir() / "datasets").string())) /
         name;
}

// VILMA_DIAG_OUT (default ~/.cache/vilma/diag), created.
inline std::filesystem::path OutDir() {
  const std::filesystem::path out = EnvOr("VILMA_DIAG_OUT", (CacheDir() / "diag").string());
  std::filesystem::create_directories(out);
  return out;
}

// The filter options named by VILMA_DIAG_CONFIG, else the profile `vilma vio` uses on the
// simulated sets.
inline FilterOptions Options() {
  const std::string config = EnvOr("VILMA_DIAG_CONFIG", "");
  return config.empty() ? FilterOptionsProfile("default") : LoadFilterOptions(config);
}

// `vilma vio`'s pipeline on camera 0, with the stereo camera of `options` when `stereo`.
inline VioPipelineOptions PipelineOptions(FilterOptions options, bool stereo) {
  options.stereo.enabled = stereo;
  VioPipelineOptions po;
  po.vio_camera = 0;
  po.filter = options;
  po.cameras = stereo ? std::vector<int>{0, options.stereo.camera} : std::vector<int>{0};
  return po;
}

}  // namespace vilma::estimator::diag
