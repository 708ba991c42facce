// Random test data that is the same under every compiler (docs/testing.md "Random test data").
//
// C++ leaves unspecified the order in which a call's arguments are evaluated (and the operands
// of most binary operators): Eigen::Vector3d(n(rng), n(rng), n(rng)) fills x, y, z from
// different draws under GCC (it evaluates such arguments last to first) and clang (first to
// last), so with the same seed a test would get other data under each. Tests therefore draw
// into named variables, one statement per draw, or through these helpers. The order kept is
// GCC's, z then y then x, because the tests' bounds were tuned on the data GCC drew.
//
// Include from tests as "test_random.h" (tests/ is on the include path).
#pragma once

#include <Eigen/Core>
#include <Eigen/Geometry>

namespace vilma::testing {

// Eigen::Vector2d(draw(), draw()) as GCC evaluated it: y first, then x.
template <typename Draw>
Eigen::Vector2d DrawVector2(Draw&& draw) {
  const double y = draw();
  const double x = draw();
  return Eigen::Vector2d(x, y);
}

// Eigen::Vector3d(draw(), draw(), draw()) as GCC evaluated it: z, y, then x.
template <typename Draw>
Eigen::Vector3d DrawVector3(Draw&& draw) {
  const double z = draw();
  const double y = draw();
  const double x = draw();
  return Eigen::Vector3d(x, y, z);
}

// Eigen::Quaterniond(draw(), draw(), draw(), draw()) (w, x, y, z; not normalized) as GCC
// evaluated it: z, y, x, then w.
template <typename Draw>
Eigen::Quaterniond DrawQuaternion(Draw&& draw) {
  const double z = draw();
  const double y = draw();
  const double x = draw();
  const double w = draw();
  return Eigen::Quaterniond(w, x, y, z);
}

}  // namespace vilma::testing
