#include "export_files.h"

#include <cinttypes>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <system_error>

#include "vilma/core/error.h"

namespace vilma::mapping::export_files {

namespace fs = std::filesystem;
using mapstore::MissionId;

std::vector<MissionId> MissionsToExport(const mapstore::VIMap& map,
                                        const std::vector<MissionId>& selected,
                                        const std::string& flag) {
  if (map.mission_ids().empty()) {
    throw InputError(FormatInputError("map", "missions", "expected at least one mission"));
  }
  if (selected.empty()) return map.mission_ids();
  std::vector<MissionId> missions;
  for (const MissionId& id : selected) {
    if (!map.HasMission(id)) {
      throw InputError(FormatInputError(
          "--" + flag, "",
          "expected a mission of the map, found " + id.Hex() + " (not in the map)"));
    }
    bool seen = false;
    for (const MissionId& m : missions) seen = seen || m == id;
    if (!seen) missions.push_back(id);
  }
  return missions;
}

void CreateFolder(const std::string& folder, const std::string& flag) {
  std::error_code error;
  if (fs::is_directory(folder, error)) return;
  fs::create_directories(folder, error);
  if (error || !fs::is_directory(folder)) {
    throw InputError(FormatInputError(
        "--" + flag, folder,
        "expected a folder that exists or can be created (" +
            (error ? error.message() : std::string("a file of that name exists")) + ")"));
  }
}

bool IsFolderPath(const std::string& out) {
  std::error_code error;
  return (!out.empty() && out.back() == '/') || fs::is_directory(out, error);
}

namespace {

void RequireOut(const std::string& out, const std::string& flag) {
  if (out.empty()) throw InputError(FormatInputError("--" + flag, "", "expected a path"));
}

std::string ParentOrDot(const fs::path& path) {
  return path.has_parent_path() ? path.parent_path().string() : std::string(".");
}

}  // namespace

std::vector<std::string> PerMissionFiles(const std::string& out, const std::string& flag,
                                         const std::vector<MissionId>& missions,
                                         const std::string& base, const std::string& ext) {
  RequireOut(out, flag);
  std::vector<std::string> files;
  if (IsFolderPath(out)) {
    CreateFolder(out, flag);
    for (const MissionId& id : missions) {
      const std::string name = missions.size() == 1 ? base + ext : base + "_" + id.Hex() + ext;
      files.push_back((fs::path(out) / name).string());
    }
    return files;
  }
  const fs::path path(out);
  CreateFolder(ParentOrDot(path), flag);
  if (missions.size() == 1) return {out};
  const std::string extension = path.has_extension() ? path.extension().string() : ext;
  const fs::path stem = path.parent_path() / path.stem();
  for (const MissionId& id : missions) files.push_back(stem.string() + "_" + id.Hex() + extension);
  return files;
}

std::string SingleFile(const std::string& out, const std::string& flag,
                       const std::string& default_name) {
  RequireOut(out, flag);
  if (IsFolderPath(out)) {
    CreateFolder(out, flag);
    return (fs::path(out) / default_name).string();
  }
  CreateFolder(ParentOrDot(fs::path(out)), flag);
  return out;
}

std::string Fixed(double value, int decimals) {
  char buf[64];
  std::snprintf(buf, sizeof(buf), "%.*f", decimals, value);
  return buf;
}

std::string Exact(double value) {
  char buf[64];
  for (int precision = 15; precision <= 17; ++precision) {
    std::snprintf(buf, sizeof(buf), "%.*g", precision, value);
    if (std::strtod(buf, nullptr) == value || !std::isfinite(value)) break;
  }
  return buf;
}

std::string SecondsFromNs(int64_t t_ns) {
  const bool negative = t_ns < 0;
  // Magnitude as unsigned so that INT64_MIN has one too.
  const uint64_t magnitude =
      negative ? static_cast<uint64_t>(-(t_ns + 1)) + 1 : static_cast<uint64_t>(t_ns);
  char buf[48];
  std::snprintf(buf, sizeof(buf), "%s%" PRIu64 ".%09" PRIu64, negative ? "-" : "",
                magnitude / uint64_t{1000000000}, magnitude % uint64_t{1000000000});
  return buf;
}

}  // namespace vilma::mapping::export_files
