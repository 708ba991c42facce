// The target-recording loader (target_detections.h, map_from_target.h): bad input names the
// file, line and field; the real EuRoC calibration slice gives a consistent map whose poses are
// the per-frame PnP.
#include <catch2/catch.hpp>

#include <filesystem>
#include <fstream>
#include <functional>

#include "test_skip.h"
#include "vilma/core/error.h"
#include "vilma/core/rig.h"
#include "vilma/mapping/from_poses/map_from_target.h"
#include "vilma/mapstore/consistency.h"

namespace vilma::mapping {
namespace {

namespace fs = std::filesystem;

const char* kHeader = "#ts,tag_rows,tag_cols,tag_size,tag_spacing,kp_x,kp_y,p_x,p_y,p_z,tag_id,corner_idx\n";

std::string WriteFile(const std::string& name, const std::string& text) {
  const fs::path dir = fs::temp_directory_path() / "vilma_target_test";
  fs::create_directories(dir);
  const std::string path = (dir / name).string();
  std::ofstream(path) << text;
  return path;
}

std::string ErrorOf(const std::function<void()>& f) {
  try {
    f();
  } catch (const InputError& e) {
    return e.what();
  }
  return "";
}

TEST_CASE("Target detections: bad rows name the file, the line and the field") {
  const std::string good_row = "100,6,6,0.088,0.3,175.9,336.8,0.0,0.0,0.0,0,0\n";
  const std::string ok = WriteFile("100.csv", std::string(kHeader) + good_row);
  const TargetImage image = ReadTargetImage(ok, 100);
  REQUIRE(image.corners.size() == 1);
  CHECK(image.corners[0].uv.x() == Approx(175.9));

  std::string e = ErrorOf([] {
    ReadTargetImage(WriteFile("a.csv", std::string(kHeader) + "100,6,6,0.088,0.3,175.9\n"), 100);
  });
  CHECK(e.find("a.csv: line 2") != std::string::npos);
  CHECK(e.find("12 columns") != std::string::npos);

  e = ErrorOf([] {
    ReadTargetImage(WriteFile("b.csv", std::string(kHeader) +
                                           "100,6,6,0.088,0.3,17x,336.8,0,0,0,0,0\n"), 100);
  });
  CHECK(e.find("b.csv: line 2: kp_x") != std::string::npos);

  e = ErrorOf([&] { ReadTargetImage(WriteFile("c.csv", std::string(kHeader) + good_row), 101); });
  CHECK(e.find("c.csv: line 2: ts") != std::string::npos);

  e = ErrorOf([&] {
    ReadTargetImage(WriteFile("d.csv", std::string(kHeader) + good_row + good_row), 100);
  });
  CHECK(e.find("d.csv: line 3: tag_id, corner_idx") != std::string::npos);

  e = ErrorOf([] {
    ReadTargetImage(WriteFile("e.csv", std::string(kHeader) +
                                           "100,6,6,0.088,0.3,1,2,0,0,0,0,7\n"), 100);
  });
  CHECK(e.find("e.csv: line 2: corner_idx") != std::string::npos);

  e = ErrorOf([] {
    ReadTargetImu(WriteFile("imu0.csv", "#ts,wx,wy,wz,ax,ay,az\n10,0,0,0,0,0,9.8\n"
                                        "10,0,0,0,0,0,9.8\n"));
  });
  CHECK(e.find("imu0.csv: line 3: ts") != std::string::npos);
  CHECK(e.find("increasing") != std::string::npos);

  e = ErrorOf([] { ReadTargetCamera("/nonexistent/vilma/cam0"); });
  CHECK(e.find("/nonexistent/vilma/cam0") != std::string::npos);
}

TEST_CASE("Target map from the EuRoC calibration slice: consistent, poses are the PnP") {
  const std::string recording = std::string(VILMA_SHARED_DATA_DIR) + "/euroc_imu_april";
  if (!fs::exists(recording + "/imu0.csv")) {
    VILMA_SKIP(recording << " not found");
  }
  const SensorRig rig = LoadSensorRig(std::string(VILMA_SOURCE_DIR) + "/config/euroc-rig.yaml");
  MapFromTargetOptions options;
  options.max_duration_s = 6.0;
  MapFromTargetSummary summary;
  const mapstore::VIMap map = BuildMapFromTarget(recording, rig, options, &summary);
  INFO(summary.FullReport());
  CHECK(mapstore::CheckMapConsistency(map).ok());
  CHECK(summary.vertices > 100);
  CHECK(summary.landmarks <= 144);  // 6 x 6 tags, 4 corners each
  CHECK(summary.landmarks > 100);
  CHECK(summary.imu_edges == summary.vertices - 1);
  CHECK(summary.pnp_rmse_median_px < 1.0);
  // Before any optimization, the map's camera poses are the PnP ones.
  const mapstore::MissionId m = map.mission_ids()[0];
  const TargetPnpComparison c = CompareWithTargetPnp(map, m, 0, 0.0, options.min_corners);
  CHECK(c.frames == summary.vertices);
  CHECK(c.position_rms_m < 1e-6);
  CHECK(c.rotation_rms_deg < 1e-4);
  // M is gravity aligned: the mean specific force points up in M.
  CHECK(!map.mission(m).baseframe_known);

  // A known clock shift moves every vertex time by it.
  options.camera_time_shift_ns = 5'000'000;
  const mapstore::VIMap shifted = BuildMapFromTarget(recording, rig, options);
  CHECK(shifted.vertex(shifted.VertexChain(shifted.mission_ids()[0]).front()).t_ns ==
        map.vertex(map.VertexChain(m).front()).t_ns + 5'000'000);

  MapFromTargetOptions bad;
  bad.min_corners = 3;
  CHECK_THROWS_AS(BuildMapFromTarget(recording, rig, bad), std::invalid_argument);
}

}  // namespace
}  // namespace vilma::mapping
