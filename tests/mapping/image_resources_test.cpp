// Image resources (image_resources.h) and the map builder's keep_images option.
#include "vilma/mapping/image_resources.h"

#include <unistd.h>

#include <catch2/catch.hpp>
#include <filesystem>
#include <set>

#include "test_skip.h"
#include "vilma/core/asl_dataset.h"
#include "vilma/mapping/map_builder.h"
#include "vilma/mapstore/consistency.h"
#include "vilma/mapstore/map_io.h"
#include "vilma/sim/simulator.h"

using namespace vilma;
using namespace vilma::mapping;
namespace fs = std::filesystem;

TEST_CASE("image resources: ids depend on vertex and camera only, PNG is lossless", "[mapping]") {
  mapstore::IdGenerator ids(7);
  std::set<mapstore::Id> seen;
  for (int v = 0; v < 100; ++v) {
    const mapstore::VertexId vertex = ids.Next();
    for (uint32_t c = 0; c < 4; ++c) {
      const mapstore::ResourceId id = ImageResourceId(vertex, c);
      CHECK(id.IsValid());
      CHECK(id == ImageResourceId(vertex, c));
      CHECK(id != vertex);
      seen.insert(id);
    }
  }
  CHECK(seen.size() == 400);
  // Vertices that differ in one half only.
  CHECK(ImageResourceId({1, 2}, 0) != ImageResourceId({1, 3}, 0));
  CHECK(ImageResourceId({1, 2}, 0) != ImageResourceId({4, 2}, 0));

  cv::Mat grey(37, 53, CV_8UC1);
  cv::randu(grey, 0, 256);
  const cv::Mat back = DecodeImageResource(EncodeImagePng(grey));
  REQUIRE(back.type() == CV_8UC1);
  CHECK(cv::norm(back, grey, cv::NORM_INF) == 0.0);
  cv::Mat colour(5, 6, CV_8UC3, cv::Scalar(10, 20, 30));
  CHECK(DecodeImageResource(EncodeImagePng(colour)).type() == CV_8UC3);
  CHECK_THROWS_AS(EncodeImagePng(cv::Mat()), std::invalid_argument);
  CHECK_THROWS_AS(EncodeImagePng(cv::Mat(3, 3, CV_32FC1)), std::invalid_argument);
  CHECK_THROWS_AS(DecodeImageResource("not a png"), std::runtime_error);
}

TEST_CASE("map builder: keep_images stores every camera image of each vertex as PNG", "[mapping]") {
  const fs::path dataset_dir = fs::path(VILMA_SHARED_DATA_DIR) / "euroc_V1_01_micro";
  if (!fs::exists(dataset_dir)) VILMA_SKIP("no shared data: " << dataset_dir);
  const AslDataset dataset = AslDataset::Open(dataset_dir.string());
  REQUIRE(dataset.cameras().size() == 2);
  const SensorRig rig = sim::MakeEurocRig(true);
  const auto& frames0 = dataset.cameras()[0].frames;
  const auto& frames1 = dataset.cameras()[1].frames;

  // Features in cam0 only: cam1's images are kept all the same. The fifth vertex gets no cam1
  // image.
  auto build = [&](bool keep_images, std::vector<mapstore::MissionDelta>* deltas) {
    MapBuilderOptions options;
    options.cameras = {0};
    options.keep_images = keep_images;
    MapBuilder builder(rig, options, 5, "images");
    int vertices = 0;
    const auto& imu = dataset.imu();
    std::size_t next_imu = 0;
    for (std::size_t i = 0; i < 24 && i < frames0.size(); ++i) {
      mapping::FrameState state;
      state.t_ns = frames0[i].t_ns;
      // The dataset's IMU up to the frame and one beyond (the edges then cover the vertices).
      while (next_imu < imu.size() && imu[next_imu].t_ns <= state.t_ns) {
        builder.AddImu(imu[next_imu++]);
      }
      if (next_imu < imu.size()) builder.AddImu(imu[next_imu++]);
      state.T_M_I = Transformation(Eigen::Quaterniond::Identity(),
                                   Eigen::Vector3d(0.01 * static_cast<double>(i), 0, 0));
      if (!builder.WantsFrame(state.t_ns)) {
        builder.AddFrame(state, {});
        continue;
      }
      std::vector<cv::Mat> images(2);
      images[0] = AslDataset::LoadImage(frames0[i].image_path);
      if (vertices != 4 && frames1.at(i).t_ns == frames0[i].t_ns) {
        images[1] = AslDataset::LoadImage(frames1[i].image_path);
      }
      REQUIRE(builder.AddFrame(state, images));
      ++vertices;
      if (deltas != nullptr && vertices % 3 == 0) deltas->push_back(builder.TakeDelta());
    }
    builder.Finish();
    if (deltas != nullptr) deltas->push_back(builder.TakeDelta());
    INFO(builder.stats().FullReport());
    CHECK(builder.stats().images_kept == (keep_images ? 2 * vertices - 1 : 0));
    return builder.ReleaseMap();
  };

  std::vector<mapstore::MissionDelta> deltas;
  const mapstore::VIMap map = build(true, &deltas);
  const mapstore::MissionId mission = map.mission_ids().at(0);
  REQUIRE(map.vertex_ids(mission).size() == 12);
  std::size_t with_image = 0;
  for (const mapstore::VertexId& vid : map.vertex_ids(mission)) {
    const mapstore::Vertex& v = map.vertex(vid);
    REQUIRE(v.frames.size() == 2);
    for (uint32_t c = 0; c < 2; ++c) {
      const mapstore::ResourceId& rid = v.frames[c].image_resource_id;
      const auto& frames = dataset.cameras()[c].frames;
      const auto it = std::find_if(frames.begin(), frames.end(),
                                   [&](const CameraFrame& f) { return f.t_ns == v.t_ns; });
      REQUIRE(it != frames.end());
      if (!rid.IsValid()) {
        CHECK(c == 1);  // the fifth vertex's
        continue;
      }
      ++with_image;
      CHECK(rid == ImageResourceId(vid, c));
      const cv::Mat image =
          DecodeImageResource(*map.resources().Load(mapstore::ResourceType::kImage, rid));
      REQUIRE(image.type() == CV_8UC1);
      CHECK(cv::norm(image, AslDataset::LoadImage(it->image_path), cv::NORM_INF) == 0.0);
    }
  }
  CHECK(with_image == 23);
  INFO(mapstore::CheckMapConsistency(map).FullReport());
  CHECK(mapstore::CheckMapConsistency(map).ok());
  // Deltas carry no resources, hence no image ids.
  for (const mapstore::MissionDelta& d : deltas) {
    for (const mapstore::Vertex& v : d.vertices) {
      for (const mapstore::VisualFrame& f : v.frames) CHECK_FALSE(f.image_resource_id.IsValid());
    }
  }
  // Saved and loaded: the same ids and bytes.
  const fs::path dir =
      fs::path(VILMA_BINARY_DIR) / "test-data" / ("keep_images_" + std::to_string(::getpid()));
  fs::remove_all(dir);
  mapstore::SaveMap(map, dir.string());
  const mapstore::VIMap loaded = mapstore::LoadMap(dir.string());
  CHECK(mapstore::CheckMapConsistency(loaded).ok());
  CHECK(loaded.resources().List().size() == 23);
  for (const mapstore::VertexId& vid : map.vertex_ids(mission)) {
    for (uint32_t c = 0; c < 2; ++c) {
      const mapstore::ResourceId& rid = map.vertex(vid).frames[c].image_resource_id;
      CHECK(loaded.vertex(vid).frames[c].image_resource_id == rid);
      if (!rid.IsValid()) continue;
      CHECK(*loaded.resources().Load(mapstore::ResourceType::kImage, rid) ==
            *map.resources().Load(mapstore::ResourceType::kImage, rid));
    }
  }
  fs::remove_all(dir);

  // The default keeps none, and the rest of the map is the same (ids included).
  CHECK_FALSE(MapBuilderOptions().keep_images);
  const mapstore::VIMap plain = build(false, nullptr);
  CHECK(plain.resources().List().empty());
  CHECK(plain.vertex_ids(mission) == map.vertex_ids(mission));
  CHECK(plain.landmark_ids(mission) == map.landmark_ids(mission));
}
