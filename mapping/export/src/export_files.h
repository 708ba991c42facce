// Private helpers of the data exports (trajectory, calibration, CSV, PLY, COLMAP): where the
// files go, which missions are exported, and fixed-format numbers. docs/export.md "Output
// paths" describes the naming rules implemented here.
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include "vilma/mapstore/vi_map.h"

namespace vilma::mapping::export_files {

// The missions to export: `selected` (each must exist in the map; InputError naming the id
// otherwise) or, when empty, every mission in map order. InputError when the map has none.
std::vector<mapstore::MissionId> MissionsToExport(const mapstore::VIMap& map,
                                                  const std::vector<mapstore::MissionId>& selected,
                                                  const std::string& flag);

// Creates `folder` and its parents. InputError "--FLAG: PATH: expected a folder that can be
// created (REASON)" when that fails (a path under a regular file, no permission, ...).
void CreateFolder(const std::string& folder, const std::string& flag);

// True when `out` names a folder: it exists as one, or ends with '/'.
bool IsFolderPath(const std::string& out);

// One output file per mission (docs/export.md "Output paths"):
//   one mission:   OUT itself, or OUT/<base><ext> when OUT is a folder;
//   several:       OUT/<base>_<mission id><ext> when OUT is a folder, else
//                  <OUT without extension>_<mission id><OUT's extension, or ext if none>.
// The folder that will hold the files is created. InputError naming `flag` when OUT is empty.
std::vector<std::string> PerMissionFiles(const std::string& out, const std::string& flag,
                                         const std::vector<mapstore::MissionId>& missions,
                                         const std::string& base, const std::string& ext);

// One output file for the whole export: OUT, or OUT/<default_name> when OUT is a folder. Its
// folder is created.
std::string SingleFile(const std::string& out, const std::string& flag,
                       const std::string& default_name);

// Fixed-point text of `value` with `decimals` digits after the point ("nan"/"inf" as printf).
std::string Fixed(double value, int decimals);
// Shortest text that reads back to the same double ("%.17g" trimmed by round trip).
std::string Exact(double value);
// Seconds with nanosecond resolution, exactly: 1403636579.763555584 for that many ns.
std::string SecondsFromNs(int64_t t_ns);

}  // namespace vilma::mapping::export_files
