#include "vilma/estimator/given_state_io.h"

#include <catch2/catch.hpp>
#include <filesystem>
#include <fstream>
#include <unistd.h>

#include "vilma/core/error.h"

namespace vilma::estimator {
namespace {

std::string TempFile(const std::string& name, const std::string& text) {
  const std::filesystem::path path = std::filesystem::temp_directory_path() /
                                     ("vilma_given_state_" + std::to_string(::getpid()) + name);
  std::ofstream(path) << text;
  return path.string();
}

}  // namespace

TEST_CASE("given state from a TUM file: interpolated pose, velocity from differences") {
  // 20 Hz poses moving at (1, -2, 0.5) m/s, rotating about z.
  std::string text = "# t x y z qx qy qz qw\n";
  for (int i = 0; i < 20; ++i) {
    const double t = 10.0 + 0.05 * i;
    const double half = 0.05 * i;  // yaw / 2
    text += std::to_string(t) + " " + std::to_string(1.0 * (t - 10)) + " " +
            std::to_string(-2.0 * (t - 10)) + " " + std::to_string(0.5 * (t - 10)) + " 0 0 " +
            std::to_string(std::sin(half)) + " " + std::to_string(std::cos(half)) + "\n";
  }
  const std::string path = TempFile("a.txt", text);
  GivenStateSource source;
  const GivenState s = LoadGivenState(path, 10'325'000'000, &source);
  CHECK_FALSE(source.velocity_from_file);
  CHECK_FALSE(source.biases_from_file);
  CHECK((s.p_M_I - Eigen::Vector3d(0.325, -0.65, 0.1625)).norm() < 1e-5);
  CHECK((s.v_M - Eigen::Vector3d(1.0, -2.0, 0.5)).norm() < 1e-4);
  CHECK(s.b_g.norm() == 0.0);
  CHECK(s.sigma_gyro_bias > GivenState().sigma_gyro_bias);  // unknown biases: wider
  const double yaw = 2.0 * std::atan2(s.q_M_I.z(), s.q_M_I.w());
  CHECK(yaw == Approx(0.325 * 2.0).margin(1e-5));  // yaw = 2 * (t - 10) rad/s
  CHECK_THROWS_WITH(LoadGivenState(path, 12'000'000'000),
                    Catch::Contains(path) && Catch::Contains("covers"));
  std::filesystem::remove(path);
}

TEST_CASE("given state from an ASL ground truth CSV: velocity and biases from the file") {
  std::string text = "#timestamp,p_x,p_y,p_z,q_w,q_x,q_y,q_z,v_x,v_y,v_z,bw_x,bw_y,bw_z,ba_x,ba_y,ba_z\n";
  text += "1000000000,0,0,0,1,0,0,0,1,0,0,0.01,0.02,0.03,0.1,0.2,0.3\n";
  text += "1050000000,0.05,0,0,1,0,0,0,3,0,0,0.03,0.02,0.03,0.1,0.2,0.5\n";
  const std::string path = TempFile("b.csv", text);
  GivenStateSource source;
  const GivenState s = LoadGivenState(path, 1'025'000'000, &source);
  CHECK(source.velocity_from_file);
  CHECK(source.biases_from_file);
  CHECK((s.v_M - Eigen::Vector3d(2, 0, 0)).norm() < 1e-12);
  CHECK((s.b_g - Eigen::Vector3d(0.02, 0.02, 0.03)).norm() < 1e-12);
  CHECK((s.b_a - Eigen::Vector3d(0.1, 0.2, 0.4)).norm() < 1e-12);
  CHECK(s.p_M_I.x() == Approx(0.025));
  CHECK(s.t_ns == 1'025'000'000);
  std::filesystem::remove(path);
  CHECK_THROWS_AS(LoadGivenState("/nonexistent/gt.csv", 0), InputError);
}

}  // namespace vilma::estimator
