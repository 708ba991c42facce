// OptimizeViMap (vi_optimization.h): one solve, or with ba_estimate_noise_scales solves
// alternating with variance component estimation (variance_components.h) until the noise
// components' weights agree with the residuals.
#include <algorithm>
#include <chrono>
#include <cmath>
#include <stdexcept>
#include <unordered_map>

#include "vi_problem_util.h"
#include "vilma/mapping/landmarks/landmark_quality.h"
#include "vilma/mapping/optimization/vi_optimization.h"

namespace vilma::mapping {

ViOptimizationSummary OptimizeViMap(const ViOptimizationOptions& options, mapstore::VIMap* map,
                                    const std::vector<mapstore::MissionId>& missions,
                                    ProgressObserver* progress) {
  const std::string problem_text = options.Validate();
  if (!problem_text.empty()) throw std::invalid_argument("optimization options: " + problem_text);
  if (!options.ba_estimate_noise_scales) {
    return SolveViMap(options, NoiseScales{}, map, missions, progress, nullptr);
  }
  const auto start = std::chrono::steady_clock::now();
  // Solved on a copy: a failure or a cancel in any solve leaves the map untouched.
  mapstore::VIMap work = map->Clone();
  const std::vector<mapstore::MissionId> selected =
      missions.empty() ? map->mission_ids() : missions;
  std::unordered_map<mapstore::VertexId, Transformation, mapstore::IdHash> T_G_I_before;
  for (const mapstore::MissionId& m : selected) {
    for (const mapstore::VertexId& v : map->vertex_ids(m)) T_G_I_before[v] = map->T_G_I(v);
  }
  ViOptimizationOptions inner = options;
  inner.evaluate_quality = false;  // once, at the end: the problem's landmarks stay the same
  NoiseScales scales;
  ViOptimizationSummary total;
  for (int round = 0; round < options.ba_noise_scale_rounds; ++round) {
    NoiseFactors factors;
    const ViOptimizationSummary s = SolveViMap(inner, scales, &work, missions, progress, &factors);
    if (round == 0) {
      total = s;
    } else {
      total.final_cost = s.final_cost;
      total.iterations += s.iterations;
      total.rounds += s.rounds;
      total.solve_seconds += s.solve_seconds;
      total.reprojection_rmse_after_px = s.reprojection_rmse_after_px;
      total.outlier_observations += s.outlier_observations;
      total.reintegrations += s.reintegrations;
      total.termination = s.termination;
      for (std::size_t c = 0; c < s.cameras.size() && c < total.cameras.size(); ++c) {
        total.cameras[c].T_I_C_after = s.cameras[c].T_I_C_after;
        total.cameras[c].time_offset_after_s = s.cameras[c].time_offset_after_s;
      }
      total.baseframe_tilt_change_deg += s.baseframe_tilt_change_deg;
    }
    total.noise_scales.push_back(scales);
    total.noise_factors.push_back(factors);
    // σ_k ← σ_k sqrt(f_k), bounded (the IMU's from below by ba_noise_scale_imu_min: its
    // datasheet); converged when no scale moved by more than the tolerance (a factor that
    // pushes a scale against its bound moves nothing).
    bool converged = true;
    for (int k = 0; k < NoiseFactors::kCount; ++k) {
      if (!factors.estimated[k] || (k == 0 && !options.ba_noise_scale_visual)) continue;
      const double lower = k == 0 ? 1.0 / options.ba_noise_scale_max
                                  : std::max(options.ba_noise_scale_imu_min,
                                             1.0 / options.ba_noise_scale_max);
      const double before = scales.sigma[k];
      scales.sigma[k] = std::clamp(before * std::sqrt(factors.factor[k]), lower,
                                   options.ba_noise_scale_max);
      if (std::abs(scales.sigma[k] / before - 1.0) > options.ba_noise_scale_tolerance) {
        converged = false;
      }
    }
    if (converged) break;
  }
  total.missions.clear();
  for (const mapstore::MissionId& m : selected) {
    total.missions.push_back(vi_problem::ChangeOf(work, m, T_G_I_before));
  }
  if (options.evaluate_quality) {
    total.good_landmarks_after =
        EvaluateLandmarkQualities(options.quality, &work, selected).good_after;
  }
  *map = std::move(work);
  total.total_seconds = vi_problem::SecondsSince(start);
  return total;
}

}  // namespace vilma::mapping
