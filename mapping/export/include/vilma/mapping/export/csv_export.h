// csv_export (maplab's `csv_export --csv_export_path`): the map as CSV files with one header
// row each, for Python, Matlab or a spreadsheet. Unlike maplab (a folder per mission) every
// file holds all exported missions, with mission ids as columns, so that cross-mission
// observations need no join across folders. Columns, units and frames: docs/export.md "CSV".
//
//   missions.csv      one row per mission: baseframe T_G_M, counts
//   vertices.csv      one row per vertex: t, T_G_I and T_M_I, v_M, biases, keypoint counts
//   edges.csv         one row per edge: type, vertices, IMU sample count and time span,
//                     T_A_B (loop closure, odometry, pose prior), switch variable
//   landmarks.csv     one row per landmark: p_G and p_M, quality, covariance in G, observers
//   observations.csv  one row per landmark observation: landmark, vertex, camera, keypoint, u, v
//   keypoints.csv     (optional) one row per keypoint: uv, scale, orientation, score, track,
//                     landmark — maplab's tracks.csv
//   descriptors.csv   (optional) one row per keypoint: descriptor type and bytes as hex
//   imu.csv           (optional) one row per IMU sample of every IMU edge
//
// Ids are maplab-style 32 hex digits; a missing id (keypoint without landmark) is empty.
// Doubles are written with enough digits to read back exactly (%.17g shortest round trip).
#pragma once

#include <cstddef>
#include <map>
#include <string>
#include <vector>

#include "vilma/core/progress.h"
#include "vilma/mapstore/vi_map.h"

namespace vilma::mapping {

struct CsvExportOptions {
  // The folder to write into (created; existing files of these names are replaced).
  std::string out;
  bool keypoints = true;     // keypoints.csv
  bool descriptors = false;  // descriptors.csv (64 bytes per BRISK keypoint: large)
  bool imu = false;          // imu.csv
  // Missions to export; empty: every mission. Landmarks are those stored in the exported
  // missions; observations only those made from exported vertices (every id in the files
  // resolves within the export).
  std::vector<mapstore::MissionId> missions;

  // "field: expectation", or "" when valid.
  std::string Validate() const;
};

struct CsvExportSummary {
  std::string folder;
  // Data rows (without the header) per file name, e.g. rows["vertices.csv"].
  std::map<std::string, std::size_t> rows;
  std::size_t bytes = 0;
  std::string BriefReport() const;  // one line: counts and where it went
  std::string FullReport() const;   // the brief line and the details (what the command prints)
};

// The files' texts by name (what ExportCsv writes), for tests and other writers.
std::map<std::string, std::string> MakeCsvFiles(const mapstore::VIMap& map,
                                                const CsvExportOptions& options,
                                                CsvExportSummary* summary,
                                                ProgressObserver* progress = nullptr);

// Makes every file's text, then writes each atomically into options.out. Bad input (invalid
// options, a mission not in the map, an unwritable folder) throws InputError before anything is
// written; so does Cancelled.
CsvExportSummary ExportCsv(const mapstore::VIMap& map, const CsvExportOptions& options,
                           ProgressObserver* progress = nullptr);

}  // namespace vilma::mapping
