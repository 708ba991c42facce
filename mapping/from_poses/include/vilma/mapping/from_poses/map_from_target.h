// A VI-map from a camera-IMU calibration recording with a known target (target_detections.h;
// docs/optimization.md "Target calibration"), for visual-inertial optimization with the
// target's corners as held landmarks: optvi then estimates the trajectory, the IMU biases, the
// extrinsics T_I_C and the camera time offset (maplab's VIWLS used as Kalibr's batch).
//
//   1. Vertices: one per image of the first rig camera with at least `min_corners` corners
//      whose per-frame PnP (SolveTargetPnp) fits within max_pnp_rmse_px; its time is the image
//      stamp plus camera_time_shift_ns plus the rig camera's time_offset_ns (the IMU clock).
//      Images outside the IMU's time span are skipped.
//      T_T_I = T_T_C · T_I_C⁻¹ with the rig's (optionally perturbed) extrinsics.
//   2. The frame: G = the target frame T (the landmarks are the corners' p_T). The mission
//      frame M must be gravity aligned for the IMU terms: the direction "up" in T is estimated
//      as the mean over the vertices of R_T_I a_I (the specific force; over a long hand-held
//      recording the mean acceleration is ~0, so this is −g's direction up to ~0.1°) and
//      T_G_M = (R_T_M, 0) with R_T_M e_z = up (the shortest rotation). The baseframe is marked
//      unknown: optvi --ba_estimate_baseframe_tilt refines the tilt.
//   3. T_M_I = T_G_M⁻¹ T_T_I; v_M by central differences of the PnP positions (zero where the
//      neighbours are more than 0.2 s apart); biases zero (optvi fits them first).
//   4. Keypoints: every camera's detected corners at the vertex's stamp (no descriptors:
//      descriptor_type "TARGET", size 0); landmarks: one per physical corner (tag id, corner),
//      stored in the first vertex that sees it, quality good; the observations.
//   5. IMU edges between consecutive vertices: the samples interpolated at both vertex times
//      plus the raw ones between (as the map builder makes them).
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include "vilma/core/camera.h"
#include "vilma/core/geometry.h"
#include "vilma/core/rig.h"
#include "vilma/mapping/from_poses/target_detections.h"
#include "vilma/mapstore/vi_map.h"

namespace vilma::mapping {

struct MapFromTargetOptions {
  int min_corners = 12;            // a first-camera image with fewer is skipped
  double max_pnp_rmse_px = 2.0;    // an image whose PnP fits worse is skipped [px]
  int every_nth_image = 1;         // every n-th image of the first camera
  double max_duration_s = 0.0;     // only the first seconds of the recording (0: all)
  // Added to every camera stamp: a known clock offset injected to test its estimate [ns].
  int64_t camera_time_shift_ns = 0;
  // The rig's extrinsics moved by a rigid motion in I (all cameras alike, as a misplaced rig):
  // a translation of this length [m] and a rotation of this angle [deg], directions from seed.
  double perturb_extrinsics_m = 0.0;
  double perturb_extrinsics_deg = 0.0;
  uint64_t seed = 1;
  std::string mission_name = "target";
  std::string Validate() const;
};

struct MapFromTargetSummary {
  int images = 0;                 // of the first camera
  int skipped_few_corners = 0;
  int skipped_pnp = 0;            // PnP failed or fit worse than max_pnp_rmse_px
  int skipped_outside_imu = 0;    // before the first or after the last IMU sample
  int vertices = 0;
  int landmarks = 0;
  int observations = 0;
  int imu_edges = 0;
  double pnp_rmse_median_px = 0.0;
  double gravity_tilt_deg = 0.0;  // angle between the target's z axis and up
  // "ltr: V vertices from I images (S skipped), L held landmarks, O observations, E IMU edges,
  // PnP RMSE median X px".
  std::string BriefReport() const;
  std::string FullReport() const;  // one line per count (what `load_target_recording` prints)
};

// Camera pose T_T_C from target corners by PnP: OpenCV's IPPE (planar targets) on the
// undistorted normalized coordinates, refined by Levenberg-Marquardt; RMSE of the reprojection
// in pixels through `camera`. False with fewer than 4 corners or when undistortion or the
// solution fails.
bool SolveTargetPnp(const Camera& camera, const std::vector<Eigen::Vector2d>& uv,
                    const std::vector<Eigen::Vector3d>& p_T, Transformation* T_T_C,
                    double* rmse_px);

// Reads the recording in `folder` (imu0.csv, one folder per rig camera named as the camera) and
// builds the map. Throws InputError for bad or missing input (naming file, line and field),
// std::invalid_argument for invalid options.
mapstore::VIMap BuildMapFromTarget(const std::string& folder, const SensorRig& rig,
                                   const MapFromTargetOptions& options,
                                   MapFromTargetSummary* summary = nullptr);

// The map's camera trajectory against per-frame PnP on its own observations (the check of a
// target calibration): for each vertex of `mission` with >= min_corners observations of held
// target landmarks in `camera`, T_G_C from the map (T_G_M T_M_I(t + δ) T_I_C, the vertex pose
// carried over the time offset δ as time_offset_residual.h does) against PnP of the same
// keypoints and landmark positions.
struct TargetPnpComparison {
  int frames = 0;
  double position_rms_m = 0.0, rotation_rms_deg = 0.0;
  double position_max_m = 0.0, rotation_max_deg = 0.0;
  double pnp_rmse_median_px = 0.0;

  // "F frames against PnP: position RMS .. mm (max ..), rotation RMS .. deg (max ..); PnP RMSE
  // median .. px" (the console's target report prints it per camera).
  std::string BriefReport() const;
  std::string FullReport() const { return BriefReport() + "\n"; }
};
TargetPnpComparison CompareWithTargetPnp(const mapstore::VIMap& map,
                                         const mapstore::MissionId& mission, uint32_t camera,
                                         double time_offset_s, int min_corners);

}  // namespace vilma::mapping
