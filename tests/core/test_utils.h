// Reusable numeric-differentiation kit for checking analytic Jacobians in tests
// (in the spirit of basalt-headers' test_utils.h and Ceres' manifold_test_utils.h).
//
// Central differences: J(:, i) = (f(x + h e_i) - f(x - h e_i)) / (2 h), truncation error
// O(h^2 f''') and round-off O(eps |f| / h); h ~ 1e-5 (times the scale of x) balances the two
// at ~1e-10 relative for smooth functions of O(1) inputs.
//
// Perturbations on groups are on the right, in local coordinates:
//   SO(3): q [+] d = q * ExpSO3(d);      SE(3): T [+] xi = T * Transformation::Exp(xi)
// and outputs on a group are compared the same way: y [-] y0 = LogSO3(y0^-1 y) or
// (y0^-1 y).Log(). These match the conventions of geometry.h (right Jacobians).
//
// Include from tests as "core/test_utils.h" (tests/ is on the include path).
#pragma once

#include <Eigen/Core>
#include <algorithm>
#include <catch2/catch.hpp>
#include <sstream>
#include <string>

#include "vilma/core/geometry.h"

namespace vilma {
namespace test {

// d f / d x of f: R^N -> R^M at x. F is callable as `Eigen::Matrix<double, M, 1> f(const
// Eigen::Matrix<double, N, 1>&)` (anything convertible to an Eigen vector works).
template <int M, int N, typename F>
Eigen::Matrix<double, M, N> NumericJacobian(const F& f, const Eigen::Matrix<double, N, 1>& x,
                                            double h = 1e-5) {
  Eigen::Matrix<double, M, N> J;
  for (int i = 0; i < N; ++i) {
    Eigen::Matrix<double, N, 1> x_plus = x, x_minus = x;
    x_plus[i] += h;
    x_minus[i] -= h;
    const Eigen::Matrix<double, M, 1> f_plus = f(x_plus);
    const Eigen::Matrix<double, M, 1> f_minus = f(x_minus);
    J.col(i) = (f_plus - f_minus) / (2.0 * h);
  }
  return J;
}

// d f(q [+] d) / d d at d = 0 for f: SO(3) -> R^M.
template <int M, typename F>
Eigen::Matrix<double, M, 3> NumericJacobianSO3(const F& f, const Eigen::Quaterniond& q,
                                               double h = 1e-5) {
  return NumericJacobian<M, 3>(
      [&](const Eigen::Vector3d& d) -> Eigen::Matrix<double, M, 1> { return f(q * ExpSO3(d)); },
      Eigen::Vector3d::Zero(), h);
}

// d f(T [+] xi) / d xi at xi = 0 for f: SE(3) -> R^M, xi = [rho; phi].
template <int M, typename F>
Eigen::Matrix<double, M, 6> NumericJacobianSE3(const F& f, const Transformation& T,
                                               double h = 1e-5) {
  return NumericJacobian<M, 6>(
      [&](const Vector6d& xi) -> Eigen::Matrix<double, M, 1> {
        return f(T * Transformation::Exp(xi));
      },
      Vector6d::Zero(), h);
}

// d (f(x) [-] f(x0)) / d x for f: R^N -> SO(3) (returns a quaternion), i.e. the right-local
// Jacobian J with f(x0 + dx) ~ f(x0) ExpSO3(J dx).
template <int N, typename F>
Eigen::Matrix<double, 3, N> NumericJacobianToSO3(const F& f, const Eigen::Matrix<double, N, 1>& x,
                                                 double h = 1e-5) {
  const Eigen::Quaterniond q0 = f(x);
  return NumericJacobian<3, N>(
      [&](const Eigen::Matrix<double, N, 1>& y) -> Eigen::Vector3d {
        return LogSO3(q0.conjugate() * f(y));
      },
      x, h);
}

// Likewise for f: R^N -> SE(3): f(x0 + dx) ~ f(x0) Exp(J dx).
template <int N, typename F>
Eigen::Matrix<double, 6, N> NumericJacobianToSE3(const F& f, const Eigen::Matrix<double, N, 1>& x,
                                                 double h = 1e-5) {
  const Transformation T0_inv = f(x).inverse();
  return NumericJacobian<6, N>(
      [&](const Eigen::Matrix<double, N, 1>& y) -> Vector6d { return (T0_inv * f(y)).Log(); }, x,
      h);
}

// |a - b|_max <= rel_tol * max(1, |b|_max): a relative test that degrades to absolute for
// small entries (Jacobians with zero blocks).
template <typename A, typename B>
bool MatricesNear(const Eigen::MatrixBase<A>& a, const Eigen::MatrixBase<B>& b, double rel_tol) {
  if (a.rows() != b.rows() || a.cols() != b.cols()) return false;
  if (!a.allFinite() || !b.allFinite()) return false;
  const double scale = std::max(1.0, b.cwiseAbs().maxCoeff());
  return (a - b).cwiseAbs().maxCoeff() <= rel_tol * scale;
}

template <typename A, typename B>
std::string DescribeMatrices(const Eigen::MatrixBase<A>& a, const Eigen::MatrixBase<B>& b) {
  std::ostringstream out;
  const Eigen::IOFormat fmt(Eigen::FullPrecision, 0, ", ", "\n", "[", "]");
  out << "actual:\n" << a.format(fmt) << "\nexpected:\n" << b.format(fmt);
  if (a.rows() == b.rows() && a.cols() == b.cols()) {
    out << "\ndifference:\n" << (a - b).format(fmt);
  }
  return out.str();
}

}  // namespace test
}  // namespace vilma

// CHECK that two matrices agree to a relative tolerance; prints both on failure.
#define VILMA_CHECK_MATRIX_NEAR(a, b, rel_tol)               \
  do {                                                       \
    INFO(::vilma::test::DescribeMatrices((a), (b)));         \
    CHECK(::vilma::test::MatricesNear((a), (b), (rel_tol))); \
  } while (false)
#define VILMA_REQUIRE_MATRIX_NEAR(a, b, rel_tol)               \
  do {                                                         \
    INFO(::vilma::test::DescribeMatrices((a), (b)));           \
    REQUIRE(::vilma::test::MatricesNear((a), (b), (rel_tol))); \
  } while (false)
