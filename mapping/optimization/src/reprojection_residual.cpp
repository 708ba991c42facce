#include "vilma/mapping/optimization/reprojection_residual.h"

#include <Eigen/Geometry>
#include <cmath>
#include <stdexcept>

#include "vilma/core/geometry.h"

namespace vilma::mapping {

bool ReprojectionCostFunction::Evaluate(double const* const* parameters, double* residuals,
                                        double** jacobians) const {
  using Mat23 = Eigen::Matrix<double, 2, 3>;
  Eigen::Map<const Eigen::Vector3d> t_M_I(parameters[0]);
  const Eigen::Matrix3d R_M_I =
      Eigen::Map<const Eigen::Quaterniond>(parameters[0] + 3).normalized().toRotationMatrix();
  Eigen::Map<const Eigen::Vector3d> p_G(parameters[1]);
  Eigen::Map<const Eigen::Vector3d> t_G_M(parameters[2]);
  const Eigen::Matrix3d R_G_M =
      Eigen::Map<const Eigen::Quaterniond>(parameters[2] + 3).normalized().toRotationMatrix();
  Eigen::Map<const Eigen::Vector3d> t_I_C(parameters[3]);
  const Eigen::Matrix3d R_I_C =
      Eigen::Map<const Eigen::Quaterniond>(parameters[3] + 3).normalized().toRotationMatrix();

  const Eigen::Vector3d p_M = R_G_M.transpose() * (p_G - t_G_M);
  const Eigen::Vector3d p_I = R_M_I.transpose() * (p_M - t_M_I);
  const Eigen::Vector3d p_C = R_I_C.transpose() * (p_I - t_I_C);
  Eigen::Vector2d uv;
  Mat23 J_uv_p_C;
  const Camera::ProjectionResult result = camera_->Project(p_C, &uv, &J_uv_p_C);
  Eigen::Map<Eigen::Vector2d> r(residuals);
  const bool usable = (result == Camera::ProjectionResult::kValid ||
                       result == Camera::ProjectionResult::kOutsideImage) &&
                      uv.allFinite() && J_uv_p_C.allFinite();
  if (!usable) {
    r.setZero();
  } else {
    r = (uv - uv_) * inverse_sigma_;
  }
  if (jacobians == nullptr) return true;
  const Mat23 J = usable ? Mat23(J_uv_p_C * inverse_sigma_) : Mat23::Zero();
  const Mat23 J_I = J * R_I_C.transpose();  // ∂r/∂p_I
  if (jacobians[0] != nullptr) {
    Eigen::Map<Eigen::Matrix<double, 2, 7, Eigen::RowMajor>> Jp(jacobians[0]);
    Jp.setZero();
    Jp.block<2, 3>(0, 0) = -J_I * R_M_I.transpose();
    Jp.block<2, 3>(0, 3) = J_I * Skew(p_I);
  }
  const Mat23 J_M = J_I * R_M_I.transpose();  // ∂r/∂p_M
  if (jacobians[1] != nullptr) {
    Eigen::Map<Eigen::Matrix<double, 2, 3, Eigen::RowMajor>> Jl(jacobians[1]);
    Jl = J_M * R_G_M.transpose();
  }
  if (jacobians[2] != nullptr) {
    Eigen::Map<Eigen::Matrix<double, 2, 7, Eigen::RowMajor>> Jb(jacobians[2]);
    Jb.setZero();
    Jb.block<2, 3>(0, 0) = -J_M * R_G_M.transpose();
    Jb.block<2, 3>(0, 3) = J_M * Skew(p_M);
  }
  if (jacobians[3] != nullptr) {
    Eigen::Map<Eigen::Matrix<double, 2, 7, Eigen::RowMajor>> Je(jacobians[3]);
    Je.setZero();
    Je.block<2, 3>(0, 0) = -J * R_I_C.transpose();
    Je.block<2, 3>(0, 3) = J * Skew(p_C);
  }
  return true;
}

std::unique_ptr<ceres::LossFunction> ReprojectionLoss(const std::string& type, double scale_sigma,
                                                      double scale_px, double sigma_px) {
  if (!(sigma_px > 0 && std::isfinite(sigma_px))) {
    throw std::invalid_argument("ReprojectionLoss: sigma_px must be > 0");
  }
  if (!(scale_px >= 0 && std::isfinite(scale_px))) {
    throw std::invalid_argument("ReprojectionLoss: scale_px must be >= 0");
  }
  // The residual is (pi(p_C) - uv) / sigma_px: a pixel scale becomes scale_px / sigma_px.
  const double scale = scale_px > 0 ? scale_px / sigma_px : scale_sigma;
  if (!(scale > 0 && std::isfinite(scale))) {
    throw std::invalid_argument("ReprojectionLoss: scale_sigma must be > 0");
  }
  if (type == "none") return nullptr;
  if (type == "huber") return std::make_unique<ceres::HuberLoss>(scale);
  if (type == "cauchy") return std::make_unique<ceres::CauchyLoss>(scale);
  throw std::invalid_argument("ReprojectionLoss: unknown loss '" + type + "'");
}

}  // namespace vilma::mapping
