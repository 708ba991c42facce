// Landmark triangulation from N calibrated observations and maplab's landmark quality rules
// (docs/mapping.md, "Triangulation" and "Landmark quality").
//
// Linear step (midpoint of N rays): camera k at centre c_k sees the landmark along the unit
// bearing f_k (in M). The point p minimizing the sum of squared distances to the rays,
//   sum_k |(I - f_k f_k^T)(p - c_k)|^2,
// solves  (sum_k P_k) p = sum_k P_k c_k  with the projectors P_k = I - f_k f_k^T; the system is
// singular when all rays are parallel (no parallax).
// Refinement: Gauss-Newton on the pixel residuals r_k = pi_k(R_C_M,k (p - c_k)) - uv_k with
// J_k = d pi / d p_C * R_C_M,k (core/camera.h gives d pi / d p_C), so the result is the maximum
// likelihood point under isotropic pixel noise. Each residual is weighted by 1 / sigma_k^2, the
// observation's keypoint noise (its sigma_px, else options.keypoint_sigma_px); covariance
// (sum J_k^T J_k / sigma_k^2)^-1, i.e. sigma_px^2 (sum J_k^T J_k)^-1 for equal noise.
#pragma once

#include <Eigen/Core>
#include <vector>

#include "vilma/core/camera.h"
#include "vilma/core/geometry.h"
#include "vilma/mapping/map_builder_options.h"

namespace vilma::mapping {

// One observation: the pixel `uv` seen by `camera` at pose T_M_C.
struct TriangulationObservation {
  Transformation T_M_C;
  const Camera* camera = nullptr;
  Eigen::Vector2d uv = Eigen::Vector2d::Zero();  // [px], distorted image
  // Keypoint noise of uv [px] (mapstore::Keypoint::sigma_px); 0: the options' keypoint_sigma_px.
  double sigma_px = 0.0;
};

enum class TriangulationStatus {
  kOk,
  kTooFewObservations,  // fewer than 2
  kUnprojectFailed,     // a keypoint whose undistortion does not converge
  kDegenerate,          // rays (nearly) parallel: the linear system is singular
  kBehindCamera,        // the point lies behind an observing camera
};
const char* TriangulationStatusName(TriangulationStatus status);

struct TriangulationResult {
  TriangulationStatus status = TriangulationStatus::kTooFewObservations;
  Eigen::Vector3d p_M = Eigen::Vector3d::Zero();           // [m]
  Eigen::Matrix3d covariance_M = Eigen::Matrix3d::Zero();  // of p_M [m^2]
  int iterations = 0;                                      // Gauss-Newton iterations done
  double rms_reprojection_error_px = 0.0;                  // at p_M [px]
  bool ok() const { return status == TriangulationStatus::kOk; }
};

// Linear (midpoint) solution only: status kOk and p_M, nothing else filled.
TriangulationResult TriangulateLinear(const std::vector<TriangulationObservation>& observations);
// Linear solution refined by Gauss-Newton (options.max_iterations), with covariance and error.
TriangulationResult Triangulate(const std::vector<TriangulationObservation>& observations,
                                const TriangulationOptions& options);

enum class LandmarkVerdict {
  kGood,
  kTriangulationFailed,
  kTooFewObservers,
  kTooClose,
  kTooFar,
  kSmallAngle,
  kLargeReprojectionError,
};
constexpr int kNumLandmarkVerdicts = 7;
const char* LandmarkVerdictName(LandmarkVerdict verdict);

// The elq rules in this order: triangulation ok, observers, distance to the closest observing
// camera (min, max), largest observation angle, RMS reprojection error. The first failing rule
// is returned. `observations` are those `result` was computed from.
LandmarkVerdict EvaluateLandmarkQuality(const std::vector<TriangulationObservation>& observations,
                                        const TriangulationResult& result,
                                        const LandmarkQualityOptions& options);

// Largest angle between two observation rays c_k -> p (at p) [rad]; 0 for < 2 observations.
double MaxObservationAngle(const std::vector<TriangulationObservation>& observations,
                           const Eigen::Vector3d& p_M);

}  // namespace vilma::mapping
