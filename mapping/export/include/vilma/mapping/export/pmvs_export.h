// export_for_pmvs: the map as the input folder of PMVS2 / CMVS (Furukawa and Ponce's patch-based
// multi-view stereo), as Bundler's Bundle2PMVS and RadialUndistort would make it. docs/export.md
// "PMVS2" has the whole mapping:
//
//   visualize/%08d.jpg  one image per camera frame with an image resource, in mission, vertex
//                       time, camera order (index i = 0 .. N-1); undistorted to the pinhole
//                       K = [f 0 cx; 0 f cy; 0 0 1] with f = (fx + fy) / 2 of the rig camera and
//                       (cx, cy) = ((w - 1) / 2, (h - 1) / 2), the image centre, so that
//                       Bundler's camera model (one focal length, principal point at the
//                       centre, here k1 = k2 = 0) describes the images exactly; same size; RGB
//                       (PMVS2 refuses images with fewer than 3 channels; grey stays grey).
//   txt/%08d.txt        "CONTOUR" and the 3x4 matrix P = K [R_C_G | t_C_G]: p_G (homogeneous)
//                       to pixels of the undistorted image, (0, 0) the centre of the top-left
//                       pixel (vilma's and PMVS's convention).
//   bundle.rd.out       Bundler v0.3: per image f, 0, 0, R = diag(1, -1, -1) R_C_G and
//                       t = diag(1, -1, -1) t_C_G (Bundler's camera looks down -z, y up); per
//                       point (landmark of the chosen qualities with at least min_observations
//                       observations in exported images) p_G, the RGB of its first observation's
//                       pixel, and `image keypoint x y` per observation: x = u - (w - 1) / 2,
//                       y = (h - 1) / 2 - v of the undistorted keypoint (centre origin, y up).
//   vis.dat             "VISDATA", N, then per image `i k j1 .. jk`: the images sharing at least
//                       min_covisible_landmarks points with image i.
//   option-0000         PMVS2's options: every image a target image, vis.dat used.
//   models/             empty; PMVS2 writes option-0000.ply and .patch there.
//
// Run: `pmvs2 DIR/ option-0000` (the trailing slash matters).
#pragma once

#include <cstddef>
#include <string>
#include <vector>

#include "vilma/core/progress.h"
#include "vilma/mapstore/vi_map.h"

namespace vilma::mapping {

struct PmvsExportOptions {
  // The folder to make (PMVS2's root): must not exist or be empty. Written as <out>.partial
  // and renamed into place when complete, so a failure leaves no half folder.
  std::string out;
  // Landmark qualities that become bundle.rd.out points: good, unknown, bad (comma separated).
  std::string landmarks = "good";
  // Points need this many observations in exported images (after dropping those that cannot
  // be undistorted or lie behind the camera).
  int min_observations = 2;
  // vis.dat: two images are neighbours when they share at least this many points.
  int min_covisible_landmarks = 10;
  int jpeg_quality = 95;  // visualize/*.jpg, 1 .. 100
  int threads = 2;        // option-0000 "CPU"
  // Missions to export; empty: every mission.
  std::vector<mapstore::MissionId> missions;

  // "field: expectation", or "" when valid.
  std::string Validate() const;
};

struct PmvsExportSummary {
  std::string folder;
  std::size_t images = 0;                // visualize/, txt/, bundle.rd.out cameras
  std::size_t frames_without_image = 0;  // camera frames of exported missions left out
  std::size_t points = 0;
  std::size_t observations = 0;  // view-list entries over all points
  std::size_t landmarks_skipped_quality = 0;
  std::size_t landmarks_skipped_track = 0;  // fewer than min_observations observations left
  // Observations in exported images left out: the keypoint cannot be undistorted, the
  // landmark is behind the camera, or a second observation of the point in one image.
  // (Observations from frames without an image are not counted.)
  std::size_t observations_dropped = 0;
  std::size_t vis_pairs = 0;                  // neighbour pairs (i < j) in vis.dat
  std::size_t images_without_neighbours = 0;  // vis.dat lines `i 0`
  // Points re-projected through P against their undistorted keypoints.
  double mean_reprojection_error_px = 0.0;
  double max_reprojection_error_px = 0.0;
  std::string BriefReport() const;  // one line: counts and where it went
  std::string FullReport() const;   // the brief line and the details (what the command prints)
};

// Writes the PMVS2 folder. InputError for invalid options, a mission not in the map or
// without a rig, no camera frame with an image in the exported missions, an unreadable image
// resource, an existing non-empty `out` (or a stale `out.partial`), or a folder that cannot be
// written. Cancelled (progress): nothing is left behind.
PmvsExportSummary ExportPmvs(const mapstore::VIMap& map, const PmvsExportOptions& options,
                             ProgressObserver* progress = nullptr);

}  // namespace vilma::mapping
