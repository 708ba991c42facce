// Pieces of the visual-inertial problem (vi_optimization.cpp) that stand on their own: the
// observation record and its pixel error, mission clusters, the cancel callback, input checks.
// Private to mapping/optimization.
#pragma once

#include <ceres/ceres.h>

#include <chrono>
#include <numeric>
#include <unordered_map>
#include <vector>

#include "vilma/core/camera.h"
#include "vilma/core/progress.h"
#include "vilma/mapping/optimization/vi_optimization.h"
#include "vilma/mapstore/vi_map.h"

namespace vilma::mapping::vi_problem {

double SecondsSince(std::chrono::steady_clock::time_point start);

// One reprojection term, for outlier rejection and the error figures.
struct Observation {
  mapstore::LandmarkId landmark;
  mapstore::LandmarkObservation observation;
  const Camera* camera;
  Eigen::Vector2d uv;
  double* pose_M_I;
  double* p_G;
  double* pose_G_M;
  double* pose_I_C;
  ceres::ResidualBlockId residual = nullptr;
  // With a time offset (time_offset_residual.h): the vertex's speed/bias block, the offset
  // block and the gyroscope's reading at the vertex time; nullptr: no offset.
  double* speed_bias = nullptr;
  double* time_offset = nullptr;
  Eigen::Vector3d omega_m_I = Eigen::Vector3d::Zero();
};

// Pixel error of an observation at the current blocks; negative when behind the camera.
double PixelError(const Observation& o);
// RMSE over the observations still in the problem [px].
double RmsePx(const std::vector<Observation>& observations);

// Union-find over mission indices; the older mission is the root.
struct Clusters {
  std::vector<int> parent;
  explicit Clusters(std::size_t n) : parent(n) { std::iota(parent.begin(), parent.end(), 0); }
  int Find(int i) { return parent[i] == i ? i : parent[i] = Find(parent[i]); }
  void Join(int a, int b);
};

// Records the trust region radius; aborts the solve when a cancel was requested.
class CancelCallback : public ceres::IterationCallback {
 public:
  explicit CancelCallback(ProgressObserver* progress) : progress_(progress) {}
  ceres::CallbackReturnType operator()(const ceres::IterationSummary& summary) override;
  bool cancelled = false;
  double radius = 1e4;

 private:
  ProgressObserver* progress_;
};

// How far mission m's vertices moved in G from `T_G_I_before` (every vertex of m) to the map.
MissionChange ChangeOf(
    const mapstore::VIMap& map, const mapstore::MissionId& m,
    const std::unordered_map<mapstore::VertexId, Transformation, mapstore::IdHash>& T_G_I_before);

// Throws std::invalid_argument when a vertex state is not finite.
void CheckFinite(const mapstore::VIMap& map, const mapstore::VertexId& id);

}  // namespace vilma::mapping::vi_problem
