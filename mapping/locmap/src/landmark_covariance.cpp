#include "vilma/mapping/locmap/landmark_covariance.h"

#include <Eigen/Dense>
#include <algorithm>
#include <cmath>

namespace vilma::mapping {

bool ObservationResidual(const mapstore::VIMap& map, const mapstore::LandmarkObservation& obs,
                         const Eigen::Vector3d& p_G, Eigen::Vector2d* residual_px,
                         Eigen::Matrix<double, 2, 3>* d_r_d_p_G) {
  const mapstore::Vertex& v = map.vertex(obs.vertex_id);
  const SensorRig& rig = map.mission(v.mission_id).rig;
  if (obs.camera >= rig.cameras.size() || obs.camera >= v.frames.size() ||
      obs.keypoint >= v.frames[obs.camera].keypoints.size()) {
    return false;
  }
  const CameraConfig& camera = rig.cameras[obs.camera];
  const Transformation T_G_C = map.T_G_I(obs.vertex_id) * camera.T_I_C;
  const Eigen::Matrix3d R_C_G = T_G_C.rotation().toRotationMatrix().transpose();
  const Eigen::Vector3d p_C = R_C_G * (p_G - T_G_C.translation());
  Eigen::Vector2d uv;
  Eigen::Matrix<double, 2, 3> J_uv_p_C;
  if (camera.camera.Project(p_C, &uv, &J_uv_p_C) != Camera::ProjectionResult::kValid) return false;
  *residual_px = uv - v.frames[obs.camera].keypoints[obs.keypoint].uv;
  if (d_r_d_p_G != nullptr) *d_r_d_p_G = J_uv_p_C * R_C_G;
  return residual_px->allFinite();
}

KeypointNoiseEstimate EstimateKeypointNoise(
    const mapstore::VIMap& map,
    const std::vector<std::vector<const mapstore::LandmarkObservation*>>& observations,
    const std::vector<Eigen::Vector3d>& p_G) {
  KeypointNoiseEstimate e;
  std::vector<double> scaled;  // |r|^2 2N / (2N - 3): E = 2 sigma^2 per observation
  std::vector<double> r2;
  for (std::size_t l = 0; l < observations.size(); ++l) {
    r2.clear();
    for (const mapstore::LandmarkObservation* obs : observations[l]) {
      Eigen::Vector2d r;
      if (ObservationResidual(map, *obs, p_G[l], &r, nullptr)) r2.push_back(r.squaredNorm());
    }
    if (r2.size() < 2) continue;
    const double n = static_cast<double>(r2.size());
    for (double x : r2) scaled.push_back(x * 2.0 * n / (2.0 * n - 3.0));
    ++e.landmarks;
  }
  e.observations = static_cast<int>(scaled.size());
  if (scaled.empty()) return e;
  const auto mid = scaled.begin() + static_cast<std::ptrdiff_t>(scaled.size() / 2);
  std::nth_element(scaled.begin(), mid, scaled.end());
  // |r|^2 / sigma^2 ~ chi^2_2, whose median is 2 ln 2.
  e.sigma_px = std::sqrt(*mid / (2.0 * std::log(2.0)));
  return e;
}

bool TriangulationCovariance_G(const mapstore::VIMap& map,
                               const std::vector<const mapstore::LandmarkObservation*>& observations,
                               const Eigen::Vector3d& p_G, double sigma_px,
                               Eigen::Matrix3d* covariance_G) {
  Eigen::Matrix3d information = Eigen::Matrix3d::Zero();
  int used = 0;
  for (const mapstore::LandmarkObservation* obs : observations) {
    Eigen::Vector2d r;
    Eigen::Matrix<double, 2, 3> J;
    if (!ObservationResidual(map, *obs, p_G, &r, &J)) continue;
    information += J.transpose() * J;
    ++used;
  }
  if (used < 2) return false;
  const Eigen::FullPivLU<Eigen::Matrix3d> lu(information);
  if (!lu.isInvertible()) return false;
  *covariance_G = sigma_px * sigma_px * lu.inverse();
  *covariance_G = 0.5 * (*covariance_G + covariance_G->transpose()).eval();
  return covariance_G->allFinite();
}

}  // namespace vilma::mapping
