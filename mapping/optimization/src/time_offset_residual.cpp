#include "vilma/mapping/optimization/time_offset_residual.h"

#include <Eigen/Geometry>

#include "vilma/core/geometry.h"

namespace vilma::mapping {
namespace {

Eigen::Matrix3d Rotation(const double* pose) {
  return Eigen::Map<const Eigen::Quaterniond>(pose + 3).normalized().toRotationMatrix();
}

}  // namespace

Eigen::Vector3d TimeOffsetReprojectionCostFunction::PointInCamera(
    const double* pose_M_I, const double* speed_bias, const double* p_G, const double* pose_G_M,
    const double* pose_I_C, double delta_s, const Eigen::Vector3d& omega_m_I) {
  const Eigen::Vector3d omega_I = omega_m_I - Eigen::Map<const Eigen::Vector3d>(speed_bias + 3);
  const Eigen::Matrix3d R_shifted =
      Rotation(pose_M_I) * ExpSO3(omega_I * delta_s).toRotationMatrix();
  const Eigen::Vector3d t_shifted = Eigen::Map<const Eigen::Vector3d>(pose_M_I) +
                                    Eigen::Map<const Eigen::Vector3d>(speed_bias) * delta_s;
  const Eigen::Vector3d p_M =
      Rotation(pose_G_M).transpose() *
      (Eigen::Map<const Eigen::Vector3d>(p_G) - Eigen::Map<const Eigen::Vector3d>(pose_G_M));
  const Eigen::Vector3d p_I = R_shifted.transpose() * (p_M - t_shifted);
  return Rotation(pose_I_C).transpose() * (p_I - Eigen::Map<const Eigen::Vector3d>(pose_I_C));
}

bool TimeOffsetReprojectionCostFunction::Evaluate(double const* const* parameters,
                                                  double* residuals, double** jacobians) const {
  using Mat23 = Eigen::Matrix<double, 2, 3>;
  const double* pose_M_I = parameters[0];
  const double* speed_bias = parameters[1];
  const double delta = parameters[5][0];
  const Eigen::Matrix3d R_M_I = Rotation(pose_M_I);
  const Eigen::Matrix3d R_G_M = Rotation(parameters[3]);
  const Eigen::Matrix3d R_I_C = Rotation(parameters[4]);
  Eigen::Map<const Eigen::Vector3d> v_M(speed_bias);
  const Eigen::Vector3d omega_I = omega_m_I_ - Eigen::Map<const Eigen::Vector3d>(speed_bias + 3);
  const Eigen::Vector3d phi = omega_I * delta;
  const Eigen::Matrix3d E = ExpSO3(phi).toRotationMatrix();
  const Eigen::Matrix3d R_shifted = R_M_I * E;
  const Eigen::Vector3d t_shifted = Eigen::Map<const Eigen::Vector3d>(pose_M_I) + v_M * delta;

  const Eigen::Vector3d p_M =
      R_G_M.transpose() * (Eigen::Map<const Eigen::Vector3d>(parameters[2]) -
                           Eigen::Map<const Eigen::Vector3d>(parameters[3]));
  const Eigen::Vector3d q = R_M_I.transpose() * (p_M - t_shifted);
  const Eigen::Vector3d p_I = E.transpose() * q;
  const Eigen::Vector3d p_C =
      R_I_C.transpose() * (p_I - Eigen::Map<const Eigen::Vector3d>(parameters[4]));

  Eigen::Vector2d uv;
  Mat23 J_uv_p_C;
  const Camera::ProjectionResult result = camera_->Project(p_C, &uv, &J_uv_p_C);
  Eigen::Map<Eigen::Vector2d> r(residuals);
  const bool usable = (result == Camera::ProjectionResult::kValid ||
                       result == Camera::ProjectionResult::kOutsideImage) &&
                      uv.allFinite() && J_uv_p_C.allFinite();
  r = usable ? Eigen::Vector2d((uv - uv_) * inverse_sigma_) : Eigen::Vector2d::Zero();
  if (jacobians == nullptr) return true;

  const Mat23 J = usable ? Mat23(J_uv_p_C * inverse_sigma_) : Mat23::Zero();  // ∂r/∂p_C
  const Mat23 J_I = J * R_I_C.transpose();                                     // ∂r/∂p_I
  if (jacobians[0] != nullptr) {
    Eigen::Map<Eigen::Matrix<double, 2, 7, Eigen::RowMajor>> Jp(jacobians[0]);
    Jp.setZero();
    Jp.block<2, 3>(0, 0) = -J_I * R_shifted.transpose();
    Jp.block<2, 3>(0, 3) = J_I * E.transpose() * Skew(q);
  }
  if (jacobians[1] != nullptr) {
    Eigen::Map<Eigen::Matrix<double, 2, 9, Eigen::RowMajor>> Js(jacobians[1]);
    Js.setZero();
    Js.block<2, 3>(0, 0) = -J_I * R_shifted.transpose() * delta;
    Js.block<2, 3>(0, 3) = -J_I * Skew(p_I) * RightJacobianSO3(phi) * delta;
  }
  const Mat23 J_M = J_I * R_shifted.transpose();  // ∂r/∂p_M
  if (jacobians[2] != nullptr) {
    Eigen::Map<Eigen::Matrix<double, 2, 3, Eigen::RowMajor>> Jl(jacobians[2]);
    Jl = J_M * R_G_M.transpose();
  }
  if (jacobians[3] != nullptr) {
    Eigen::Map<Eigen::Matrix<double, 2, 7, Eigen::RowMajor>> Jb(jacobians[3]);
    Jb.setZero();
    Jb.block<2, 3>(0, 0) = -J_M * R_G_M.transpose();
    Jb.block<2, 3>(0, 3) = J_M * Skew(p_M);
  }
  if (jacobians[4] != nullptr) {
    Eigen::Map<Eigen::Matrix<double, 2, 7, Eigen::RowMajor>> Je(jacobians[4]);
    Je.setZero();
    Je.block<2, 3>(0, 0) = -J * R_I_C.transpose();
    Je.block<2, 3>(0, 3) = J * Skew(p_C);
  }
  if (jacobians[5] != nullptr) {
    Eigen::Map<Eigen::Vector2d> Jt(jacobians[5]);
    Jt = J_I * (-Skew(omega_I) * p_I - R_shifted.transpose() * v_M);
  }
  return true;
}

}  // namespace vilma::mapping
