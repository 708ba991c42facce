#include "vilma/mapping/optimization/vi_optimization.h"

#include <ceres/ceres.h>

#include <algorithm>
#include <array>
#include <chrono>
#include <cmath>
#include <map>
#include <memory>
#include <numeric>
#include <sstream>
#include <stdexcept>
#include <unordered_map>

#include "vilma/mapping/landmarks/landmark_quality.h"
#include "vilma/mapping/optimization/inertial_residual.h"
#include "vilma/mapping/optimization/pose_manifold.h"
#include "vilma/mapping/optimization/reprojection_residual.h"
#include "vilma/mapping/optimization/time_offset_residual.h"
#include "variance_components.h"
#include "vi_problem_util.h"

namespace vilma::mapping {

using mapstore::EdgeType;
using mapstore::IdHash;
using mapstore::LandmarkId;
using mapstore::LandmarkObservation;
using mapstore::MissionId;
using mapstore::VertexId;
using mapstore::VIMap;

using vi_problem::CancelCallback;
using vi_problem::CheckFinite;
using vi_problem::Clusters;
using vi_problem::Observation;
using vi_problem::PixelError;
using vi_problem::RmsePx;
using vi_problem::SecondsSince;

ViOptimizationSummary SolveViMap(const ViOptimizationOptions& options, const NoiseScales& scales,
                                 VIMap* map, const std::vector<MissionId>& missions,
                                 ProgressObserver* progress, NoiseFactors* factors) {
  const auto start = std::chrono::steady_clock::now();
  const std::string problem_text = options.Validate();
  if (!problem_text.empty()) throw std::invalid_argument("optimization options: " + problem_text);
  ViOptimizationSummary summary;
  summary.command = options.inertial ? "optvi" : "optv";
  const std::vector<MissionId> selected = missions.empty() ? map->mission_ids() : missions;
  std::unordered_map<MissionId, int, IdHash> mission_index;
  for (std::size_t i = 0; i < selected.size(); ++i) mission_index[selected[i]] = static_cast<int>(i);

  // ---- states (copied out of the map; written back only at the end). Every block lives in one
  // arena, handed out in the (deterministic) order the problem is built: Ceres orders blocks
  // by address (e.g. in the Schur elimination), so the same map gives the same arithmetic.
  std::size_t max_cameras = 1;
  for (const MissionId& m : map->mission_ids()) {
    max_cameras = std::max(max_cameras, map->mission(m).rig.cameras.size());
  }
  std::vector<double> arena;
  arena.reserve(map->num_vertices() * 16 + map->mission_ids().size() * 8 * (1 + max_cameras) +
                map->num_landmarks() * 3);
  auto allocate = [&arena](std::size_t n) {
    const std::size_t offset = arena.size();
    if (offset + n > arena.capacity()) throw std::logic_error("optimization arena too small");
    arena.resize(offset + n);
    return arena.data() + offset;
  };
  std::unordered_map<VertexId, double*, IdHash> poses;
  std::unordered_map<VertexId, double*, IdHash> speed_biases;
  std::unordered_map<MissionId, double*, IdHash> baseframes;
  std::map<std::pair<MissionId, uint32_t>, double*> extrinsics;
  std::unordered_map<LandmarkId, double*, IdHash> landmarks;
  std::map<std::pair<MissionId, uint32_t>, double*> time_offsets;  // [s], from 0
  std::unordered_map<VertexId, Eigen::Vector3d, IdHash> omega_m_I;  // gyroscope at the vertex
  auto pose_of = [&](const VertexId& id) -> double* {
    auto it = poses.find(id);
    if (it == poses.end()) {
      CheckFinite(*map, id);
      it = poses.emplace(id, allocate(7)).first;
      PoseToBlock(map->vertex(id).T_M_I, it->second);
    }
    return it->second;
  };
  auto speed_bias_of = [&](const VertexId& id) -> double* {
    auto it = speed_biases.find(id);
    if (it == speed_biases.end()) {
      const mapstore::Vertex& x = map->vertex(id);
      double* sb = allocate(9);
      for (int k = 0; k < 3; ++k) {
        sb[k] = x.v_M[k];
        sb[3 + k] = x.gyro_bias[k];
        sb[6 + k] = x.accel_bias[k];
      }
      it = speed_biases.emplace(id, sb).first;
    }
    return it->second;
  };
  auto baseframe_of = [&](const MissionId& id) -> double* {
    auto it = baseframes.find(id);
    if (it == baseframes.end()) {
      it = baseframes.emplace(id, allocate(7)).first;
      PoseToBlock(map->mission(id).T_G_M, it->second);
    }
    return it->second;
  };
  auto extrinsics_of = [&](const MissionId& id, uint32_t camera) -> double* {
    auto key = std::make_pair(id, camera);
    auto it = extrinsics.find(key);
    if (it == extrinsics.end()) {
      it = extrinsics.emplace(key, allocate(7)).first;
      PoseToBlock(map->mission(id).rig.cameras.at(camera).T_I_C, it->second);
    }
    return it->second;
  };

  auto time_offset_of = [&](const MissionId& id, uint32_t camera) -> double* {
    auto key = std::make_pair(id, camera);
    auto it = time_offsets.find(key);
    if (it == time_offsets.end()) {
      it = time_offsets.emplace(key, allocate(1)).first;
      it->second[0] = 0.0;
    }
    return it->second;
  };

  ceres::Problem::Options problem_options;
  problem_options.loss_function_ownership = ceres::DO_NOT_TAKE_OWNERSHIP;
  problem_options.manifold_ownership = ceres::DO_NOT_TAKE_OWNERSHIP;
  ceres::Problem problem(problem_options);
  // Reprojection residuals are whitened by their keypoint's sigma (the map's per-observation
  // sigma_px, or options.keypoint_sigma_px when that overrides it); the robust loss acts on the
  // whitened residual at ba_robust_loss_scale_sigma (k sigma for every observation), or at
  // ba_robust_loss_scale_px / sigma when a pixel scale is given (reprojection_residual.h). One
  // loss function per distinct sigma (owned here; a map has few distinct values).
  std::map<double, std::unique_ptr<ceres::LossFunction>> losses;
  auto loss_for = [&](double sigma_px) -> ceres::LossFunction* {
    auto it = losses.find(sigma_px);
    if (it == losses.end()) {
      it = losses
               .emplace(sigma_px, ReprojectionLoss(options.ba_robust_loss,
                                                   options.ba_robust_loss_scale_sigma,
                                                   options.ba_robust_loss_scale_px, sigma_px))
               .first;
    }
    return it->second.get();
  };
  Clusters clusters(selected.size());

  // ---- inertial terms
  std::vector<std::unique_ptr<ImuPreintegration>> preintegrations;
  std::vector<VertexId> preintegration_from, preintegration_to;
  std::vector<double> preintegration_gravity;
  std::vector<vi_problem::InertialBlock> inertial_blocks;
  if (options.inertial) {
    for (const MissionId& m : selected) {
      const std::vector<VertexId> chain = map->VertexChain(m);
      if (chain.size() != map->vertex_ids(m).size()) {
        throw std::invalid_argument("mission " + m.Hex() + ": its vertices are not one chain of "
                                    "IMU edges (check_map_consistency names the break)");
      }
      if (chain.size() < 2) continue;
      const SensorRig& rig = map->mission(m).rig;
      // The rig's densities times the options' scales (model mismatch) and the solve's.
      ImuNoise noise = rig.imu.noise;
      const double gyro = options.ba_imu_noise_scale * options.ba_gyro_noise_scale;
      const double accel = options.ba_imu_noise_scale * options.ba_accel_noise_scale;
      noise.gyroscope_noise_density *= gyro * scales.sigma[1];
      noise.accelerometer_noise_density *= accel * scales.sigma[2];
      noise.gyroscope_random_walk *= gyro * scales.sigma[3];
      noise.accelerometer_random_walk *= accel * scales.sigma[4];
      for (const mapstore::EdgeId& eid : map->edge_ids(m)) {
        const mapstore::Edge& e = map->edge(eid);
        if (e.type != EdgeType::kImu) continue;
        double* pose_i = pose_of(e.from);
        double* speed_bias_i = speed_bias_of(e.from);
        double* pose_j = pose_of(e.to);
        double* speed_bias_j = speed_bias_of(e.to);
        const mapstore::Vertex& from = map->vertex(e.from);
        try {
          preintegrations.push_back(std::make_unique<ImuPreintegration>(
              e.imu_samples, noise, from.gyro_bias, from.accel_bias));
        } catch (const std::invalid_argument& error) {
          throw std::invalid_argument("IMU edge " + eid.Hex() + ": " + error.what());
        }
        preintegration_from.push_back(e.from);
        preintegration_to.push_back(e.to);
        preintegration_gravity.push_back(rig.imu.gravity_magnitude);
        // The samples cover both vertex times exactly (interpolated there).
        omega_m_I.emplace(e.from, e.imu_samples.front().omega_I);
        omega_m_I.emplace(e.to, e.imu_samples.back().omega_I);
        inertial_blocks.push_back({problem.AddResidualBlock(
            new InertialCostFunction(preintegrations.back().get(), rig.imu.gravity_magnitude),
            nullptr, pose_i, speed_bias_i, pose_j, speed_bias_j), preintegrations.back().get()});
        ++summary.inertial_residuals;
      }
      if (summary.inertial_residuals == 0 && chain.size() > 1) {
        throw std::invalid_argument("mission " + m.Hex() + " has no IMU edges: use optv");
      }
    }
  }

  // ---- visual terms: good landmarks stored in the selected missions
  std::vector<Observation> observations;
  std::unordered_map<LandmarkId, std::vector<std::size_t>, IdHash> landmark_observations;
  if (options.visual) {
    for (const MissionId& m : selected) {
      for (const LandmarkId& lid : map->landmark_ids(m)) {
        const mapstore::Landmark& l = map->landmark(lid);
        if (l.quality != mapstore::LandmarkQuality::kGood) continue;
        const Eigen::Vector3d p_G = map->LandmarkPosition_G(lid);
        if (!p_G.allFinite()) {
          throw std::invalid_argument("landmark " + lid.Hex() + ": a position that is not finite");
        }
        double* block = allocate(3);
        landmarks[lid] = block;
        for (int k = 0; k < 3; ++k) block[k] = p_G[k];
        for (const LandmarkObservation& o : l.observations) {
          const mapstore::Vertex& v = map->vertex(o.vertex_id);
          const mapstore::Mission& observer = map->mission(v.mission_id);
          const mapstore::Keypoint& keypoint = v.frames.at(o.camera).keypoints.at(o.keypoint);
          const double sigma_px =
              scales.sigma[0] *
              (options.keypoint_sigma_px > 0.0 ? options.keypoint_sigma_px : keypoint.sigma_px);
          Observation ob{lid,
                         o,
                         &observer.rig.cameras.at(o.camera).camera,
                         keypoint.uv,
                         pose_of(o.vertex_id),
                         block,
                         baseframe_of(v.mission_id),
                         extrinsics_of(v.mission_id, o.camera)};
          const auto omega = omega_m_I.find(o.vertex_id);
          if (options.ba_estimate_time_offset && omega != omega_m_I.end()) {
            ob.speed_bias = speed_bias_of(o.vertex_id);
            ob.time_offset = time_offset_of(v.mission_id, o.camera);
            ob.omega_m_I = omega->second;
            ob.residual = problem.AddResidualBlock(
                new TimeOffsetReprojectionCostFunction(ob.camera, ob.uv, sigma_px, ob.omega_m_I),
                loss_for(sigma_px), ob.pose_M_I, ob.speed_bias, ob.p_G, ob.pose_G_M, ob.pose_I_C,
                ob.time_offset);
          } else {
            ob.residual = problem.AddResidualBlock(
                new ReprojectionCostFunction(ob.camera, ob.uv, sigma_px), loss_for(sigma_px), ob.pose_M_I, ob.p_G, ob.pose_G_M, ob.pose_I_C);
          }
          landmark_observations[lid].push_back(observations.size());
          observations.push_back(ob);
          auto it = mission_index.find(v.mission_id);
          if (it != mission_index.end()) clusters.Join(mission_index.at(m), it->second);
        }
      }
    }
    summary.reprojection_residuals = observations.size();
  }
  if (problem.NumResidualBlocks() == 0) {
    throw std::invalid_argument(summary.command + ": nothing to optimize (no good landmarks" +
                                std::string(options.inertial ? " and no IMU edges" : "") +
                                " in the selected missions; run elq?)");
  }
  summary.landmarks = landmarks.size();

  // ---- which blocks move
  // Owned here (the problem does not take ownership); they outlive the solve.
  PoseManifold pose_manifold;
  // Per cluster: the anchor vertex's position and heading held (inertial), or the visual-only
  // scale gauge.
  std::vector<std::unique_ptr<GaugePoseManifold>> gauges;
  ceres::SubsetManifold biases_fixed(9, {3, 4, 5, 6, 7, 8});
  for (auto& [id, pose] : poses) {
    if (!problem.HasParameterBlock(pose)) continue;
    if (mission_index.count(map->vertex(id).mission_id) == 0) {
      problem.SetParameterBlockConstant(pose);  // an observer of another mission
    } else {
      problem.SetManifold(pose, &pose_manifold);
      ++summary.vertices;
    }
  }
  for (auto& [id, sb] : speed_biases) {
    (void)id;
    if (options.ba_fix_biases) {
      problem.SetManifold(sb, &biases_fixed);
    }
  }
  BaseframeTiltManifold tilt;
  for (auto& [id, pose] : baseframes) {
    if (options.ba_estimate_baseframe_tilt && mission_index.count(id) != 0 &&
        !map->mission(id).baseframe_known) {
      problem.SetManifold(pose, &tilt);
    } else {
      problem.SetParameterBlockConstant(pose);
    }
  }
  for (auto& [key, pose] : extrinsics) {
    (void)key;
    if (options.ba_fix_extrinsics) {
      problem.SetParameterBlockConstant(pose);
    } else {
      problem.SetManifold(pose, &pose_manifold);
    }
  }
  for (auto& [id, p] : landmarks) {
    (void)id;
    if (options.ba_fix_landmarks) problem.SetParameterBlockConstant(p);
  }
  // Held landmarks fix G (and, seen by the missions, their frames): no vertex is held then.
  const bool landmarks_fix_gauge = options.ba_fix_landmarks && !landmarks.empty();
  // Gauge per cluster: the anchor mission (the first with a known baseframe, else the first).
  std::map<int, std::vector<int>> members;
  for (std::size_t i = 0; i < selected.size(); ++i) {
    members[clusters.Find(static_cast<int>(i))].push_back(static_cast<int>(i));
  }
  summary.clusters = members.size();
  for (const auto& [root, list] : members) {
    (void)root;
    if (landmarks_fix_gauge) break;
    int anchor = list.front();
    for (int i : list) {
      if (map->mission(selected[i]).baseframe_known) {
        anchor = i;
        break;
      }
    }
    std::vector<double*> in_problem;
    for (const VertexId& v : map->VertexChain(selected[anchor])) {
      auto it = poses.find(v);
      if (it != poses.end() && problem.HasParameterBlock(it->second)) {
        in_problem.push_back(it->second);
      }
    }
    if (in_problem.empty()) continue;
    if (options.inertial) {
      // Position and heading of the first vertex in M held at their values now (docs/
      // optimization.md "Gauge": its roll and pitch move without turning the map).
      gauges.push_back(std::make_unique<GaugePoseManifold>(
          true, Eigen::Map<const Eigen::Quaterniond>(in_problem[0] + 3)));
      problem.SetManifold(in_problem[0], gauges.back().get());
      continue;
    }
    // Visual only: the first vertex's pose, and the scale: the distance to the vertex farthest
    // from it (the longest baseline, so the VIO's scale error enters least).
    problem.SetParameterBlockConstant(in_problem[0]);
    const Eigen::Map<const Eigen::Vector3d> p0(in_problem[0]);
    double* far = nullptr;
    double far_distance = 0.0;
    for (double* b : in_problem) {
      const double d = (Eigen::Map<const Eigen::Vector3d>(b) - p0).norm();
      if (d > far_distance) {
        far_distance = d;
        far = b;
      }
    }
    if (far != nullptr && far_distance > 1e-3) {
      gauges.push_back(std::make_unique<GaugePoseManifold>(
          Eigen::Vector3d(Eigen::Map<const Eigen::Vector3d>(far) - p0)));
      problem.SetManifold(far, gauges.back().get());
    }
  }

  // Re-integrates the IMU edges whose start bias moved far from the linearization point.
  auto reintegrate = [&]() {
    std::size_t n = 0;
    for (std::size_t k = 0; k < preintegrations.size(); ++k) {
      const double* sb = speed_biases.at(preintegration_from[k]);
      const Eigen::Vector3d bg(sb[3], sb[4], sb[5]), ba(sb[6], sb[7], sb[8]);
      if (preintegrations[k]->NeedsReintegration(bg, ba, options.preintegration)) {
        preintegrations[k]->Reintegrate(bg, ba);
        ++n;
      }
    }
    summary.reintegrations += n;
    return n;
  };

  // ---- IMU states first: velocities and biases that fit the current trajectory (poses and
  // landmarks held), re-integrating as the biases settle. A map whose biases are far off (zero
  // where the gyroscope has 0.08 rad/s, as a map built from given poses) would otherwise start
  // with IMU residuals that dwarf everything and drag the poses away.
  if (options.inertial && options.ba_initialize_imu_states && !preintegrations.empty()) {
    for (int pass = 0; pass < 4; ++pass) {
      ceres::Problem::Options init_options;
      init_options.manifold_ownership = ceres::DO_NOT_TAKE_OWNERSHIP;
      ceres::Problem init(init_options);
      for (std::size_t k = 0; k < preintegrations.size(); ++k) {
        const VertexId from = preintegration_from[k];
        const VertexId to = preintegration_to[k];
        const ImuPreintegration* pre = preintegrations[k].get();
        init.AddResidualBlock(
            new InertialCostFunction(pre, preintegration_gravity[k]), nullptr, poses.at(from),
            speed_biases.at(from), poses.at(to), speed_biases.at(to));
        init.SetParameterBlockConstant(poses.at(from));
        init.SetParameterBlockConstant(poses.at(to));
      }
      if (options.ba_fix_biases) {
        for (auto& [id, sb] : speed_biases) {
          (void)id;
          if (init.HasParameterBlock(sb)) init.SetManifold(sb, &biases_fixed);
        }
      }
      ceres::Solver::Options init_solver;
      init_solver.linear_solver_type = ceres::SPARSE_NORMAL_CHOLESKY;
      init_solver.max_num_iterations = 20;
      init_solver.num_threads = options.ba_num_threads;
      init_solver.logging_type = ceres::SILENT;
      ceres::Solver::Summary init_summary;
      ceres::Solve(init_solver, &init, &init_summary);
      const std::size_t reintegrated = reintegrate();
      if (reintegrated == 0) break;
    }
  }

  // ---- solver
  ceres::Solver::Options solver;
  solver.minimizer_type = ceres::TRUST_REGION;
  solver.trust_region_strategy_type = ceres::LEVENBERG_MARQUARDT;
  solver.num_threads = options.ba_num_threads;
  solver.jacobi_scaling = true;
  solver.function_tolerance = options.ba_function_tolerance;
  solver.logging_type = ceres::SILENT;
  const bool schur = options.ba_linear_solver != "sparse_normal_cholesky";
  if (options.ba_linear_solver == "sparse_schur") solver.linear_solver_type = ceres::SPARSE_SCHUR;
  if (options.ba_linear_solver == "dense_schur") solver.linear_solver_type = ceres::DENSE_SCHUR;
  if (options.ba_linear_solver == "sparse_normal_cholesky") {
    solver.linear_solver_type = ceres::SPARSE_NORMAL_CHOLESKY;
  }
  if (options.ba_linear_solver == "iterative_schur") {
    solver.linear_solver_type = ceres::ITERATIVE_SCHUR;
    solver.preconditioner_type = ceres::SCHUR_JACOBI;
  }
  if (schur && !options.ba_fix_landmarks && !landmarks.empty()) {
    // Landmarks first: eliminated by the Schur complement.
    auto ordering = std::make_shared<ceres::ParameterBlockOrdering>();
    std::vector<double*> blocks;
    problem.GetParameterBlocks(&blocks);
    for (double* b : blocks) ordering->AddElementToGroup(b, problem.ParameterBlockSize(b) == 3 ? 0 : 1);
    solver.linear_solver_ordering = ordering;
  }
  CancelCallback callback(progress);
  solver.callbacks.push_back(&callback);
  solver.update_state_every_iteration = false;

  summary.reprojection_rmse_before_px = RmsePx(observations);
  std::unordered_map<VertexId, Transformation, IdHash> T_G_I_before;
  for (const MissionId& m : selected) {
    for (const VertexId& v : map->vertex_ids(m)) T_G_I_before[v] = map->T_G_I(v);
  }
  std::size_t good_before = 0;
  for (const LandmarkId& lid : LandmarksOf(*map, selected)) {
    good_before += map->landmark(lid).quality == mapstore::LandmarkQuality::kGood;
  }
  summary.good_landmarks_before = good_before;

  BeginProgress(progress, summary.command, static_cast<std::size_t>(options.ba_num_iterations));
  int done = 0;
  double radius = 1e4;
  bool first = true;
  while (done < options.ba_num_iterations) {
    solver.max_num_iterations = std::min(options.ba_iterations_per_round,
                                         options.ba_num_iterations - done);
    solver.initial_trust_region_radius = radius;
    ceres::Solver::Summary round;
    ceres::Solve(solver, &problem, &round);
    if (callback.cancelled) throw Cancelled();
    if (round.termination_type == ceres::FAILURE) {
      throw std::runtime_error(summary.command + ": the solver failed: " + round.message);
    }
    radius = std::max(callback.radius, 1e-8);
    if (first) summary.initial_cost = round.initial_cost;
    first = false;
    summary.final_cost = round.final_cost;
    summary.solve_seconds += round.total_time_in_seconds;
    const int iterations = std::max(1, static_cast<int>(round.iterations.size()) - 1);
    summary.iterations += iterations;
    done += iterations;
    ++summary.rounds;
    summary.termination =
        std::string(ceres::TerminationTypeToString(round.termination_type)) + ": " + round.message;

    const std::size_t reintegrated = reintegrate();
    // Outlier rejection: observations behind the camera or too far off; a landmark left with
    // fewer than two observations loses them all (its depth would be unconstrained).
    // Only once the round has settled (cost down by less than 10 %, or converged): from a
    // perturbed start every observation looks like an outlier.
    const bool settled = round.termination_type == ceres::CONVERGENCE ||
                         round.final_cost > 0.9 * round.initial_cost;
    std::size_t outliers = 0;
    if (options.ba_outlier_rejection && settled) {
      for (auto& [lid, list] : landmark_observations) {
        (void)lid;
        std::size_t kept = 0;
        for (std::size_t k : list) {
          Observation& o = observations[k];
          if (o.residual == nullptr) continue;
          const double e = PixelError(o);
          if (e < 0 || e > options.ba_outlier_threshold_px) {
            problem.RemoveResidualBlock(o.residual);
            o.residual = nullptr;
            ++outliers;
          } else {
            ++kept;
          }
        }
        if (kept == 1) {
          for (std::size_t k : list) {
            Observation& o = observations[k];
            if (o.residual == nullptr) continue;
            problem.RemoveResidualBlock(o.residual);
            o.residual = nullptr;
            ++outliers;
          }
        }
      }
    }
    summary.outlier_observations += outliers;
    ReportProgress(progress, static_cast<std::size_t>(done));
    if (round.termination_type == ceres::CONVERGENCE && outliers == 0 && reintegrated == 0) break;
  }
  summary.reprojection_rmse_after_px = RmsePx(observations);
  if (factors != nullptr) {
    std::vector<ceres::ResidualBlockId> visual_blocks;
    for (const Observation& o : observations) {
      if (o.residual != nullptr) visual_blocks.push_back(o.residual);
    }
    *factors = vi_problem::EstimateVarianceComponents(&problem, inertial_blocks, visual_blocks,
                                                      options.ba_noise_scale_probes);
  }

  // ---- write back: vertices first (landmarks are stored relative to their store vertex)
  for (const auto& [id, pose] : poses) {
    if (mission_index.count(map->vertex(id).mission_id) == 0) continue;
    map->vertex(id).T_M_I = BlockToPose(pose);
  }
  for (const auto& [id, sb] : speed_biases) {
    mapstore::Vertex& v = map->vertex(id);
    v.v_M = Eigen::Vector3d(sb[0], sb[1], sb[2]);
    v.gyro_bias = Eigen::Vector3d(sb[3], sb[4], sb[5]);
    v.accel_bias = Eigen::Vector3d(sb[6], sb[7], sb[8]);
  }
  for (const auto& [key, pose] : extrinsics) {
    if (mission_index.count(key.first) == 0) continue;
    if (options.ba_fix_extrinsics && time_offsets.count(key) == 0) continue;
    CameraConfig& camera = map->mission(key.first).rig.cameras[key.second];
    CameraCalibrationChange c;
    c.mission = key.first;
    c.camera = key.second;
    c.T_I_C_before = camera.T_I_C;
    c.T_I_C_after = BlockToPose(pose);
    c.time_offset_before_s = c.time_offset_after_s = 1e-9 * static_cast<double>(camera.time_offset_ns);
    const auto offset = time_offsets.find(key);
    if (offset != time_offsets.end()) c.time_offset_after_s += offset->second[0];
    summary.cameras.push_back(c);
    if (!options.ba_fix_extrinsics) camera.T_I_C = c.T_I_C_after;
  }
  // The time offset is reported, not written to the rig: the vertex times were made with the
  // rig's offset, and a rig changed under them would be applied twice by the next estimate.
  for (const auto& [id, pose] : baseframes) {
    if (mission_index.count(id) == 0 || map->mission(id).baseframe_known) continue;
    const Transformation T_G_M = BlockToPose(pose);
    summary.baseframe_tilt_change_deg =
        std::max(summary.baseframe_tilt_change_deg,
                 AngleBetween(T_G_M.rotation(), map->mission(id).T_G_M.rotation()) * 180 / M_PI);
    map->mission(id).T_G_M = T_G_M;
  }
  for (const auto& [id, p] : landmarks) {
    mapstore::Landmark& l = map->landmark(id);
    l.p_I = map->T_G_I(l.store_vertex_id).inverse() * Eigen::Vector3d(p[0], p[1], p[2]);
  }
  // Dropped observations leave the map; a landmark left without any is removed.
  VIMap::IdSet orphans;
  for (const Observation& o : observations) {
    if (o.residual != nullptr) continue;
    map->RemoveObservation(o.landmark, o.observation);
    if (map->landmark(o.landmark).observations.empty()) orphans.insert(o.landmark);
  }
  map->RemoveLandmarks(orphans);

  for (const MissionId& m : selected) {
    summary.missions.push_back(vi_problem::ChangeOf(*map, m, T_G_I_before));
  }
  if (options.evaluate_quality) {
    const LandmarkQualitySummary q = EvaluateLandmarkQualities(options.quality, map, selected);
    summary.good_landmarks_after = q.good_after;
  } else {
    summary.good_landmarks_after = summary.good_landmarks_before;
  }
  summary.total_seconds = SecondsSince(start);
  return summary;
}

}  // namespace vilma::mapping
