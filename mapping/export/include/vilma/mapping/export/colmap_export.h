// export_colmap: the map as a COLMAP sparse model in COLMAP's text format (COLMAP 3.8 docs,
// "Output Format": cameras.txt, images.txt, points3D.txt), which `colmap model_analyzer`,
// `colmap gui --import_path`, `colmap image_undistorter` / `patch_match_stereo` (dense MVS),
// NeRF and Gaussian-splatting tools read. docs/export.md "COLMAP" has the whole mapping:
//
//   cameras.txt   one camera per (mission, rig camera), ids from 1:
//                 radtan -> OPENCV fx fy cx cy k1 k2 p1 p2; equidistant -> OPENCV_FISHEYE
//                 fx fy cx cy k1 k2 k3 k4; no distortion -> PINHOLE fx fy cx cy; or, with
//                 camera_model "pinhole", every camera as the undistorted PINHOLE of
//                 Camera::UndistortedPinhole(alpha) with undistorted keypoints and images.
//   images.txt    one image per (vertex, camera), ids from 1 in mission, time, camera order;
//                 QW QX QY QZ TX TY TZ of T_C_G = (T_G_M T_M_I T_I_C)^-1 (world to camera, the
//                 COLMAP convention; world = vilma's G); NAME <vertex id>_cam<k>.png;
//                 POINTS2D: every keypoint of the frame, in keypoint order (POINT2D_IDX is the
//                 keypoint index), with its POINT3D_ID or -1.
//   points3D.txt  one point per exported landmark (qualities as asked, at least
//                 min_track_length observations from exported images), ids from 1: p_G, RGB
//                 (the image's pixel at the first observation when images are written, else
//                 the mission colour), ERROR = mean reprojection error [px] over the track,
//                 TRACK = (IMAGE_ID, POINT2D_IDX) per observation.
//   images/       <vertex id>_cam<k>.png for every frame with an image resource (undistorted
//                 for camera_model "pinhole").
//
// Pixel convention: vilma puts (0, 0) at the centre of the top-left pixel, COLMAP at its
// top-left corner (the centre is (0.5, 0.5)); cx, cy and every keypoint get +0.5.
#pragma once

#include <cstddef>
#include <string>
#include <vector>

#include "vilma/core/progress.h"
#include "vilma/mapstore/vi_map.h"

namespace vilma::mapping {

struct ColmapExportOptions {
  // The model folder (created): cameras.txt, images.txt, points3D.txt and images/.
  std::string out;
  // "auto": the camera's own model (OPENCV, OPENCV_FISHEYE or PINHOLE) with the keypoints as
  // measured; "pinhole": undistorted PINHOLE cameras, keypoints and images.
  std::string camera_model = "auto";
  // For "pinhole": 0 keeps only valid pixels, 1 keeps every source pixel (OpenCV's alpha).
  double undistort_alpha = 0.0;
  bool images = true;  // write images/ where the map has image resources
  // Landmark qualities that become points: good, unknown, bad (comma separated).
  std::string landmarks = "good";
  // Landmarks seen from fewer exported images than this are left out (COLMAP needs 2 to
  // triangulate; 1 is allowed for inspection).
  int min_track_length = 2;
  // Missions to export; empty: every mission. Tracks keep only observations from exported
  // missions.
  std::vector<mapstore::MissionId> missions;

  // "field: expectation", or "" when valid.
  std::string Validate() const;
};

struct ColmapExportSummary {
  std::string folder;
  std::size_t cameras = 0;
  std::size_t images = 0;
  std::size_t image_files = 0;  // images written into images/
  std::size_t points = 0;
  std::size_t observations = 0;  // track elements over all points
  std::size_t keypoints = 0;     // POINTS2D entries over all images
  std::size_t landmarks_skipped_quality = 0;
  std::size_t landmarks_skipped_track = 0;  // fewer than min_track_length observations left
  // Observations left out of tracks: the landmark is behind the camera, or (pinhole) the
  // keypoint cannot be undistorted.
  std::size_t observations_dropped = 0;
  double mean_reprojection_error_px = 0.0;  // over all track elements
  double max_reprojection_error_px = 0.0;
  std::vector<std::string> camera_models;  // per COLMAP camera, e.g. "OPENCV"
  std::string BriefReport() const;  // one line: counts and where it went
  std::string FullReport() const;   // the brief line and the details (what the command prints)
};

// Writes the model: images first (each atomically), then the three text files (each
// atomically), so a model folder with points3D.txt is complete. InputError for invalid
// options, a mission not in the map or without a rig, a camera model COLMAP has no equivalent
// for, an unreadable image resource or an unwritable folder. Cancelled: some images may be
// written, no text file.
ColmapExportSummary ExportColmap(const mapstore::VIMap& map, const ColmapExportOptions& options,
                                 ProgressObserver* progress = nullptr);

}  // namespace vilma::mapping
