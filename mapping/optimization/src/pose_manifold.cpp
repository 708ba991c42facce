#include "vilma/mapping/optimization/pose_manifold.h"

#include <Eigen/Core>

namespace vilma::mapping {

bool PoseManifold::Plus(const double* x, const double* delta, double* x_plus_delta) const {
  Eigen::Map<const Eigen::Vector3d> p(x);
  Eigen::Map<const Eigen::Quaterniond> q(x + 3);
  Eigen::Map<const Eigen::Vector3d> dp(delta), dtheta(delta + 3);
  Eigen::Map<Eigen::Vector3d> p_out(x_plus_delta);
  Eigen::Map<Eigen::Quaterniond> q_out(x_plus_delta + 3);
  p_out = p + dp;
  q_out = (q * ExpSO3(dtheta)).normalized();
  return true;
}

bool PoseManifold::PlusJacobian(const double* /*x*/, double* jacobian) const {
  Eigen::Map<Eigen::Matrix<double, 7, 6, Eigen::RowMajor>> J(jacobian);
  J.setZero();
  J.topLeftCorner<6, 6>().setIdentity();
  return true;
}

bool PoseManifold::Minus(const double* y, const double* x, double* y_minus_x) const {
  Eigen::Map<const Eigen::Vector3d> py(y), px(x);
  Eigen::Map<const Eigen::Quaterniond> qy(y + 3), qx(x + 3);
  Eigen::Map<Eigen::Vector3d> dp(y_minus_x), dtheta(y_minus_x + 3);
  dp = py - px;
  dtheta = LogSO3(qx.conjugate() * qy);
  return true;
}

bool PoseManifold::MinusJacobian(const double* /*x*/, double* jacobian) const {
  Eigen::Map<Eigen::Matrix<double, 6, 7, Eigen::RowMajor>> J(jacobian);
  J.setZero();
  J.leftCols<6>().setIdentity();
  return true;
}

void PoseToBlock(const Transformation& T, double* block) {
  Eigen::Map<Eigen::Vector3d> p(block);
  Eigen::Map<Eigen::Quaterniond> q(block + 3);
  p = T.translation();
  q = T.rotation().normalized();
}

Transformation BlockToPose(const double* block) {
  return Transformation(Eigen::Map<const Eigen::Quaterniond>(block + 3).normalized(),
                        Eigen::Map<const Eigen::Vector3d>(block));
}

}  // namespace vilma::mapping
