#include "vilma/mapping/dense/tum_depth_import.h"

#include <unistd.h>

#include <catch2/catch.hpp>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <opencv2/imgcodecs.hpp>

#include "mapping_dense/dense_test_util.h"
#include "vilma/core/error.h"
#include "vilma/mapping/dense/depth_map.h"

using namespace vilma;
using namespace vilma::mapping;
using vilma::mapping::testing::InputErrorOf;
namespace fs = std::filesystem;

namespace {

// The raw TUM value (depth [m] * 5000) of pixel (u, v) of image i; 0 in a corner (no depth).
uint16_t RawDepth(int i, int u, int v) {
  if (u < 4 && v < 4) return 0;
  return static_cast<uint16_t>(5000 + 300 * i + 7 * u + 11 * v);
}

cv::Mat DepthImage(int i, int width, int height) {
  cv::Mat raw(height, width, CV_16UC1);
  for (int v = 0; v < height; ++v) {
    for (int u = 0; u < width; ++u) raw.at<uint16_t>(v, u) = RawDepth(i, u, v);
  }
  return raw;
}

std::string TumStamp(int64_t t_ns) {
  char s[64];
  std::snprintf(s, sizeof(s), "%lld.%06lld", static_cast<long long>(t_ns / 1'000'000'000LL),
                static_cast<long long>((t_ns % 1'000'000'000LL) / 1000));
  return s;
}

// A TUM folder with one depth image per vertex of `map`, at the vertex time plus offsets_s[i]
// (missing entries: +10 ms), listed in reverse order under a header of comments.
fs::path WriteTumFolder(const std::string& name, const mapstore::VIMap& map,
                        const std::vector<double>& offsets_s, int width, int height) {
  const fs::path dir = fs::path(VILMA_BINARY_DIR) / "test-data" /
                       ("tum_depth_" + name + "_" + std::to_string(::getpid()));
  fs::remove_all(dir);
  fs::create_directories(dir / "depth");
  const std::vector<mapstore::VertexId>& vertices = map.vertex_ids(map.mission_ids().at(0));
  std::vector<std::string> lines;
  for (std::size_t i = 0; i < vertices.size(); ++i) {
    const double offset = i < offsets_s.size() ? offsets_s[i] : 0.01;
    const int64_t t_ns = map.vertex(vertices[i]).t_ns + static_cast<int64_t>(std::llround(offset * 1e9));
    const std::string file = "depth/" + TumStamp(t_ns) + ".png";
    REQUIRE(cv::imwrite((dir / file).string(), DepthImage(static_cast<int>(i), width, height)));
    lines.push_back(TumStamp(t_ns) + " " + file);
  }
  std::ofstream list(dir / "depth.txt");
  list << "# depth maps\n# file: 'rgbd_dataset_test.bag'\n# timestamp filename\n";
  for (auto it = lines.rbegin(); it != lines.rend(); ++it) list << *it << "\n";
  return dir;
}

testing::PlaneMap BareMap(int vertices) {
  testing::PlaneMapOptions o;
  o.depth = false;
  o.vertices = vertices;
  return testing::MakePlaneMap(o);
}

std::vector<mapstore::ResourceId> DepthIds(const mapstore::VIMap& map) {
  std::vector<mapstore::ResourceId> ids;
  for (const mapstore::VertexId& v : map.vertex_ids(map.mission_ids().at(0))) {
    ids.push_back(map.vertex(v).frames[0].depth_resource_id);
  }
  return ids;
}

}  // namespace

TEST_CASE("TUM depth import: nearest image within the tolerance, values kept", "[tum]") {
  testing::PlaneMap m = BareMap(4);
  const testing::Pinhole k;
  // Vertex 2's image is 30 ms away, the others 10 ms (or -5 ms).
  const fs::path dir = WriteTumFolder("basic", m.map, {0.01, -0.005, 0.03, 0.01}, k.width, k.height);
  TumDepthImportOptions options;
  options.dataset = dir.string();
  REQUIRE(options.Validate().empty());

  const TumDepthImportSummary summary = ImportTumDepth(&m.map, {}, options);
  INFO(summary.BriefReport());
  CHECK(summary.depth_images == 4);
  CHECK(summary.vertices == 4);
  CHECK(summary.attached == 3);
  CHECK(summary.no_image_in_time == 1);
  CHECK(summary.skipped_existing == 0);
  CHECK_THAT(summary.BriefReport(), Catch::StartsWith("3 of 4 vertices got a depth map (4 depth "
                                                      "images listed, 1 vertices without one in time"));
  const std::vector<mapstore::ResourceId> ids = DepthIds(m.map);
  CHECK(!ids[2].IsValid());
  for (int i : {0, 1, 3}) {
    REQUIRE(ids[i].IsValid());
    CHECK(m.map.resources().Has(mapstore::ResourceType::kDepthMap, ids[i]));
    const DepthMap depth = LoadDepthMap(m.map, m.vertices[i], 0);
    // A pinhole camera: its own intrinsics, no rotation.
    CHECK(depth.width() == k.width);
    CHECK(depth.height() == k.height);
    CHECK(depth.fx == k.fx);
    CHECK(depth.fy == k.fy);
    CHECK(depth.cx == k.cx);
    CHECK(depth.cy == k.cy);
    CHECK(depth.q_C_D.coeffs() == Eigen::Quaterniond::Identity().coeffs());
    double worst = 0.0;
    int zeros = 0;
    for (int v = 0; v < k.height; ++v) {
      for (int u = 0; u < k.width; ++u) {
        const double expected = RawDepth(i, u, v) / 5000.0;
        const float z = depth.depth_m.at<float>(v, u);
        if (expected == 0.0) {
          zeros += z == 0.0f;
        } else {
          worst = std::max(worst, std::abs(z - expected));
        }
      }
    }
    CHECK(zeros == 16);
    CHECK(worst <= 0.0005 + 1e-6);  // the stored unit: 1 mm
  }

  // A wider tolerance takes vertex 2's image as well; the others are kept (overwrite off).
  options.max_time_difference_s = 0.05;
  const TumDepthImportSummary more = ImportTumDepth(&m.map, {}, options);
  CHECK(more.attached == 1);
  CHECK(more.skipped_existing == 3);
  CHECK(more.no_image_in_time == 0);
  const std::vector<mapstore::ResourceId> after = DepthIds(m.map);
  for (int i : {0, 1, 3}) CHECK(after[i] == ids[i]);
  REQUIRE(after[2].IsValid());
  CHECK(LoadDepthMap(m.map, m.vertices[2], 0).depth_m.at<float>(10, 10) ==
        Approx(RawDepth(2, 10, 10) / 5000.0).margin(0.0005));

  // Overwrite with another unit: new content, new ids.
  options.overwrite = true;
  options.depth_unit_m = 0.0002;
  const TumDepthImportSummary replaced = ImportTumDepth(&m.map, {m.mission}, options);
  CHECK(replaced.attached == 4);
  CHECK(replaced.skipped_existing == 0);
  const std::vector<mapstore::ResourceId> replaced_ids = DepthIds(m.map);
  for (int i = 0; i < 4; ++i) CHECK(!(replaced_ids[i] == after[i]));
  CHECK(LoadDepthMap(m.map, m.vertices[0], 0).depth_m.at<float>(10, 10) ==
        Approx(RawDepth(0, 10, 10) / 5000.0).margin(0.0001));

  // Deterministic: the same import into a fresh map gives the same ids.
  testing::PlaneMap fresh = BareMap(4);
  ImportTumDepth(&fresh.map, {}, options);
  CHECK(DepthIds(fresh.map) == replaced_ids);
  fs::remove_all(dir);
}

TEST_CASE("TUM depth import: a distorted camera gets undistorted pinhole depth", "[tum]") {
  testing::PlaneMap m = BareMap(2);
  Camera& camera = m.map.mission(m.mission).rig.cameras[0].camera;
  const testing::Pinhole k;
  camera = Camera(k.width, k.height, Eigen::Vector4d(k.fx, k.fy, k.cx, k.cy), DistortionModel::kRadTan,
                  Eigen::Vector4d(-0.28, 0.07, 0.0002, 0.00002));
  const Camera pinhole = camera.UndistortedPinhole(0.0);
  const fs::path dir = WriteTumFolder("distorted", m.map, {}, k.width, k.height);
  TumDepthImportOptions options;
  options.dataset = dir.string();
  REQUIRE(ImportTumDepth(&m.map, {}, options).attached == 2);
  const DepthMap depth = LoadDepthMap(m.map, m.vertices[1], 0);
  CHECK(depth.fx == Approx(pinhole.fx()).epsilon(1e-12));
  CHECK(depth.fy == Approx(pinhole.fy()).epsilon(1e-12));
  CHECK(depth.cx == Approx(pinhole.cx()).epsilon(1e-12));
  CHECK(depth.cy == Approx(pinhole.cy()).epsilon(1e-12));
  CHECK(depth.fx != Approx(k.fx).epsilon(1e-3));  // not the distorted camera's
  // Each undistorted pixel holds the depth of the distorted pixel it comes from (nearest).
  cv::Mat map_x, map_y;
  camera.ComputeUndistortionMaps(pinhole, &map_x, &map_y);
  int compared = 0;
  for (int v = 0; v < k.height; v += 7) {
    for (int u = 0; u < k.width; u += 7) {
      const int su = static_cast<int>(std::lround(map_x.at<float>(v, u)));
      const int sv = static_cast<int>(std::lround(map_y.at<float>(v, u)));
      if (su < 4 || sv < 4 || su >= k.width || sv >= k.height) continue;
      CHECK(depth.depth_m.at<float>(v, u) == Approx(RawDepth(1, su, sv) / 5000.0).margin(0.0005 + 1e-6));
      ++compared;
    }
  }
  CHECK(compared > 300);
  fs::remove_all(dir);
}

TEST_CASE("TUM depth import: bad input is an error naming the file and leaves the map unchanged",
          "[tum]") {
  testing::PlaneMap m = BareMap(3);
  const testing::Pinhole k;
  const fs::path dir = WriteTumFolder("bad", m.map, {}, k.width, k.height);
  TumDepthImportOptions options;
  options.dataset = dir.string();
  const std::string list = (dir / "depth.txt").string();
  auto unchanged = [&] {
    for (const mapstore::ResourceId& id : DepthIds(m.map)) CHECK(!id.IsValid());
    CHECK(m.map.resources().List().empty());
  };
  using Catch::Contains;
  using Catch::StartsWith;

  SECTION("malformed depth.txt line") {
    std::ofstream(list, std::ios::app) << "1305031102.3 \n";
    CHECK_THAT(InputErrorOf([&] { ImportTumDepth(&m.map, {}, options); }),
               StartsWith(list + ":7: expected 'timestamp[s] filename'"));
    std::ofstream(list) << "# header\n\nnot-a-time depth/x.png\n";
    CHECK_THAT(InputErrorOf([&] { ImportTumDepth(&m.map, {}, options); }), StartsWith(list + ":3: "));
    std::ofstream(list) << "-1.0 depth/x.png\n";
    CHECK_THAT(InputErrorOf([&] { ImportTumDepth(&m.map, {}, options); }), StartsWith(list + ":1: "));
    std::ofstream(list) << "# only comments\n";
    CHECK_THAT(InputErrorOf([&] { ImportTumDepth(&m.map, {}, options); }),
               StartsWith(list + ": expected at least one depth image"));
    fs::remove(list);
    CHECK_THAT(InputErrorOf([&] { ImportTumDepth(&m.map, {}, options); }), StartsWith(list + ": "));
    unchanged();
  }
  SECTION("an 8-bit image") {
    const std::string file = (dir / "depth" / (TumStamp(m.map.vertex(m.vertices[1]).t_ns + 10'000'000) + ".png")).string();
    REQUIRE(fs::exists(file));
    REQUIRE(cv::imwrite(file, cv::Mat(k.height, k.width, CV_8UC1, cv::Scalar(100))));
    CHECK_THAT(InputErrorOf([&] { ImportTumDepth(&m.map, {}, options); }),
               StartsWith(file + ": expected a 16-bit one-channel PNG"));
    unchanged();
  }
  SECTION("a missing image") {
    const std::string file = (dir / "depth" / (TumStamp(m.map.vertex(m.vertices[2]).t_ns + 10'000'000) + ".png")).string();
    fs::remove(file);
    CHECK_THAT(InputErrorOf([&] { ImportTumDepth(&m.map, {}, options); }), StartsWith(file + ": "));
    unchanged();
  }
  SECTION("an image of another size than the camera's") {
    const std::string file = (dir / "depth" / (TumStamp(m.map.vertex(m.vertices[0]).t_ns + 10'000'000) + ".png")).string();
    REQUIRE(cv::imwrite(file, DepthImage(0, k.width + 2, k.height)));
    CHECK_THAT(InputErrorOf([&] { ImportTumDepth(&m.map, {}, options); }),
               StartsWith(file + ": size: expected 160x120") && Contains("found 162x120"));
    unchanged();
  }
  SECTION("no vertex has an image in time") {
    options.max_time_difference_s = 0.005;
    CHECK_THAT(InputErrorOf([&] { ImportTumDepth(&m.map, {}, options); }),
               StartsWith(dir.string() + ": expected depth images within 0.005") &&
                   Contains("found none (3 images listed)"));
    unchanged();
  }
  SECTION("a camera the rig does not have, invalid options") {
    options.camera = 1;
    CHECK_THAT(InputErrorOf([&] { ImportTumDepth(&m.map, {}, options); }),
               Contains("camera: expected a camera index below 1, found 1"));
    options.camera = 0;
    options.depth_scale_factor = 0.0;
    CHECK_THAT(InputErrorOf([&] { ImportTumDepth(&m.map, {}, options); }), Contains("depth_scale_factor"));
    options = TumDepthImportOptions();
    CHECK_THAT(InputErrorOf([&] { ImportTumDepth(&m.map, {}, options); }), Contains("dataset"));
    unchanged();
  }
  fs::remove_all(dir);
}
