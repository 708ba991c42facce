#include "vilma/core/asl_dataset.h"

#include <catch2/catch.hpp>
#include <filesystem>
#include <fstream>
#include <stdexcept>
#include <tuple>

#include "core/test_data.h"
#include "vilma/core/error.h"

namespace vilma {
namespace {

namespace fs = std::filesystem;

void WriteText(const std::string& path, const std::string& text) {
  fs::create_directories(fs::path(path).parent_path());
  std::ofstream(path) << text;
}

TEST_CASE("The bundled EuRoC slice reads with the expected counts and stamps", "[asl]") {
  const std::string euroc = testing::EurocMicroDir();
  VILMA_REQUIRE_SHARED_DATA(euroc);
  const AslDataset dataset = AslDataset::Open(euroc);
  REQUIRE(dataset.cameras().size() == 2);
  CHECK(dataset.cameras()[0].name == "cam0");
  CHECK(dataset.cameras()[0].frames.size() == 95);
  // cam1/data.csv has 100 lines (a header and 99 rows) for 95 images: warn, skip, go on.
  CHECK(dataset.cameras()[1].frames.size() == 95);
  REQUIRE(dataset.warnings().size() == 1);
  CHECK_THAT(dataset.warnings()[0], Catch::Contains("cam1/data.csv") && Catch::Contains("4 rows"));
  CHECK(dataset.cameras()[0].frames.front().t_ns == 1403715273262142976);
  CHECK(dataset.cameras()[0].frames.back().t_ns == 1403715277962142976);
  CHECK(dataset.imu().size() == 29120);
  CHECK(dataset.imu().front().t_ns == 1403715273262142976);
  CHECK(dataset.imu().front().a_I.x() == Approx(9.0874956666666655));
  CHECK(dataset.ground_truth().size() == 2895);
  CHECK(dataset.ground_truth().front().q_W_I.w() == Approx(0.069433).margin(1e-6));
  CHECK(dataset.ground_truth().front().b_g.z() == Approx(0.0770299));
  // The vehicle is static: accelerometer magnitude close to gravity.
  CHECK(dataset.imu().front().a_I.norm() == Approx(9.81).margin(0.2));
  const cv::Mat image = AslDataset::LoadImage(dataset.cameras()[0].frames[0].image_path);
  CHECK(image.cols == 752);
  CHECK(image.rows == 480);
  CHECK(image.type() == CV_8UC1);
}

TEST_CASE("Writing a dataset and reading it back gives the same data", "[asl]") {
  testing::TempDir dir;
  AslDatasetWriter writer(dir.path(), 2);
  cv::Mat image(48, 64, CV_8UC1);
  cv::randu(image, 0, 255);
  for (int i = 0; i < 3; ++i) {
    writer.AddImage(0, 1000 + i * 50, image);
    writer.AddImage(1, 1000 + i * 50, image + i);
  }
  for (int i = 0; i < 10; ++i) {
    ImuSample s;
    s.t_ns = 1000 + i * 5;
    s.omega_I = Eigen::Vector3d(0.1 * i, -0.2, 1e-7);
    s.a_I = Eigen::Vector3d(0.0, 9.81, -1.0 / 3.0);
    writer.AddImu(s);
  }
  GroundTruthState gt;
  gt.t_ns = 1000;
  gt.p_W_I = Eigen::Vector3d(1.25, -2.5, 123.456789);
  gt.q_W_I = Eigen::Quaterniond(Eigen::AngleAxisd(0.3, Eigen::Vector3d(1, 2, 3).normalized()));
  gt.v_W = Eigen::Vector3d(0.5, 0, 0);
  gt.b_a = Eigen::Vector3d(0.01, 0.02, 0.03);
  writer.AddGroundTruth(gt);
  writer.Finish();

  const AslDataset dataset = AslDataset::Open(dir.path());
  CHECK(dataset.warnings().empty());
  REQUIRE(dataset.cameras().size() == 2);
  REQUIRE(dataset.cameras()[1].frames.size() == 3);
  CHECK(dataset.cameras()[1].frames[2].t_ns == 1100);
  const cv::Mat back = AslDataset::LoadImage(dataset.cameras()[1].frames[2].image_path);
  CHECK(cv::norm(back, image + 2, cv::NORM_INF) == 0.0);
  REQUIRE(dataset.imu().size() == 10);
  CHECK(dataset.imu()[9].omega_I.x() == Approx(0.9));
  CHECK(dataset.imu()[9].a_I.z() == Approx(-1.0 / 3.0).epsilon(1e-9));
  REQUIRE(dataset.ground_truth().size() == 1);
  CHECK((dataset.ground_truth()[0].p_W_I - gt.p_W_I).norm() < 1e-7);
  CHECK(dataset.ground_truth()[0].q_W_I.angularDistance(gt.q_W_I) < 1e-8);
  CHECK((dataset.ground_truth()[0].b_a - gt.b_a).norm() < 1e-12);
}

TEST_CASE("Malformed ASL files are rejected naming file, line and column", "[asl]") {
  testing::TempDir dir;
  const std::string mav0 = dir.File("mav0");
  WriteText(mav0 + "/cam0/data.csv", "#timestamp [ns],filename\n");
  SECTION("IMU row with a missing column") {
    WriteText(mav0 + "/imu0/data.csv", "#header\n100,1,2,3,4,5,6\n105,1,2,3,4,5\n");
    CHECK_THROWS_WITH(AslDataset::Open(dir.path()),
                      Catch::Contains("imu0/data.csv:3") && Catch::Contains("7 comma-separated") &&
                          Catch::Contains("got 6"));
  }
  SECTION("IMU value that is not a number") {
    WriteText(mav0 + "/imu0/data.csv", "100,1,2,3,4,x5,6\n");
    CHECK_THROWS_WITH(AslDataset::Open(dir.path()),
                      Catch::Contains("imu0/data.csv:1") && Catch::Contains("column 6") &&
                          Catch::Contains("'x5'"));
  }
  SECTION("Negative or fractional timestamp") {
    WriteText(mav0 + "/imu0/data.csv", "100.5,1,2,3,4,5,6\n");
    CHECK_THROWS_WITH(AslDataset::Open(dir.path()),
                      Catch::Contains("column 1") && Catch::Contains("whole nanoseconds"));
  }
  SECTION("Ground truth quaternion that is not unit") {
    WriteText(mav0 + "/state_groundtruth_estimate0/data.csv", "100,0,0,0,2,0,0,0\n");
    CHECK_THROWS_WITH(AslDataset::Open(dir.path()),
                      Catch::Contains("state_groundtruth_estimate0/data.csv:1") &&
                          Catch::Contains("unit quaternion"));
  }
  SECTION("Out-of-order and repeated IMU rows are sorted and deduplicated with warnings") {
    WriteText(mav0 + "/imu0/data.csv", "110,1,2,3,4,5,6\n100,1,2,3,4,5,6\n110,0,0,0,0,0,0\n");
    const AslDataset dataset = AslDataset::Open(dir.path());
    REQUIRE(dataset.imu().size() == 2);
    CHECK(dataset.imu()[0].t_ns == 100);
    CHECK(dataset.warnings().size() == 2);
  }
  SECTION("Not a dataset at all") {
    CHECK_THROWS_WITH(AslDataset::Open(dir.File("nothing")),
                      Catch::Contains("nothing") && Catch::Contains("mav0"));
  }
}

TEST_CASE("An unreadable image is named in the error", "[asl]") {
  testing::TempDir dir;
  WriteText(dir.File("bad.png"), "not a png");
  CHECK_THROWS_WITH(AslDataset::LoadImage(dir.File("bad.png")),
                    Catch::Contains("bad.png") && Catch::Contains("readable image"));
}


TEST_CASE("ArrivalOrder merges IMU and cameras by stamp, IMU first, cameras by index", "[asl]") {
  testing::TempDir dir;
  AslDatasetWriter writer(dir.path(), 2);
  const cv::Mat image(8, 8, CV_8UC1, cv::Scalar(7));
  // Frames at 1000 and 1050 on both cameras; IMU every 25 ns from 1000 to 1100.
  for (int i = 0; i < 2; ++i) {
    writer.AddImage(0, 1000 + i * 50, image);
    writer.AddImage(1, 1000 + i * 50, image);
  }
  for (int i = 0; i < 5; ++i) {
    ImuSample s;
    s.t_ns = 1000 + i * 25;
    writer.AddImu(s);
  }
  writer.Finish();
  const AslDataset dataset = AslDataset::Open(dir.path());

  // (t_ns, stream, index) in the order vilma-replay sends them.
  using Triple = std::tuple<int64_t, int, std::size_t>;
  auto triples = [](const std::vector<AslEvent>& events) {
    std::vector<Triple> t;
    for (const AslEvent& e : events) t.emplace_back(e.t_ns, e.stream, e.index);
    return t;
  };
  // The camera list's order does not matter: at equal stamps cameras go by index.
  const std::vector<Triple> expected = {{1000, -1, 0}, {1000, 0, 0}, {1000, 1, 0}, {1025, -1, 1},
                                        {1050, -1, 2}, {1050, 0, 1}, {1050, 1, 1}, {1075, -1, 3},
                                        {1100, -1, 4}};
  CHECK(triples(ArrivalOrder(dataset, {0, 1})) == expected);
  CHECK(triples(ArrivalOrder(dataset, {1, 0})) == expected);
  // One camera; a time window (inclusive).
  CHECK(triples(ArrivalOrder(dataset, {1}, 1025, 1050)) ==
        std::vector<Triple>{{1025, -1, 1}, {1050, -1, 2}, {1050, 1, 1}});
  CHECK(triples(ArrivalOrder(dataset, {})).size() == 5);
  CHECK_THROWS_AS(ArrivalOrder(dataset, {2}), std::out_of_range);
}

}  // namespace
}  // namespace vilma
