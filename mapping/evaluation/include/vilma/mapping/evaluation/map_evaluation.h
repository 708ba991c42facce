// A VI-map judged against ground truth (docs/evaluation.md "Maps"): the vertex trajectory of a
// mission (T_G_I) against a dataset's ground-truth states — ATE (translation, rotation) after an
// alignment, velocity and IMU-bias errors at the matched vertices —, the reprojection error of
// its good landmarks, and, for a simulated dataset, how far its good landmarks lie from the true
// surfaces of the simulator's world (after the same alignment). The optimization benchmarks
// (scripts/bench-optvi.sh) read these figures before and after.
#pragma once

#include <string>
#include <vector>

#include "vilma/core/asl_dataset.h"
#include "vilma/eval/evaluate.h"
#include "vilma/mapstore/vi_map.h"
#include "vilma/sim/world.h"

namespace vilma::mapping {

struct MapEvaluationOptions {
  AlignmentType alignment = AlignmentType::kPosYaw;  // posyaw, se3, sim3 or none
  AssociationOptions association;                   // vertex <-> ground truth by time
  std::string Validate() const;
};

struct MapEvaluation {
  mapstore::MissionId mission;
  std::string mission_name;
  std::size_t vertices = 0;
  EvalResult trajectory;           // ATE of the vertices (T_G_I) and the alignment S_W_G
  ErrorStats velocity_error_mps;   // |R_W_G v_G - v_W| at matched vertices (rotated by S)
  ErrorStats gyro_bias_error;      // |b_g - b_g,gt| [rad/s]
  ErrorStats accel_bias_error;     // |b_a - b_a,gt| [m/s^2]
  std::size_t good_landmarks = 0;  // stored in the mission
  ErrorStats reprojection_px;      // per observation of a good landmark [px]
  // The same split by the observations' keypoint noise (Keypoint::sigma_px, e.g. 0.15 px for a
  // track-refined keypoint, 1 px for a detector's; docs/mapping.md "Keypoint noise in the
  // map"), ascending: how far each class's residuals are from its declared sigma [px].
  struct SigmaClass {
    double sigma_px = 0.0;
    ErrorStats reprojection_px;
  };
  std::vector<SigmaClass> reprojection_by_sigma;
  bool has_world = false;
  ErrorStats surface_distance_m;   // good landmarks to the world's surfaces (has_world)
  std::string BriefReport() const;  // the first line: mission, vertices, matched, alignment
  std::string FullReport() const;   // the brief line, then ATE, velocity, biases, landmarks
  std::string ToJson() const;      // one JSON object (docs/evaluation.md)
};

// Throws InputError when too few vertices match the ground truth for the alignment, and
// std::invalid_argument for invalid options. `world` may be null.
MapEvaluation EvaluateMap(const mapstore::VIMap& map, const mapstore::MissionId& mission,
                          const std::vector<GroundTruthState>& ground_truth,
                          const sim::World* world, const MapEvaluationOptions& options);

// The simulator's world of a vilma-sim dataset folder: its sim.yaml names a preset world (or
// a world YAML file) and a seed. Returns false when DIR has no sim.yaml (a real dataset);
// throws InputError naming the file and key when sim.yaml is unreadable.
bool LoadDatasetWorld(const std::string& dataset_dir, sim::World* world);

}  // namespace vilma::mapping
