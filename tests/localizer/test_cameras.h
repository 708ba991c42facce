// Cameras and a query pose shared by the localizer's pose tests.
#pragma once

#include <Eigen/Core>
#include <Eigen/Geometry>

#include "vilma/core/camera.h"
#include "vilma/core/geometry.h"

namespace vilma::localizer::test {

// EuRoC's cam0 (752x480, radial-tangential): distortion strong at the image corners.
inline Camera EurocCamera() {
  Eigen::VectorXd dist(4);
  dist << -0.28340811, 0.07395907, 0.00019359, 1.76187114e-05;
  return Camera(752, 480, Eigen::Vector4d(458.654, 457.296, 367.215, 248.375),
                DistortionModel::kRadTan, dist);
}

// A query camera pose in G away from every axis.
inline const Transformation kT_G_C(
    Eigen::Quaterniond(Eigen::AngleAxisd(0.3, Eigen::Vector3d(1, 2, 3).normalized())),
    Eigen::Vector3d(0.5, -1.0, 2.0));

}  // namespace vilma::localizer::test
