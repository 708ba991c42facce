// Error metrics of matched, aligned poses (docs/evaluation.md, "3. ATE" to "5. Within"):
// statistics of a list of errors, the absolute error per pose, the distance-based relative
// error (RPE) and the counts within a distance.
#pragma once

#include <cstddef>
#include <vector>

#include "vilma/core/geometry.h"

namespace vilma {

// ---- statistics ----

struct ErrorStats {
  std::size_t count = 0;
  double rmse = 0.0;
  double mean = 0.0;
  double median = 0.0;  // mean of the two middle values for an even count
  double std_dev = 0.0; // population standard deviation
  double min = 0.0;
  double max = 0.0;
};
// All zeros for an empty input.
ErrorStats ComputeErrorStats(const std::vector<double>& values);

struct AbsoluteError {
  ErrorStats translation_m;
  ErrorStats rotation_deg;
  // Roll/pitch error: the angle between the gravity axis seen in the body frame by the ground
  // truth and by the aligned estimate, angle(R_gt^T e_z, R_est^T e_z). Yaw does not enter, so
  // for posyaw (and none/first) it does not depend on the alignment: the VIO attitude error
  // that gravity makes observable.
  ErrorStats roll_pitch_deg;
  // Per matched pose, in association order.
  std::vector<double> translation_errors_m;
  std::vector<double> rotation_errors_deg;
  std::vector<double> roll_pitch_errors_deg;
};

struct RelativeError {
  double length_m = 0.0;
  std::size_t pairs = 0;  // 0 when the ground-truth path is shorter than length_m
  ErrorStats translation_m;
  ErrorStats translation_percent;  // 100 * translation / length_m
  ErrorStats rotation_deg;
};

// Matched poses whose aligned position error is <= distance_m (the boundary counts as within),
// e.g. a localization benchmark's recall = (results within 0.5 m) / attempts.
struct WithinCount {
  double distance_m = 0.0;
  std::size_t poses = 0;          // matched poses with translation error <= distance_m
  std::size_t matched_poses = 0;  // all matched poses
  double fraction = 0.0;          // poses / matched_poses (0 when nothing matched)
};
// One WithinCount per distance, same order.
std::vector<WithinCount> CountWithin(const std::vector<double>& translation_errors_m,
                                     const std::vector<double>& distances_m);

// Distance-based RPE over matched, aligned poses (see the header comment). Exposed for tests.
RelativeError ComputeRelativeError(const std::vector<Transformation>& T_G_B_gt,
                                   const std::vector<Transformation>& T_G_B_est, double length_m);

}  // namespace vilma
