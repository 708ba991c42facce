// The sync stage without LCM: input items in, filter items out (daemon/src/sync_stage.h).
#include "sync_stage.h"

#include <catch2/catch.hpp>
#include <vector>

namespace vilma::daemon {
namespace {

InputItem Imu(int64_t t_ns) {
  InputItem item;
  item.kind = InputItem::Kind::kImu;
  item.imu.t_ns = t_ns;
  item.imu.a_I = Eigen::Vector3d(0, 0, 9.81);
  return item;
}

InputItem Image(int64_t t_ns, const cv::Mat& image) {
  InputItem item;
  item.kind = InputItem::Kind::kImage;
  item.camera = 0;
  item.t_cam_ns = t_ns;
  item.image = image;
  return item;
}

// 200 Hz IMU and 20 Hz images over [t0, t0 + seconds], then the stage runs to the end.
void Feed(SyncStage* stage, int64_t t0, double seconds, const cv::Mat& image) {
  const int n = static_cast<int>(seconds * 200);
  for (int i = 0; i <= n; ++i) {
    const int64_t t = t0 + int64_t{5'000'000} * i;
    REQUIRE(stage->queue().push(Imu(t)));
    if (i % 10 == 0) REQUIRE(stage->queue().push(Image(t, image)));
  }
}

std::vector<FilterItem> Drain(Spsc<FilterItem>* queue) {
  std::vector<FilterItem> items;
  FilterItem item;
  while (queue->pop(item)) items.push_back(item);
  return items;
}

SyncStageOptions Options() {
  SyncStageOptions o;
  o.camera_offsets_ns = {0};
  o.input_capacity = 8192;
  o.max_frames_in_flight = 1000;
  return o;
}

}  // namespace

TEST_CASE("sync stage: every IMU sample once and in order, frames with their camera stamp",
          "[daemon][sync]") {
  Pipeline p(true);
  Spsc<FilterItem> out(8192);
  std::atomic<int> in_flight{0};
  SyncStage stage(Options(), &p, &out, &in_flight);
  const cv::Mat image(8, 8, CV_8UC1, cv::Scalar(7));
  const int64_t t0 = 100'000'000'000;
  Feed(&stage, t0, 2.0, image);
  p.input_done.store(true);
  stage.Run();
  CHECK(p.sync_done.load());
  const std::vector<FilterItem> items = Drain(&out);
  int64_t last_imu = 0;
  int frames = 0, imu = 0;
  for (const FilterItem& item : items) {
    REQUIRE(item.kind != FilterItem::Kind::kRestart);
    if (item.kind == FilterItem::Kind::kImu) {
      CHECK(item.imu.t_ns > last_imu);  // strictly increasing: no sample twice
      last_imu = item.imu.t_ns;
      ++imu;
    } else {
      CHECK((item.t_cam_ns - t0) % 50'000'000 == 0);
      CHECK(item.t_cam_ns <= last_imu);  // the IMU covers the frame before it goes out
      CHECK(item.image.data == image.data);
      CHECK(item.map_images[0].empty());  // no map building
      ++frames;
    }
  }
  // 41 images, each released once the IMU has a sample at its stamp (every one has).
  CHECK(frames == 41);
  CHECK(frames == in_flight.load());
  // Every sample, up to the one at the last frame's stamp.
  CHECK(imu == 401);
  CHECK(last_imu == t0 + 2'000'000'000);
  CHECK(p.counters.Get(kSyncImuReceived) == 401);
  CHECK(p.counters.Get(kSyncFramesReleased) == 41);
  CHECK(p.counters.Get(kFramesDroppedBusy) == 0);
}

TEST_CASE("sync stage: a time jump restarts the filter", "[daemon][sync]") {
  Pipeline p(true);
  Spsc<FilterItem> out(8192);
  std::atomic<int> in_flight{0};
  SyncStage stage(Options(), &p, &out, &in_flight);
  const cv::Mat image(8, 8, CV_8UC1, cv::Scalar(7));
  Feed(&stage, 100'000'000'000, 1.0, image);
  Feed(&stage, 200'000'000'000, 1.0, image);  // 99 s later
  p.input_done.store(true);
  stage.Run();
  const std::vector<FilterItem> items = Drain(&out);
  int restarts = 0;
  int64_t last_frame = 0;
  for (const FilterItem& item : items) {
    if (item.kind == FilterItem::Kind::kRestart) {
      ++restarts;
      CHECK(last_frame < 200'000'000'000);  // between the two time bases
      // The first stamp on the new base (the filter stage restarts or resumes by it).
      CHECK(item.imu.t_ns >= 200'000'000'000);
      CHECK(item.imu.t_ns <= 200'000'000'000 + 5'000'000);
    } else if (item.kind == FilterItem::Kind::kFrame) {
      if (restarts == 0) CHECK(item.t_cam_ns < 200'000'000'000);
      if (restarts == 1) CHECK(item.t_cam_ns >= 200'000'000'000);
      last_frame = item.t_cam_ns;
    }
  }
  CHECK(restarts == 1);
  // Counted by the filter stage, which decides between restart and resume.
  CHECK(p.counters.Get(kTimeJumpRestarts) == 0);
}

TEST_CASE("sync stage: live, frames are thinned while the filter is behind, IMU never",
          "[daemon][sync]") {
  Pipeline p(false);
  Spsc<FilterItem> out(8192);
  std::atomic<int> in_flight{0};
  SyncStageOptions o = Options();
  o.max_frames_in_flight = 3;
  o.with_all_images = true;
  SyncStage stage(o, &p, &out, &in_flight);
  const cv::Mat image(8, 8, CV_8UC1, cv::Scalar(7));
  Feed(&stage, 100'000'000'000, 2.0, image);
  p.input_done.store(true);
  stage.Run();  // nobody filters: in_flight only grows
  const std::vector<FilterItem> items = Drain(&out);
  int frames = 0, imu = 0;
  for (const FilterItem& item : items) {
    if (item.kind == FilterItem::Kind::kFrame) {
      ++frames;
      CHECK(item.map_images[0].data == image.data);  // map building: every camera's image
    }
    if (item.kind == FilterItem::Kind::kImu) ++imu;
  }
  CHECK(frames == 3);
  CHECK(in_flight.load() == 3);
  CHECK(p.counters.Get(kFramesDroppedBusy) == 38);
  CHECK(p.counters.Get(kImuDroppedFilterQueue) == 0);
  // The same IMU as without thinning.
  Pipeline p2(false);
  Spsc<FilterItem> out2(8192);
  std::atomic<int> in_flight2{0};
  SyncStage stage2(Options(), &p2, &out2, &in_flight2);
  Feed(&stage2, 100'000'000'000, 2.0, image);
  p2.input_done.store(true);
  stage2.Run();
  int imu2 = 0;
  for (const FilterItem& item : Drain(&out2)) imu2 += item.kind == FilterItem::Kind::kImu;
  CHECK(imu == imu2);
}

TEST_CASE("sync stage: bad synchronizer options are an input error", "[daemon][sync]") {
  Pipeline p(true);
  Spsc<FilterItem> out(16);
  std::atomic<int> in_flight{0};
  SyncStageOptions o = Options();
  o.sync.max_pending_frames = 0;
  CHECK_THROWS_WITH(SyncStage(o, &p, &out, &in_flight), Catch::Contains("daemon options: sync:"));
}

TEST_CASE("sync stage: stereo frames carry the second camera's image, a missing one is released "
          "without it",
          "[daemon][sync][stereo]") {
  Pipeline p(true);
  Spsc<FilterItem> out(8192);
  std::atomic<int> in_flight{0};
  SyncStageOptions o = Options();
  o.camera_offsets_ns = {0, 0};
  o.stereo_camera = 1;
  SyncStage stage(o, &p, &out, &in_flight);
  const cv::Mat left(8, 8, CV_8UC1, cv::Scalar(1)), right(8, 8, CV_8UC1, cv::Scalar(2));
  const int64_t t0 = 100'000'000'000;
  const int dropped_frame = 7;  // CAM1's image of this frame never comes
  for (int i = 0; i <= 400; ++i) {
    const int64_t t = t0 + int64_t{5'000'000} * i;
    REQUIRE(stage.queue().push(Imu(t)));
    if (i % 10 != 0) continue;
    REQUIRE(stage.queue().push(Image(t, left)));
    if (i / 10 == dropped_frame) continue;
    InputItem second = Image(t, right);
    second.camera = 1;
    REQUIRE(stage.queue().push(second));
  }
  p.input_done.store(true);
  stage.Run();
  int frames = 0, without_second = 0;
  for (const FilterItem& item : Drain(&out)) {
    if (item.kind != FilterItem::Kind::kFrame) continue;
    CHECK(item.image.data == left.data);
    if (item.t_cam_ns == t0 + dropped_frame * int64_t{50'000'000}) {
      CHECK(item.stereo_image.empty());  // released incomplete: the filter updates it mono
      ++without_second;
    } else {
      CHECK(item.stereo_image.data == right.data);
      CHECK(item.stereo_t_cam_ns == item.t_cam_ns);
    }
    ++frames;
  }
  // 41 frames: none lost to the dropout (the last one may wait for IMU beyond the end).
  CHECK(frames >= 40);
  CHECK(without_second == 1);
  CHECK(p.counters.Get(kSyncFramesIncomplete) == 1);
}

}  // namespace vilma::daemon
