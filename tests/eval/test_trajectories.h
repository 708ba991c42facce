// Trajectories and transforms shared by the eval module's tests.
#pragma once

#include <cmath>
#include <cstddef>
#include <cstdint>

#include "vilma/core/geometry.h"
#include "vilma/eval/trajectory.h"

namespace vilma {
namespace eval_test {

inline constexpr double kPi = 3.14159265358979323846;
inline constexpr double kDeg = kPi / 180.0;

inline Eigen::Quaterniond Rz(double a) { return Eigen::Quaterniond(Eigen::AngleAxisd(a, Eigen::Vector3d::UnitZ())); }
inline Eigen::Quaterniond Rx(double a) { return Eigen::Quaterniond(Eigen::AngleAxisd(a, Eigen::Vector3d::UnitX())); }

// A 3D loop with changing heading, roll and pitch: 400 poses at 10 Hz, ~100 m of path.
inline Trajectory MakeLoop(std::size_t n = 400) {
  Trajectory t;
  for (std::size_t i = 0; i < n; ++i) {
    const double s = 0.1 * static_cast<double>(i);  // [s]
    const Eigen::Vector3d p(8.0 * std::cos(0.25 * s), 5.0 * std::sin(0.5 * s),
                            1.0 + 0.5 * std::sin(0.3 * s));
    const Eigen::Quaterniond q =
        ExpSO3(Eigen::Vector3d(0.1 * std::sin(0.7 * s), 0.05 * std::cos(0.4 * s), 0.25 * s));
    t.Add(1000000000 + static_cast<int64_t>(i) * 100000000, Transformation(q, p));
  }
  return t;
}

// est = S_E_G applied to every pose of gt: T_E_B = (R R_G_B, s R p_G_B + t).
inline Trajectory Transform(const Trajectory& gt, const Transformation& T_E_G, double scale) {
  Trajectory est = gt;
  for (auto& T : est.T_W_B) {
    T = Transformation(T_E_G.rotation() * T.rotation(),
                       scale * (T_E_G.rotation() * T.translation()) + T_E_G.translation());
  }
  return est;
}

}  // namespace eval_test
}  // namespace vilma
