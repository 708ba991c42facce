// export_landmarks_ply: landmark positions in the global frame G as a PLY point cloud
// (Turk's Stanford format, binary little-endian or ASCII) that MeshLab, CloudCompare, Open3D
// and Blender open. Each point carries a colour (by mission, in plot_map's mission colours, or
// by quality) and three extra properties readers may use or ignore:
//
//   element vertex N
//   property double x, y, z          p_G [m]
//   property uchar red, green, blue  colour
//   property uchar quality           0 unknown, 1 bad, 2 good (mapstore::LandmarkQuality)
//   property ushort mission          index into the "comment mission <i> <id> <name>" lines
//   property uint observations       number of observations of the landmark
//
// The header's comments say the frame, the colouring and each mission's baseframe state.
#pragma once

#include <array>
#include <cstddef>
#include <cstdint>
#include <string>
#include <vector>

#include "vilma/core/progress.h"
#include "vilma/mapstore/vi_map.h"

namespace vilma::mapping {

struct PlyExportOptions {
  // A .ply file, or a folder (existing, or ending in '/'): landmarks.ply in it.
  std::string out;
  std::string color_by = "mission";  // mission | quality
  bool good_only = false;            // only landmarks of quality good
  bool binary = true;                // binary_little_endian (false: ascii)
  // Missions whose landmarks are exported (landmarks stored in their vertices); empty: all.
  std::vector<mapstore::MissionId> missions;

  // "field: expectation", or "" when valid.
  std::string Validate() const;
};

struct PlyExportSummary {
  std::string path;
  std::size_t points = 0;
  std::size_t skipped_not_good = 0;  // left out by good_only
  std::size_t missions = 0;
  std::size_t bytes = 0;
  std::string BriefReport() const;  // one line: counts and where it went
  std::string FullReport() const;   // the brief line and the details (what the command prints)
};

// Colours (RGB) of landmark qualities: unknown grey, bad red, good green.
std::array<uint8_t, 3> LandmarkQualityColorRgb(mapstore::LandmarkQuality quality);

// The PLY file's bytes.
std::string MakeLandmarksPly(const mapstore::VIMap& map, const PlyExportOptions& options,
                             PlyExportSummary* summary, ProgressObserver* progress = nullptr);

// Writes the PLY atomically. InputError for invalid options, a mission not in the map or an
// unwritable path; Cancelled leaves nothing written.
PlyExportSummary ExportLandmarksPly(const mapstore::VIMap& map, const PlyExportOptions& options,
                                    ProgressObserver* progress = nullptr);

}  // namespace vilma::mapping
