// Depth images of an RGB-D dataset in the TUM layout (depth.txt: "timestamp filename" lines,
// '#' comments; depth/*.png: 16-bit, depth_scale_factor units per metre, 5000 in TUM's sets; 0 =
// no depth) attached to a map's vertices as depth resources (docs/dense.md). The depth must be
// registered to one camera of the rig (TUM's depth is registered to the RGB camera): it is
// stored for that camera, undistorted onto its distortion-free pinhole when the camera has
// distortion.
#pragma once

#include <string>
#include <vector>

#include "vilma/core/progress.h"
#include "vilma/mapstore/vi_map.h"

namespace vilma::mapping {

struct TumDepthImportOptions {
  std::string dataset;          // folder with depth.txt and depth/
  int camera = 0;               // rig camera the depth is registered to
  double depth_scale_factor = 5000.0;   // stored value per metre
  double max_time_difference_s = 0.02;  // a vertex takes the nearest depth image within this
  double depth_unit_m = 0.001;          // quantization of the stored depth
  bool overwrite = false;               // replace depth maps the frames already have
  std::string Validate() const;
};

struct TumDepthImportSummary {
  int depth_images = 0;       // listed in depth.txt
  int vertices = 0;           // of the selected missions
  int attached = 0;
  int no_image_in_time = 0;   // vertices without a depth image within max_time_difference_s
  int skipped_existing = 0;
  std::string BriefReport() const;
  std::string FullReport() const;  // the brief report as a line (what the command prints)
};

// Throws InputError naming file and line for a malformed depth.txt or image, and when no
// vertex gets a depth image (the map unchanged then); Cancelled through `progress`.
TumDepthImportSummary ImportTumDepth(mapstore::VIMap* map,
                                     const std::vector<mapstore::MissionId>& missions,
                                     const TumDepthImportOptions& options,
                                     ProgressObserver* progress = nullptr);

}  // namespace vilma::mapping
