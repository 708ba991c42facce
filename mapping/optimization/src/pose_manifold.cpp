#include "vilma/mapping/optimization/pose_manifold.h"

#include <Eigen/Core>

#include <cmath>

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

Eigen::Matrix<double, 6, Eigen::Dynamic> GaugePoseManifold::Basis(const double* x) const {
  Eigen::Matrix<double, 6, Eigen::Dynamic> B =
      Eigen::Matrix<double, 6, Eigen::Dynamic>::Zero(6, TangentSize());
  int column = 0;
  if (!fix_position_ && fixed_direction_.isZero()) {
    B.block<3, 3>(0, 0).setIdentity();
    column = 3;
  } else if (!fix_position_) {
    const Eigen::Vector3d d = fixed_direction_.normalized();
    const Eigen::Vector3d seed =
        std::abs(d.x()) < 0.9 ? Eigen::Vector3d::UnitX() : Eigen::Vector3d::UnitY();
    const Eigen::Vector3d e1 = d.cross(seed).normalized();
    B.block<3, 1>(0, 0) = e1;
    B.block<3, 1>(0, 1) = d.cross(e1);
    column = 2;
  }
  if (!fix_heading_) {
    B.block<3, 3>(3, column).setIdentity();
    return B;
  }
  // δ_k moves R by Exp(t_k) on A's side, t_k = e_k − e_z (g·e_k) (header); in the body frame
  // (PoseManifold's right perturbation, R Exp(Rᵀ t) = Exp(t) R) that is Rᵀ t_k.
  const Eigen::Quaterniond q = Eigen::Map<const Eigen::Quaterniond>(x + 3).normalized();
  Eigen::Quaterniond m = q * q_A_B_held_.conjugate();
  if (m.w() < 0.0) m.coeffs() = -m.coeffs();
  const Eigen::Vector2d g = Eigen::Vector2d(m.y(), -m.x()) / m.w();
  for (int k = 0; k < 2; ++k) {
    Eigen::Vector3d t = Eigen::Vector3d::Unit(k);
    t.z() = -g(k);
    B.block<3, 1>(3, column + k) = q.conjugate() * t;
  }
  return B;
}

Eigen::Matrix<double, Eigen::Dynamic, 6> GaugePoseManifold::BasisInverse(const double* x) const {
  const Eigen::Matrix<double, 6, Eigen::Dynamic> B = Basis(x);
  const Eigen::MatrixXd BtB = B.transpose() * B;
  return BtB.ldlt().solve(B.transpose());
}

bool GaugePoseManifold::Plus(const double* x, const double* delta, double* x_plus_delta) const {
  if (!fix_heading_) {
    const Eigen::Map<const Eigen::VectorXd> d(delta, TangentSize());
    const Eigen::Matrix<double, 6, 1> full = Basis(x) * d;
    return PoseManifold().Plus(x, full.data(), x_plus_delta);
  }
  // Position: the free part as a plain sum (held: unchanged).
  Eigen::Map<const Eigen::Vector3d> p(x);
  Eigen::Map<Eigen::Vector3d> p_out(x_plus_delta);
  p_out = p;
  int column = 0;
  if (!fix_position_) {
    const Eigen::Matrix<double, 6, Eigen::Dynamic> B = Basis(x);
    column = TangentSize() - 2;
    for (int k = 0; k < column; ++k) p_out += B.block<3, 1>(0, k) * delta[k];
  }
  // Rotation: Exp(h) R about the horizontal h of A, then back onto the held heading exactly.
  const Eigen::Quaterniond q = Eigen::Map<const Eigen::Quaterniond>(x + 3).normalized();
  const Eigen::Vector3d h(delta[column], delta[column + 1], 0.0);
  const Eigen::Quaterniond q1 = (ExpSO3(h) * q).normalized();
  const double c = YawAboutZ(q1 * q_A_B_held_.conjugate());
  Eigen::Map<Eigen::Quaterniond> q_out(x_plus_delta + 3);
  q_out = (Eigen::Quaterniond(Eigen::AngleAxisd(-c, Eigen::Vector3d::UnitZ())) * q1).normalized();
  return true;
}

bool GaugePoseManifold::PlusJacobian(const double* x, double* jacobian) const {
  Eigen::Map<Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor>> J(
      jacobian, 7, TangentSize());
  J.setZero();
  J.topRows<6>() = Basis(x);
  return true;
}

bool GaugePoseManifold::Minus(const double* y, const double* x, double* y_minus_x) const {
  Eigen::Matrix<double, 6, 1> full;
  PoseManifold().Minus(y, x, full.data());
  // Least-squares coordinates in the basis (orthonormal unless the heading is held away from
  // its reference).
  Eigen::Map<Eigen::VectorXd> out(y_minus_x, TangentSize());
  out = BasisInverse(x) * full;
  return true;
}

bool GaugePoseManifold::MinusJacobian(const double* x, double* jacobian) const {
  Eigen::Map<Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor>> J(
      jacobian, TangentSize(), 7);
  J.setZero();
  J.leftCols<6>() = BasisInverse(x);
  return true;
}

bool BaseframeTiltManifold::Plus(const double* x, const double* delta,
                                 double* x_plus_delta) const {
  const double full[6] = {0.0, 0.0, 0.0, delta[0], delta[1], 0.0};
  return PoseManifold().Plus(x, full, x_plus_delta);
}

bool BaseframeTiltManifold::PlusJacobian(const double* /*x*/, double* jacobian) const {
  Eigen::Map<Eigen::Matrix<double, 7, 2, Eigen::RowMajor>> J(jacobian);
  J.setZero();
  J(3, 0) = 1.0;
  J(4, 1) = 1.0;
  return true;
}

bool BaseframeTiltManifold::Minus(const double* y, const double* x, double* y_minus_x) const {
  double full[6];
  PoseManifold().Minus(y, x, full);
  y_minus_x[0] = full[3];
  y_minus_x[1] = full[4];
  return true;
}

bool BaseframeTiltManifold::MinusJacobian(const double* /*x*/, double* jacobian) const {
  Eigen::Map<Eigen::Matrix<double, 2, 7, Eigen::RowMajor>> J(jacobian);
  J.setZero();
  J(0, 3) = 1.0;
  J(1, 4) = 1.0;
  return true;
}

double YawAboutZ(const Eigen::Quaterniond& q) {
  const Eigen::Matrix3d R = q.normalized().toRotationMatrix();
  const double y = R(1, 0) - R(0, 1);
  const double x = R(0, 0) + R(1, 1);
  if (x == 0.0 && y == 0.0) return 0.0;
  return std::atan2(y, x);
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
