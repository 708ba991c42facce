#include "vi_problem_util.h"

#include <algorithm>
#include <cmath>
#include <stdexcept>

#include "vilma/mapping/optimization/pose_manifold.h"
#include "vilma/mapping/optimization/time_offset_residual.h"

namespace vilma::mapping::vi_problem {

double SecondsSince(std::chrono::steady_clock::time_point start) {
  return std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
}

double PixelError(const Observation& o) {
  const Transformation T_G_C =
      BlockToPose(o.pose_G_M) * BlockToPose(o.pose_M_I) * BlockToPose(o.pose_I_C);
  const Eigen::Vector3d p_C =
      o.time_offset == nullptr
          ? Eigen::Vector3d(T_G_C.inverse() * Eigen::Map<const Eigen::Vector3d>(o.p_G))
          : TimeOffsetReprojectionCostFunction::PointInCamera(o.pose_M_I, o.speed_bias, o.p_G,
                                                              o.pose_G_M, o.pose_I_C,
                                                              o.time_offset[0], o.omega_m_I);
  Eigen::Vector2d uv;
  const Camera::ProjectionResult r = o.camera->Project(p_C, &uv);
  if (r == Camera::ProjectionResult::kBehindCamera || r == Camera::ProjectionResult::kNotFinite ||
      !uv.allFinite()) {
    return -1.0;
  }
  return (uv - o.uv).norm();
}

double RmsePx(const std::vector<Observation>& observations) {
  double sum = 0.0;
  std::size_t n = 0;
  for (const Observation& o : observations) {
    if (o.residual == nullptr) continue;
    const double e = PixelError(o);
    if (e < 0) continue;
    sum += e * e;
    ++n;
  }
  return n == 0 ? 0.0 : std::sqrt(sum / static_cast<double>(n));
}

void Clusters::Join(int a, int b) {
  a = Find(a);
  b = Find(b);
  if (a != b) parent[std::max(a, b)] = std::min(a, b);
}

ceres::CallbackReturnType CancelCallback::operator()(const ceres::IterationSummary& summary) {
  radius = summary.trust_region_radius;
  if (progress_ != nullptr && progress_->CancelRequested()) {
    cancelled = true;
    return ceres::SOLVER_ABORT;
  }
  return ceres::SOLVER_CONTINUE;
}

MissionChange ChangeOf(
    const mapstore::VIMap& map, const mapstore::MissionId& m,
    const std::unordered_map<mapstore::VertexId, Transformation, mapstore::IdHash>& T_G_I_before) {
  MissionChange c;
  c.mission = m;
  double sum_shift = 0.0, sum_rotation = 0.0;
  for (const mapstore::VertexId& v : map.vertex_ids(m)) {
    const Transformation& before = T_G_I_before.at(v);
    const Transformation after = map.T_G_I(v);
    const double shift = (after.translation() - before.translation()).norm();
    const double rotation = AngleBetween(after.rotation(), before.rotation()) * 180.0 / M_PI;
    sum_shift += shift;
    sum_rotation += rotation;
    c.max_shift_m = std::max(c.max_shift_m, shift);
    c.max_rotation_deg = std::max(c.max_rotation_deg, rotation);
    ++c.vertices;
  }
  if (c.vertices > 0) {
    c.mean_shift_m = sum_shift / static_cast<double>(c.vertices);
    c.mean_rotation_deg = sum_rotation / static_cast<double>(c.vertices);
  }
  return c;
}

void CheckFinite(const mapstore::VIMap& map, const mapstore::VertexId& id) {
  const mapstore::Vertex& v = map.vertex(id);
  if (!v.T_M_I.translation().allFinite() || !v.T_M_I.rotation().coeffs().allFinite() ||
      !v.v_M.allFinite() || !v.gyro_bias.allFinite() || !v.accel_bias.allFinite()) {
    throw std::invalid_argument("vertex " + id.Hex() + ": a state that is not finite (NaN/inf)");
  }
}

}  // namespace vilma::mapping::vi_problem
