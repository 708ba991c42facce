// Attaching the camera images of an ASL / EuRoC dataset to a map's vertices (the console's
// `attach_images`, docs/dense.md "Images in maps"): for every vertex of the selected missions
// and every camera i of its mission's rig (dataset camera i = mav0/cam<i>, in name order), the
// dataset image nearest to the vertex's camera time t_cam = t_vertex - time_offset_ns(i) (the
// rig's t_imu = t_cam + offset) within a tolerance, stored losslessly as a PNG image resource
// (8-bit grey stays grey) under mapping::ImageResourceId(vertex, camera), the id the map
// builder's keep_images gives (deterministic: the same dataset and map give the same ids).
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include "vilma/core/progress.h"
#include "vilma/mapstore/vi_map.h"

namespace vilma::mapping {

struct ImageAttachmentOptions {
  std::string dataset;  // ASL folder (containing mav0/, or mav0 itself)
  // An image is a vertex camera's when its stamp is at most this far from the vertex's camera
  // time [s] (default 1 ms: a 20 Hz camera's neighbours are 50 ms away).
  double max_time_difference_s = 0.001;
  // Frames that already have an image: replace it (keeping its id, so no resource is orphaned)
  // or leave it as it is (default).
  bool overwrite = false;
  // Empty if valid, else "field: expectation".
  std::string Validate() const;
};

struct ImageAttachmentSummary {
  int64_t missions = 0;
  int64_t vertices = 0;
  int64_t frames = 0;                  // vertex cameras considered
  int64_t attached = 0;                // new images
  int64_t replaced = 0;                // overwrite: images replaced
  int64_t skipped_existing = 0;        // not overwrite: frames that already had an image
  int64_t missing = 0;                 // no dataset image within the tolerance
  int64_t png_bytes = 0;               // of the attached and replaced images
  double max_time_difference_s = 0.0;  // largest |t_image - t_cam| of those images [s]
  // Problems that did not stop the command (the dataset loader's, unused dataset cameras).
  std::vector<std::string> warnings;
  // Several lines: counts, then one line per warning.
  std::string BriefReport() const;  // one line: counts, sizes, time differences
  std::string FullReport() const;   // the brief line, then one line per warning
};

// Attaches the images to the vertices of `missions` (empty: every mission). Reads and encodes
// every image first, then assigns them, so that an error or a cancel (ReportProgress) leaves
// `map` unchanged. Throws InputError naming the dataset when it cannot be read, has fewer
// cameras than a mission's rig, or no vertex of the missions has an image within the
// tolerance; std::invalid_argument for invalid options.
ImageAttachmentSummary AttachImages(const ImageAttachmentOptions& options,
                                    const std::vector<mapstore::MissionId>& missions,
                                    mapstore::VIMap* map, ProgressObserver* progress = nullptr);

}  // namespace vilma::mapping
