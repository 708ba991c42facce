#include "vilma/mapping/dense/stereo_depth.h"

#include <algorithm>
#include <catch2/catch.hpp>
#include <cmath>
#include <iostream>

#include "vilma/core/error.h"
#include "vilma/sim/simulator.h"

using namespace vilma;
using namespace vilma::mapping;

namespace {

double Percentile(std::vector<double> v, double q) {
  std::sort(v.begin(), v.end());
  return v.empty() ? 0.0 : v[std::min(v.size() - 1, static_cast<std::size_t>(q * v.size()))];
}

}  // namespace

TEST_CASE("stereo pairs of a rig", "[stereo]") {
  const SensorRig stereo = sim::MakeEurocRig(true);
  const std::vector<StereoPair> pairs = FindStereoPairs(stereo, StereoPairOptions());
  REQUIRE(pairs.size() == 1);
  CHECK(pairs[0].left == 0);  // EuRoC's cam1 sits on cam0's +x side
  CHECK(pairs[0].right == 1);
  CHECK(pairs[0].baseline_m == Approx(0.110).margin(0.002));

  // Swapped cameras: the pair is found with the roles swapped.
  SensorRig swapped = stereo;
  std::swap(swapped.cameras[0], swapped.cameras[1]);
  const std::vector<StereoPair> swapped_pairs = FindStereoPairs(swapped, StereoPairOptions());
  REQUIRE(swapped_pairs.size() == 1);
  CHECK(swapped_pairs[0].left == 1);

  // A mono rig and a rig whose second camera looks sideways have no pair, and say why.
  const SensorRig mono = sim::MakeEurocRig(false);
  CHECK(FindStereoPairs(mono, StereoPairOptions()).empty());
  CHECK(ExplainNoStereoPair(mono, StereoPairOptions()).find("stereo needs two") != std::string::npos);
  SensorRig sideways = stereo;
  sideways.cameras[1].T_I_C =
      stereo.cameras[1].T_I_C *
      Transformation(Eigen::Quaterniond(Eigen::AngleAxisd(M_PI / 2, Eigen::Vector3d::UnitY())),
                     Eigen::Vector3d::Zero());
  CHECK(FindStereoPairs(sideways, StereoPairOptions()).empty());
  CHECK(ExplainNoStereoPair(sideways, StereoPairOptions()).find("optical axes 90.0 deg") !=
        std::string::npos);
}

TEST_CASE("rectification: a point lands on the same row in both rectified views", "[stereo]") {
  const SensorRig rig = sim::MakeEurocRig(true);
  const std::vector<StereoPair> pairs = FindStereoPairs(rig, StereoPairOptions());
  REQUIRE(pairs.size() == 1);
  const StereoRectification r = ComputeStereoRectification(
      rig.cameras[0].camera, rig.cameras[1].camera, pairs[0].T_L_R);
  // For points in front of the rig, project into D of both cameras: same v, u_L - u_R = f B / z.
  for (const Eigen::Vector3d& p_L : {Eigen::Vector3d(0.3, -0.2, 2.0), Eigen::Vector3d(-1.0, 0.5, 4.0),
                                     Eigen::Vector3d(0.0, 0.0, 1.0)}) {
    const Eigen::Vector3d p_DL = r.R_L_D.transpose() * p_L;
    const Eigen::Vector3d p_DR = r.R_R_D.transpose() * (pairs[0].T_L_R.inverse() * p_L);
    const double v_left = r.f * p_DL.y() / p_DL.z() + r.cy;
    const double v_right = r.f * p_DR.y() / p_DR.z() + r.cy;
    const double disparity = r.f * (p_DL.x() / p_DL.z() - p_DR.x() / p_DR.z());
    CHECK(v_left == Approx(v_right).margin(1e-9));
    CHECK(p_DL.z() == Approx(p_DR.z()).margin(1e-9));
    CHECK(disparity == Approx(r.f * r.baseline_m / p_DL.z()).epsilon(1e-9));
    // The remap table of the left view points at the camera's own projection of the point.
    const int u = static_cast<int>(std::round(r.f * p_DL.x() / p_DL.z() + r.cx));
    const int v = static_cast<int>(std::round(v_left));
    const Eigen::Vector3d ray_L = r.R_L_D * Eigen::Vector3d((u - r.cx) / r.f, (v - r.cy) / r.f, 1.0);
    Eigen::Vector2d kp;
    REQUIRE(rig.cameras[0].camera.Project(ray_L, &kp) == Camera::ProjectionResult::kValid);
    CHECK(r.map_left_x.at<float>(v, u) == Approx(kp.x()).margin(1e-3));
    CHECK(r.map_left_y.at<float>(v, u) == Approx(kp.y()).margin(1e-3));
  }
}

TEST_CASE("SGBM depth of simulated stereo frames against the rendered geometry", "[stereo]") {
  sim::SimOptions sim_options;
  sim_options.world = "room";
  sim_options.seconds = 12.0;
  sim_options.stereo = true;
  sim::Simulator simulator(sim_options);
  const SensorRig& rig = simulator.rig();
  const std::vector<StereoPair> pairs = FindStereoPairs(rig, StereoPairOptions());
  REQUIRE(pairs.size() == 1);
  const StereoRectification r = ComputeStereoRectification(
      rig.cameras[0].camera, rig.cameras[1].camera, pairs[0].T_L_R);
  StereoDepthOptions options;

  std::vector<double> relative_errors, signed_errors;
  double valid_share = 0.0;
  const std::vector<int> frames = {80, 140, 200};
  for (int frame : frames) {
    cv::Mat left, right;
    simulator.RenderFrame(0, frame, &left);
    simulator.RenderFrame(1, frame, &right);
    const DepthMap depth = ComputeStereoDepth(r, left, right, options);
    REQUIRE(depth.width() == left.cols);
    const Transformation T_W_C = simulator.T_W_C(0, simulator.frame_time_ns(frame));
    int valid = 0;
    for (int v = 0; v < depth.height(); v += 2) {
      for (int u = 0; u < depth.width(); u += 2) {
        const float z = depth.depth_m.at<float>(v, u);
        if (!(z > 0.0f)) continue;
        ++valid;
        // True depth: the world ray cast along the pixel's ray of D.
        const Eigen::Vector3d ray_D((u - depth.cx) / depth.fx, (v - depth.cy) / depth.fy, 1.0);
        const Eigen::Vector3d direction_W = (T_W_C.rotation() * (depth.q_C_D * ray_D)).normalized();
        const double distance = simulator.world().RayCast(T_W_C.translation(), direction_W);
        if (!std::isfinite(distance)) continue;
        const double z_true = distance / ray_D.norm();
        relative_errors.push_back(std::abs(z - z_true) / z_true);
        signed_errors.push_back((z - z_true) / z_true);
      }
    }
    valid_share += static_cast<double>(valid) / ((depth.width() / 2) * (depth.height() / 2));
  }
  valid_share /= frames.size();
  const double median = Percentile(relative_errors, 0.5);
  const double p90 = Percentile(relative_errors, 0.9);
  std::cout << "SGBM on simulated frames: " << 100.0 * valid_share << " % of pixels with depth, "
            << "relative depth error median " << 100.0 * median << " %, p90 " << 100.0 * p90
            << " %, signed median " << 100.0 * Percentile(signed_errors, 0.5) << " %\n";
  CHECK(valid_share > 0.5);
  CHECK(median < 0.025);
  CHECK(p90 < 0.08);
}

TEST_CASE("stereo depth options are validated", "[stereo]") {
  StereoDepthOptions options;
  CHECK(options.Validate().empty());
  options.sgbm.num_disparities = 40;
  CHECK(options.Validate().find("num_disparities") == 0);
  options = StereoDepthOptions();
  options.sgbm.block_size = 4;
  CHECK(options.Validate().find("block_size") == 0);
  options = StereoDepthOptions();
  options.max_depth_m = 100.0;  // 100 m at 1 mm does not fit 16 bits
  CHECK(options.Validate().find("depth_unit_m") == 0);
  options = StereoDepthOptions();
  options.sgbm.mode = "fast";
  CHECK(options.Validate().find("mode") == 0);
}
