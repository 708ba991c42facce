// Rigid-body geometry with the T_A_B notation of architecture.md section 5:
// p_A = T_A_B * p_B, Hamilton quaternions (Eigen's convention), q stored (w, x, y, z) on disk
// and on the wire.
#pragma once

#include <Eigen/Core>
#include <Eigen/Geometry>

namespace vilma {

using Vector6d = Eigen::Matrix<double, 6, 1>;
using Matrix6d = Eigen::Matrix<double, 6, 6>;

// [v]x such that Skew(a) * b = a.cross(b).
Eigen::Matrix3d Skew(const Eigen::Vector3d& v);

// SO(3) exponential: rotation by angle |phi| about phi/|phi| (Rodrigues), exact near zero.
Eigen::Quaterniond ExpSO3(const Eigen::Vector3d& phi);
// SO(3) logarithm: rotation vector with angle in [0, pi].
Eigen::Vector3d LogSO3(const Eigen::Quaterniond& q);

// Right Jacobian of SO(3): Exp(phi + d) ~= Exp(phi) Exp(Jr(phi) d) (Barfoot, eq. 7.77a with
// the sign convention of Forster et al. 2017, eq. 8). Left Jacobian: Jl(phi) = Jr(-phi).
Eigen::Matrix3d RightJacobianSO3(const Eigen::Vector3d& phi);
Eigen::Matrix3d RightJacobianInverseSO3(const Eigen::Vector3d& phi);
Eigen::Matrix3d LeftJacobianSO3(const Eigen::Vector3d& phi);

// A rigid transformation T_A_B (rotation q_A_B, translation p_A_B). Always holds a unit
// quaternion; the constructors normalize.
class Transformation {
 public:
  Transformation() : q_(Eigen::Quaterniond::Identity()), p_(Eigen::Vector3d::Zero()) {}
  Transformation(const Eigen::Quaterniond& q_A_B, const Eigen::Vector3d& p_A_B)
      : q_(q_A_B.normalized()), p_(p_A_B) {}
  Transformation(const Eigen::Matrix3d& R_A_B, const Eigen::Vector3d& p_A_B);
  // From a homogeneous 4x4 matrix; the rotation block must be orthonormal (not checked here,
  // see IsRotationMatrix for input validation).
  explicit Transformation(const Eigen::Matrix4d& T_A_B);
  // Takes q_A_B as given, without re-normalizing: for deserializing a Transformation that was
  // normalized when it was made, so that save/load round trips are bit-exact (normalizing an
  // already unit quaternion again changes its last bits about a third of the time).
  static Transformation FromUnitQuaternion(const Eigen::Quaterniond& q_A_B,
                                           const Eigen::Vector3d& p_A_B) {
    Transformation T;
    T.q_ = q_A_B;
    T.p_ = p_A_B;
    return T;
  }

  const Eigen::Quaterniond& rotation() const { return q_; }
  const Eigen::Vector3d& translation() const { return p_; }
  Eigen::Matrix3d rotationMatrix() const { return q_.toRotationMatrix(); }
  Eigen::Matrix4d matrix() const;

  Transformation inverse() const;
  Transformation operator*(const Transformation& T_B_C) const;
  Eigen::Vector3d operator*(const Eigen::Vector3d& p_B) const { return q_ * p_B + p_; }

  // SE(3) exponential of xi = [rho; phi]: R = Exp(phi), p = Jl(phi) rho.
  static Transformation Exp(const Vector6d& xi);
  // Inverse of Exp.
  Vector6d Log() const;

  // 6x6 adjoint such that T Exp(xi) T^-1 = Exp(Ad_T xi), for xi = [rho; phi].
  Matrix6d Adjoint() const;

 private:
  Eigen::Quaterniond q_;
  Eigen::Vector3d p_;
};

// Geodesic interpolation between T_0 (alpha = 0) and T_1 (alpha = 1): rotation by slerp,
// translation linear (the usual choice for trajectories sampled in time; it does not couple
// translation to rotation as the SE(3) geodesic would).
Transformation Interpolate(const Transformation& T_0, const Transformation& T_1, double alpha);

// True when R is orthonormal with determinant +1 within tolerance (per-entry of R^T R - I).
bool IsRotationMatrix(const Eigen::Matrix3d& R, double tolerance = 1e-6);

// Rotation angle [rad] between two orientations, in [0, pi].
double AngleBetween(const Eigen::Quaterniond& q_a, const Eigen::Quaterniond& q_b);

}  // namespace vilma
