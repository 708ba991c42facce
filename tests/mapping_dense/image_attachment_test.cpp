#include "vilma/mapping/dense/image_attachment.h"

#include <catch2/catch.hpp>
#include <filesystem>

#include "test_skip.h"
#include "vilma/core/asl_dataset.h"
#include "vilma/core/error.h"
#include "vilma/mapping/image_resources.h"
#include "vilma/mapping/map_builder.h"
#include "vilma/mapstore/consistency.h"
#include "vilma/sim/simulator.h"

using namespace vilma;
using namespace vilma::mapping;
namespace fs = std::filesystem;

namespace {

fs::path SharedDataset(const std::string& name) { return fs::path(VILMA_SHARED_DATA_DIR) / name; }

// A stereo mission with a vertex at every `every`-th cam0 stamp of the dataset (at most
// `max_frames` frames) plus `shift_ns`, with the dataset's IMU (so that the map is
// consistent), no images. The rig's cameras get time offset `offset_ns`.
mapstore::VIMap MapAtDatasetTimes(const AslDataset& dataset, std::size_t every,
                                  std::size_t max_frames, int64_t shift_ns = 0,
                                  int64_t offset_ns = 0) {
  SensorRig rig = sim::MakeEurocRig(true);
  for (CameraConfig& c : rig.cameras) c.time_offset_ns = offset_ns;
  MapBuilderOptions options;
  options.vertex_rate_hz = 0.0;
  MapBuilder builder(rig, options, 77, "images");
  const auto& frames = dataset.cameras()[0].frames;
  const auto& imu = dataset.imu();
  std::size_t next_imu = 0;
  for (std::size_t i = 0; i < frames.size() && i < max_frames; i += every) {
    FrameState state;
    state.t_ns = frames[i].t_ns + shift_ns;
    state.T_M_I = Transformation(Eigen::Quaterniond::Identity(),
                                 Eigen::Vector3d(0.01 * static_cast<double>(i), 0.0, 0.0));
    while (next_imu < imu.size() && imu[next_imu].t_ns <= state.t_ns) {
      builder.AddImu(imu[next_imu++]);
    }
    if (next_imu < imu.size()) builder.AddImu(imu[next_imu++]);
    REQUIRE(builder.AddFrame(state, {}));
  }
  builder.Finish();
  return builder.ReleaseMap();
}

// The dataset image of camera c at exactly t_ns ("" if none).
std::string ImageAt(const AslDataset& dataset, std::size_t c, int64_t t_ns) {
  for (const CameraFrame& f : dataset.cameras()[c].frames) {
    if (f.t_ns == t_ns) return f.image_path;
  }
  return "";
}

std::size_t CountImages(const mapstore::VIMap& map) {
  std::size_t n = 0;
  for (const mapstore::MissionId& m : map.mission_ids()) {
    for (const mapstore::VertexId& v : map.vertex_ids(m)) {
      for (const mapstore::VisualFrame& f : map.vertex(v).frames) {
        n += f.image_resource_id.IsValid() ? 1 : 0;
      }
    }
  }
  return n;
}

}  // namespace

TEST_CASE("attach images: EuRoC PNG stereo, nearest image per vertex camera", "[dense]") {
  const fs::path dir = SharedDataset("euroc_V1_01_micro");
  if (!fs::exists(dir)) VILMA_SKIP("no shared data: " << dir);
  const AslDataset dataset = AslDataset::Open(dir.string());
  REQUIRE(dataset.cameras().size() == 2);
  mapstore::VIMap map = MapAtDatasetTimes(dataset, 2, 1000);
  const mapstore::MissionId mission = map.mission_ids().at(0);
  const std::size_t num_vertices = map.vertex_ids(mission).size();
  REQUIRE(num_vertices == 48);

  // Expected: every vertex camera with an image at its stamp (cam1 lacks some).
  std::size_t expected = 0;
  for (const mapstore::VertexId& v : map.vertex_ids(mission)) {
    for (std::size_t c = 0; c < 2; ++c)
      expected += ImageAt(dataset, c, map.vertex(v).t_ns).empty() ? 0 : 1;
  }
  REQUIRE(expected >= num_vertices);

  ImageAttachmentOptions options;
  options.dataset = dir.string();
  const ImageAttachmentSummary summary = AttachImages(options, {}, &map);
  INFO(summary.BriefReport());
  CHECK(summary.missions == 1);
  CHECK(summary.vertices == static_cast<int64_t>(num_vertices));
  CHECK(summary.frames == static_cast<int64_t>(2 * num_vertices));
  CHECK(summary.attached == static_cast<int64_t>(expected));
  CHECK(summary.missing == static_cast<int64_t>(2 * num_vertices - expected));
  CHECK(summary.max_time_difference_s == 0.0);
  // The loader's warning about cam1's rows without images is passed on.
  REQUIRE(!summary.warnings.empty());
  CHECK_THAT(summary.FullReport(), Catch::Contains("cam1"));  // a warning line
  CHECK(CountImages(map) == expected);
  CHECK(mapstore::CheckMapConsistency(map).ok());
  for (const mapstore::VertexId& v : map.vertex_ids(mission)) {
    for (uint32_t c = 0; c < 2; ++c) {
      const mapstore::ResourceId& rid = map.vertex(v).frames[c].image_resource_id;
      const std::string path = ImageAt(dataset, c, map.vertex(v).t_ns);
      CHECK(rid.IsValid() == !path.empty());
      if (!rid.IsValid()) continue;
      CHECK(rid == ImageResourceId(v, c));
      const cv::Mat image =
          DecodeImageResource(*map.resources().Load(mapstore::ResourceType::kImage, rid));
      REQUIRE(image.type() == CV_8UC1);  // grey stays grey
      CHECK(cv::norm(image, AslDataset::LoadImage(path), cv::NORM_INF) == 0.0);
    }
  }

  // Deterministic: the same dataset and map give the same ids and bytes.
  mapstore::VIMap again = MapAtDatasetTimes(dataset, 2, 1000);
  AttachImages(options, {mission}, &again);
  REQUIRE(again.resources().List().size() == map.resources().List().size());
  for (const mapstore::ResourceInfo& info : map.resources().List()) {
    REQUIRE(again.resources().Has(mapstore::ResourceType::kImage, info.id));
    CHECK(*again.resources().Load(mapstore::ResourceType::kImage, info.id) ==
          *map.resources().Load(mapstore::ResourceType::kImage, info.id));
  }

  // A second run keeps the images (default), or replaces them under the same ids.
  const ImageAttachmentSummary kept = AttachImages(options, {}, &map);
  CHECK(kept.attached == 0);
  CHECK(kept.replaced == 0);
  CHECK(kept.skipped_existing == static_cast<int64_t>(expected));
  options.overwrite = true;
  const ImageAttachmentSummary replaced = AttachImages(options, {}, &map);
  CHECK(replaced.attached == 0);
  CHECK(replaced.replaced == static_cast<int64_t>(expected));
  CHECK(map.resources().List().size() == expected);  // no orphan resources
}

TEST_CASE("attach images: time tolerance and camera time offsets", "[dense]") {
  const fs::path dir = SharedDataset("euroc_V1_01_micro");
  if (!fs::exists(dir)) VILMA_SKIP("no shared data: " << dir);
  const AslDataset dataset = AslDataset::Open(dir.string());
  ImageAttachmentOptions options;
  options.dataset = dir.string();

  // Vertices 2 ms after the images: none within the default 1 ms, an error, map unchanged.
  mapstore::VIMap late = MapAtDatasetTimes(dataset, 4, 40, 2'000'000);
  CHECK_THROWS_AS(AttachImages(options, {}, &late), InputError);
  CHECK_THROWS_WITH(AttachImages(options, {}, &late),
                    Catch::Contains("euroc_V1_01_micro") &&
                        Catch::Contains("max_time_difference_s") && Catch::Contains("unchanged"));
  CHECK(late.resources().List().empty());
  CHECK(CountImages(late) == 0);
  // Within 3 ms they are found, 2 ms off.
  options.max_time_difference_s = 0.003;
  const ImageAttachmentSummary loose = AttachImages(options, {}, &late);
  CHECK(loose.attached == 20);
  CHECK(loose.max_time_difference_s == Approx(0.002).margin(1e-9));

  // The same 2 ms as the rig's time offset (t_imu = t_cam + offset): exact matches.
  options.max_time_difference_s = 0.001;
  mapstore::VIMap offset = MapAtDatasetTimes(dataset, 4, 40, 2'000'000, 2'000'000);
  const ImageAttachmentSummary exact = AttachImages(options, {}, &offset);
  CHECK(exact.attached == 20);
  CHECK(exact.max_time_difference_s == 0.0);
}

TEST_CASE("attach images: JPEG dataset, bad datasets and options", "[dense]") {
  const fs::path keyframes = SharedDataset("euroc_V1_01_keyframes");
  const fs::path moving = SharedDataset("euroc_V1_01_moving");
  if (!fs::exists(keyframes) || !fs::exists(moving)) {
    VILMA_SKIP("no shared data: " << keyframes << ", " << moving);
  }
  const AslDataset dataset = AslDataset::Open(keyframes.string());
  mapstore::VIMap map = MapAtDatasetTimes(dataset, 1, 6);
  ImageAttachmentOptions options;
  options.dataset = keyframes.string();
  const ImageAttachmentSummary summary = AttachImages(options, {}, &map);
  CHECK(summary.attached == 12);
  CHECK(summary.missing == 0);
  const mapstore::MissionId mission = map.mission_ids().at(0);
  const mapstore::VertexId v = map.vertex_ids(mission).at(3);
  const cv::Mat image = DecodeImageResource(*map.resources().Load(
      mapstore::ResourceType::kImage, map.vertex(v).frames[1].image_resource_id));
  CHECK(image.type() == CV_8UC1);
  const std::string jpeg = ImageAt(dataset, 1, map.vertex(v).t_ns);
  REQUIRE(!jpeg.empty());
  CHECK(cv::norm(image, AslDataset::LoadImage(jpeg, true), cv::NORM_INF) == 0.0);

  // A mono dataset for a stereo rig: refused, naming the dataset and the counts.
  mapstore::VIMap stereo = MapAtDatasetTimes(dataset, 1, 3);
  options.dataset = moving.string();
  CHECK_THROWS_AS(AttachImages(options, {}, &stereo), InputError);
  CHECK_THROWS_WITH(AttachImages(options, {}, &stereo), Catch::Contains("euroc_V1_01_moving") &&
                                                            Catch::Contains("2 cameras") &&
                                                            Catch::Contains("found 1"));
  CHECK(CountImages(stereo) == 0);
  options.dataset = (fs::path(VILMA_BINARY_DIR) / "no-such-dataset").string();
  CHECK_THROWS_AS(AttachImages(options, {}, &stereo), InputError);
  options.dataset = "";
  CHECK_THROWS_AS(AttachImages(options, {}, &stereo), std::invalid_argument);
  options.dataset = keyframes.string();
  options.max_time_difference_s = -1.0;
  CHECK_THAT(options.Validate(), Catch::Contains("max_time_difference_s"));
}
