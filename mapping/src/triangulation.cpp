#include "vilma/mapping/triangulation.h"

#include <Eigen/Dense>
#include <algorithm>
#include <cmath>
#include <limits>

namespace vilma::mapping {

const char* TriangulationStatusName(TriangulationStatus status) {
  switch (status) {
    case TriangulationStatus::kOk:
      return "ok";
    case TriangulationStatus::kTooFewObservations:
      return "too_few_observations";
    case TriangulationStatus::kUnprojectFailed:
      return "unproject_failed";
    case TriangulationStatus::kDegenerate:
      return "degenerate";
    case TriangulationStatus::kBehindCamera:
      return "behind_camera";
  }
  return "unknown";
}

const char* LandmarkVerdictName(LandmarkVerdict verdict) {
  switch (verdict) {
    case LandmarkVerdict::kGood:
      return "good";
    case LandmarkVerdict::kTriangulationFailed:
      return "triangulation_failed";
    case LandmarkVerdict::kTooFewObservers:
      return "too_few_observers";
    case LandmarkVerdict::kTooClose:
      return "too_close";
    case LandmarkVerdict::kTooFar:
      return "too_far";
    case LandmarkVerdict::kSmallAngle:
      return "small_angle";
    case LandmarkVerdict::kLargeReprojectionError:
      return "large_reprojection_error";
  }
  return "unknown";
}

TriangulationResult TriangulateLinear(const std::vector<TriangulationObservation>& observations) {
  TriangulationResult result;
  if (observations.size() < 2) return result;
  // Normal equations of sum_k |P_k (p - c_k)|^2, P_k = I - f_k f_k^T (see the header).
  Eigen::Matrix3d A = Eigen::Matrix3d::Zero();
  Eigen::Vector3d b = Eigen::Vector3d::Zero();
  for (const TriangulationObservation& o : observations) {
    Eigen::Vector3d f_C;
    if (o.camera == nullptr || !o.camera->Unproject(o.uv, &f_C)) {
      result.status = TriangulationStatus::kUnprojectFailed;
      return result;
    }
    const Eigen::Vector3d f_M = (o.T_M_C.rotation() * f_C).normalized();
    const Eigen::Matrix3d P = Eigen::Matrix3d::Identity() - f_M * f_M.transpose();
    A += P;
    b += P * o.T_M_C.translation();
  }
  // A is the sum of N projectors: its smallest eigenvalue is ~ N sin^2(angle spread) / 2 and
  // zero for parallel rays. Reject when it is below 1e-8 of the largest (~0.006 deg spread).
  const Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> eig(A);
  const Eigen::Vector3d ev = eig.eigenvalues();
  if (!(ev(0) > 1e-8 * ev(2))) {
    result.status = TriangulationStatus::kDegenerate;
    return result;
  }
  result.p_M = eig.eigenvectors() * (eig.eigenvectors().transpose() * b).cwiseQuotient(ev);
  for (const TriangulationObservation& o : observations) {
    if ((o.T_M_C.inverse() * result.p_M).z() <= 0.0) {
      result.status = TriangulationStatus::kBehindCamera;
      return result;
    }
  }
  result.status = TriangulationStatus::kOk;
  return result;
}

namespace {

// At p_M: the whitened cost sum |r_k|^2 / s_k^2 (the objective), the pixel cost sum |r_k|^2
// (for the RMS error), J^T W J and J^T W r with W = diag(1 / s_k^2); s_k is the observation's
// sigma_px, or default_sigma_px where it is 0. False if p is behind a camera.
bool Linearize(const std::vector<TriangulationObservation>& observations,
               const Eigen::Vector3d& p_M, double default_sigma_px, double* cost,
               double* pixel_cost, Eigen::Matrix3d* H, Eigen::Vector3d* g) {
  *cost = 0.0;
  *pixel_cost = 0.0;
  H->setZero();
  g->setZero();
  for (const TriangulationObservation& o : observations) {
    const Eigen::Matrix3d R_C_M = o.T_M_C.rotation().toRotationMatrix().transpose();
    const Eigen::Vector3d p_C = R_C_M * (p_M - o.T_M_C.translation());
    if (!(p_C.z() > 0.0)) return false;
    Eigen::Vector2d uv;
    Eigen::Matrix<double, 2, 3> J_uv_p_C;
    // Outside the image is fine here: the keypoint was seen, only the estimate moved.
    if (o.camera->Project(p_C, &uv, &J_uv_p_C) == Camera::ProjectionResult::kBehindCamera ||
        !uv.allFinite()) {
      return false;
    }
    const double sigma = o.sigma_px > 0.0 ? o.sigma_px : default_sigma_px;
    const double w = 1.0 / (sigma * sigma);
    const Eigen::Vector2d r = uv - o.uv;
    const Eigen::Matrix<double, 2, 3> J = J_uv_p_C * R_C_M;
    *pixel_cost += r.squaredNorm();
    *cost += w * r.squaredNorm();
    *H += w * J.transpose() * J;
    *g += w * J.transpose() * r;
  }
  return true;
}

}  // namespace

TriangulationResult Triangulate(const std::vector<TriangulationObservation>& observations,
                                const TriangulationOptions& options) {
  TriangulationResult result = TriangulateLinear(observations);
  if (!result.ok()) return result;
  const double s0 = options.keypoint_sigma_px;
  double cost = 0.0, pixel_cost = 0.0;
  Eigen::Matrix3d H;
  Eigen::Vector3d g;
  if (!Linearize(observations, result.p_M, s0, &cost, &pixel_cost, &H, &g)) {
    result.status = TriangulationStatus::kBehindCamera;
    return result;
  }
  // Gauss-Newton: (J^T J) dp = -J^T r; a step that raises the cost is halved (at most 4
  // times) and otherwise ends the iteration, so the result is never worse than the linear one.
  for (int it = 0; it < options.max_iterations; ++it) {
    const Eigen::LDLT<Eigen::Matrix3d> ldlt(H);
    if (ldlt.info() != Eigen::Success) break;
    Eigen::Vector3d dp = ldlt.solve(-g);
    if (!dp.allFinite()) break;
    bool accepted = false;
    double new_cost = 0.0, new_pixel_cost = 0.0;
    Eigen::Matrix3d new_H;
    Eigen::Vector3d new_g;
    for (int halving = 0; halving < 5; ++halving, dp *= 0.5) {
      if (Linearize(observations, result.p_M + dp, s0, &new_cost, &new_pixel_cost, &new_H,
                    &new_g) &&
          new_cost <= cost) {
        accepted = true;
        break;
      }
    }
    if (!accepted) break;
    result.p_M += dp;
    cost = new_cost;
    pixel_cost = new_pixel_cost;
    H = new_H;
    g = new_g;
    result.iterations = it + 1;
    if (dp.norm() < options.convergence_step_m) break;
  }
  result.rms_reprojection_error_px =
      std::sqrt(pixel_cost / static_cast<double>(observations.size()));
  // H is already whitened: covariance (J^T W J)^-1.
  const Eigen::FullPivLU<Eigen::Matrix3d> lu(H);
  if (lu.isInvertible()) result.covariance_M = lu.inverse();
  return result;
}

double MaxObservationAngle(const std::vector<TriangulationObservation>& observations,
                           const Eigen::Vector3d& p_M) {
  // Unit rays from the landmark to each camera centre; the largest pairwise angle. O(N^2) on
  // unit vectors: observations per landmark are tens, not thousands.
  std::vector<Eigen::Vector3d> rays;
  rays.reserve(observations.size());
  for (const TriangulationObservation& o : observations) {
    const Eigen::Vector3d d = o.T_M_C.translation() - p_M;
    if (d.norm() > 0.0) rays.push_back(d.normalized());
  }
  double min_cos = 1.0;
  for (std::size_t i = 0; i < rays.size(); ++i) {
    for (std::size_t j = i + 1; j < rays.size(); ++j) {
      min_cos = std::min(min_cos, rays[i].dot(rays[j]));
    }
  }
  return std::acos(std::clamp(min_cos, -1.0, 1.0));
}

LandmarkVerdict EvaluateLandmarkQuality(const std::vector<TriangulationObservation>& observations,
                                        const TriangulationResult& result,
                                        const LandmarkQualityOptions& options) {
  if (!result.ok()) return LandmarkVerdict::kTriangulationFailed;
  if (static_cast<int>(observations.size()) < options.min_observers) {
    return LandmarkVerdict::kTooFewObservers;
  }
  double closest = std::numeric_limits<double>::infinity();
  for (const TriangulationObservation& o : observations) {
    closest = std::min(closest, (o.T_M_C.translation() - result.p_M).norm());
  }
  if (closest < options.min_distance_m) return LandmarkVerdict::kTooClose;
  if (closest > options.max_distance_m) return LandmarkVerdict::kTooFar;
  const double min_angle = options.min_observation_angle_deg * M_PI / 180.0;
  if (MaxObservationAngle(observations, result.p_M) < min_angle) {
    return LandmarkVerdict::kSmallAngle;
  }
  if (result.rms_reprojection_error_px > options.max_reprojection_error_px) {
    return LandmarkVerdict::kLargeReprojectionError;
  }
  return LandmarkVerdict::kGood;
}

}  // namespace vilma::mapping
