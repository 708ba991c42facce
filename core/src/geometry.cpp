#include "vilma/core/geometry.h"

#include <cmath>

namespace vilma {

Eigen::Matrix3d Skew(const Eigen::Vector3d& v) {
  Eigen::Matrix3d m;
  m << 0.0, -v.z(), v.y(),  //
      v.z(), 0.0, -v.x(),   //
      -v.y(), v.x(), 0.0;
  return m;
}

Eigen::Quaterniond ExpSO3(const Eigen::Vector3d& phi) {
  const double theta = phi.norm();
  const double half = 0.5 * theta;
  // sin(theta/2)/theta by its Taylor series near zero, to stay exact at small angles.
  const double k = theta < 1e-6 ? 0.5 - theta * theta / 48.0 : std::sin(half) / theta;
  Eigen::Quaterniond q(std::cos(half), k * phi.x(), k * phi.y(), k * phi.z());
  return q.normalized();
}

Eigen::Vector3d LogSO3(const Eigen::Quaterniond& q_in) {
  Eigen::Quaterniond q = q_in.normalized();
  if (q.w() < 0.0) q.coeffs() = -q.coeffs();  // shortest rotation: angle in [0, pi]
  const Eigen::Vector3d v = q.vec();
  const double s = v.norm();
  if (s < 1e-9) {
    // theta ~= 2 s; phi = 2 v / w to second order.
    return 2.0 * v / q.w();
  }
  const double theta = 2.0 * std::atan2(s, q.w());
  return theta / s * v;
}

Eigen::Matrix3d RightJacobianSO3(const Eigen::Vector3d& phi) {
  const double theta2 = phi.squaredNorm();
  const Eigen::Matrix3d W = Skew(phi);
  if (theta2 < 1e-10) return Eigen::Matrix3d::Identity() - 0.5 * W + W * W / 6.0;
  const double theta = std::sqrt(theta2);
  // 1 - cos(theta) = 2 sin^2(theta / 2): the direct difference loses ~eps / theta^2 relative
  // precision at small angles (6e-12 absolute in Jr at theta = 2e-5).
  const double sin_half = std::sin(0.5 * theta);
  return Eigen::Matrix3d::Identity() - (2.0 * sin_half * sin_half) / theta2 * W +
         (theta - std::sin(theta)) / (theta2 * theta) * W * W;
}

Eigen::Matrix3d RightJacobianInverseSO3(const Eigen::Vector3d& phi) {
  const double theta2 = phi.squaredNorm();
  const Eigen::Matrix3d W = Skew(phi);
  if (theta2 < 1e-10) return Eigen::Matrix3d::Identity() + 0.5 * W + W * W / 12.0;
  const double theta = std::sqrt(theta2);
  // (1 + cos(theta)) / (2 theta sin(theta)) = 1 / (2 theta tan(theta / 2)): the left form
  // divides two vanishing quantities near pi (1e-10 error in Jr^-1 at pi - 1e-6).
  return Eigen::Matrix3d::Identity() + 0.5 * W +
         (1.0 / theta2 - 1.0 / (2.0 * theta * std::tan(0.5 * theta))) * W * W;
}

Eigen::Matrix3d LeftJacobianSO3(const Eigen::Vector3d& phi) { return RightJacobianSO3(-phi); }

Transformation::Transformation(const Eigen::Matrix3d& R_A_B, const Eigen::Vector3d& p_A_B)
    : q_(Eigen::Quaterniond(R_A_B).normalized()), p_(p_A_B) {}

Transformation::Transformation(const Eigen::Matrix4d& T_A_B)
    : Transformation(Eigen::Matrix3d(T_A_B.topLeftCorner<3, 3>()),
                     Eigen::Vector3d(T_A_B.topRightCorner<3, 1>())) {}

Eigen::Matrix4d Transformation::matrix() const {
  Eigen::Matrix4d T = Eigen::Matrix4d::Identity();
  T.topLeftCorner<3, 3>() = rotationMatrix();
  T.topRightCorner<3, 1>() = p_;
  return T;
}

Transformation Transformation::inverse() const {
  const Eigen::Quaterniond q_inv = q_.conjugate();
  return Transformation(q_inv, -(q_inv * p_));
}

Transformation Transformation::operator*(const Transformation& T_B_C) const {
  return Transformation(q_ * T_B_C.q_, q_ * T_B_C.p_ + p_);
}

Transformation Transformation::Exp(const Vector6d& xi) {
  const Eigen::Vector3d rho = xi.head<3>();
  const Eigen::Vector3d phi = xi.tail<3>();
  return Transformation(ExpSO3(phi), LeftJacobianSO3(phi) * rho);
}

Vector6d Transformation::Log() const {
  const Eigen::Vector3d phi = LogSO3(q_);
  // Jl^-1(phi) = Jr^-1(-phi).
  Vector6d xi;
  xi.head<3>() = RightJacobianInverseSO3(-phi) * p_;
  xi.tail<3>() = phi;
  return xi;
}

Matrix6d Transformation::Adjoint() const {
  const Eigen::Matrix3d R = rotationMatrix();
  Matrix6d Ad = Matrix6d::Zero();
  Ad.topLeftCorner<3, 3>() = R;
  Ad.topRightCorner<3, 3>() = Skew(p_) * R;
  Ad.bottomRightCorner<3, 3>() = R;
  return Ad;
}

Transformation Interpolate(const Transformation& T_0, const Transformation& T_1, double alpha) {
  return Transformation(T_0.rotation().slerp(alpha, T_1.rotation()),
                        (1.0 - alpha) * T_0.translation() + alpha * T_1.translation());
}

bool IsRotationMatrix(const Eigen::Matrix3d& R, double tolerance) {
  if (!R.allFinite()) return false;
  const double orth_error = (R.transpose() * R - Eigen::Matrix3d::Identity()).cwiseAbs().maxCoeff();
  return orth_error <= tolerance && std::abs(R.determinant() - 1.0) <= 3.0 * tolerance;
}

double AngleBetween(const Eigen::Quaterniond& q_a, const Eigen::Quaterniond& q_b) {
  return LogSO3(q_a.conjugate() * q_b).norm();
}

}  // namespace vilma
