#include "vilma/core/sensor_sync.h"

#include <algorithm>
#include <catch2/catch.hpp>
#include <limits>
#include <random>

namespace vilma {
namespace {

constexpr int64_t kMs = 1000000;
constexpr int64_t kT0 = 1000 * 1000 * kMs;  // 1000 s: sensor clocks do not start at zero

ImuSample Imu(int64_t t_ns) {
  ImuSample s;
  s.t_ns = t_ns;
  s.omega_I = Eigen::Vector3d(1e-9 * static_cast<double>(t_ns % 1000000007), 0.1, 0.2);
  s.a_I = Eigen::Vector3d(0.0, 0.0, 9.81);
  return s;
}

cv::Mat Image() { return cv::Mat(4, 6, CV_8UC1, cv::Scalar(7)); }

std::vector<SyncedFrame> Drain(SensorSynchronizer* sync) {
  std::vector<SyncedFrame> out;
  SyncedFrame f;
  while (sync->PopFrame(&f)) out.push_back(f);
  return out;
}

// IMU at 200 Hz on [from, to] (multiples of 5 ms from kT0).
void FeedImu(SensorSynchronizer* sync, int64_t from, int64_t to) {
  for (int64_t t = from; t <= to; t += 5 * kMs) sync->AddImu(Imu(t));
}

std::vector<int64_t> Stamps(const std::vector<ImuSample>& v) {
  std::vector<int64_t> out;
  for (const ImuSample& s : v) out.push_back(s.t_ns);
  return out;
}

TEST_CASE("SensorSyncOptions validation and constructor", "[sync]") {
  SensorSyncOptions o;
  CHECK(o.Validate().empty());
  o.max_pending_frames = 0;
  CHECK(o.Validate().rfind("max_pending_frames", 0) == 0);
  o = SensorSyncOptions();
  o.time_jump_threshold_ns = o.max_imu_wait_ns;
  CHECK(o.Validate().rfind("time_jump_threshold_ns", 0) == 0);
  CHECK_THROWS_AS(SensorSynchronizer(o, {0}), std::invalid_argument);
  CHECK_THROWS_AS(SensorSynchronizer(SensorSyncOptions(), {}), std::invalid_argument);
  CHECK(SensorSynchronizer(SensorSyncOptions(), {0, 0}).num_cameras() == 2);
}

TEST_CASE("Mono: a frame waits for an IMU sample at or after it, samples hand over with one "
          "repeated boundary sample", "[sync]") {
  SensorSynchronizer sync(SensorSyncOptions(), {3 * kMs});  // t_imu = t_cam + 3 ms
  FeedImu(&sync, kT0, kT0 + 20 * kMs);
  const cv::Mat img = Image();
  sync.AddImage(0, kT0 + 19 * kMs, img);  // t_imu = kT0 + 22 ms: IMU only up to 20 ms
  SyncedFrame f;
  CHECK_FALSE(sync.PopFrame(&f));
  sync.AddImu(Imu(kT0 + 25 * kMs));
  REQUIRE(sync.PopFrame(&f));
  CHECK(f.t_imu_ns == kT0 + 22 * kMs);
  CHECK(f.t_cam_ns == std::vector<int64_t>{kT0 + 19 * kMs});
  CHECK(f.images[0].data == img.data);  // shared, not copied
  CHECK_FALSE(f.imu_overlaps_previous);
  CHECK_FALSE(f.time_jump_before);
  CHECK(Stamps(f.imu) == std::vector<int64_t>{kT0, kT0 + 5 * kMs, kT0 + 10 * kMs, kT0 + 15 * kMs,
                                              kT0 + 20 * kMs, kT0 + 25 * kMs});
  // Next frame exactly on an IMU stamp (35 ms): covered by that sample itself.
  FeedImu(&sync, kT0 + 30 * kMs, kT0 + 35 * kMs);
  sync.AddImage(0, kT0 + 32 * kMs, img);
  REQUIRE(sync.PopFrame(&f));
  CHECK(f.imu_overlaps_previous);
  CHECK(Stamps(f.imu) == std::vector<int64_t>{kT0 + 25 * kMs, kT0 + 30 * kMs, kT0 + 35 * kMs});
  // Two frames between two IMU samples: the second gets only the boundary sample.
  // (More than the 2 ms grouping tolerance apart from each other and from the last frame.)
  sync.AddImage(0, kT0 + 34 * kMs + kMs / 2, img);  // t_imu = 37.5 ms
  sync.AddImage(0, kT0 + 37 * kMs, img);            // t_imu = 40 ms
  CHECK_FALSE(sync.PopFrame(&f));
  sync.AddImu(Imu(kT0 + 40 * kMs));
  auto frames = Drain(&sync);
  REQUIRE(frames.size() == 2);
  CHECK(Stamps(frames[0].imu) == std::vector<int64_t>{kT0 + 35 * kMs, kT0 + 40 * kMs});
  CHECK(Stamps(frames[1].imu) == std::vector<int64_t>{kT0 + 40 * kMs});
  CHECK(frames[1].imu_overlaps_previous);
  CHECK(sync.counters().frames_released == 4);
  CHECK(sync.counters().frames_incomplete == 0);
}

TEST_CASE("Stereo: grouping with per-camera offsets and tolerance", "[sync]") {
  SensorSyncOptions o;
  o.frame_grouping_tolerance_ns = 2 * kMs;
  SensorSynchronizer sync(o, {0, -4 * kMs});  // cam1's clock runs 4 ms ahead
  FeedImu(&sync, kT0, kT0 + 200 * kMs);
  // cam1 arrives first; stamps differ by 5 ms on their own clocks, 1 ms on the IMU clock.
  sync.AddImage(1, kT0 + 15 * kMs, Image());
  CHECK(Drain(&sync).empty());  // waits for cam0
  sync.AddImage(0, kT0 + 10 * kMs, Image());
  auto frames = Drain(&sync);
  REQUIRE(frames.size() == 1);
  CHECK(frames[0].t_imu_ns == kT0 + 10 * kMs);  // cam0 defines the frame time
  CHECK(frames[0].t_cam_ns == std::vector<int64_t>{kT0 + 10 * kMs, kT0 + 15 * kMs});
  CHECK_FALSE(frames[0].images[1].empty());
  // Outside the tolerance (3 ms apart on the IMU clock): two separate incomplete frames.
  sync.AddImage(0, kT0 + 60 * kMs, Image());
  sync.AddImage(1, kT0 + 67 * kMs, Image());  // t_imu = 63 ms
  CHECK(Drain(&sync).empty());
  CHECK(sync.pending_frames() == 2);
}

TEST_CASE("Stereo: a dropped image and a camera silent for 2 s release incomplete frames, then "
          "grouping resumes", "[sync]") {
  SensorSyncOptions o;  // incomplete timeout 100 ms of newer camera data
  SensorSynchronizer sync(o, {0, 0});
  std::vector<SyncedFrame> frames;
  auto step = [&](int k, bool cam1) {  // frame k at kT0 + 50 ms * k + 1 ms
    const int64_t t = kT0 + 50 * kMs * k + kMs;
    FeedImu(&sync, t - kMs, t + 4 * kMs);
    sync.AddImage(0, t, Image());
    if (cam1) sync.AddImage(1, t, Image());
    for (auto& f : Drain(&sync)) frames.push_back(f);
  };
  step(0, true);
  step(1, false);  // cam1 drops frame 1
  step(2, true);
  CHECK(frames.size() == 1);  // frame 1 blocks (head of line) until the timeout
  step(3, true);              // 100 ms newer: not yet (strictly more than the timeout)
  CHECK(frames.size() == 1);
  step(4, true);
  REQUIRE(frames.size() == 5);
  CHECK(frames[1].images[1].empty());
  CHECK(frames[1].t_cam_ns[1] == 0);
  CHECK(sync.counters().frames_incomplete == 1);
  for (int k = 5; k < 45; ++k) step(k, false);  // cam1 silent for 2 s
  for (int k = 45; k < 50; ++k) step(k, true);   // and back
  REQUIRE(frames.size() == 50);
  for (std::size_t k = 1; k < frames.size(); ++k) {
    CHECK(frames[k].t_imu_ns > frames[k - 1].t_imu_ns);
    CHECK(frames[k].imu_overlaps_previous);
    CHECK(frames[k].imu.front().t_ns == frames[k - 1].imu.back().t_ns);
  }
  CHECK(sync.counters().frames_incomplete == 41);
  for (int k = 45; k < 48; ++k) CHECK_FALSE(frames[static_cast<std::size_t>(k)].images[1].empty());
  CHECK(sync.counters().image_time_jumps == 0);
  CHECK(sync.counters().imu_time_jumps == 0);
}

TEST_CASE("Mono: a camera silent for 2 s is not a time jump", "[sync]") {
  SensorSynchronizer sync(SensorSyncOptions(), {0});
  FeedImu(&sync, kT0, kT0 + 505 * kMs);
  sync.AddImage(0, kT0 + 501 * kMs, Image());
  FeedImu(&sync, kT0 + 510 * kMs, kT0 + 2505 * kMs);
  sync.AddImage(0, kT0 + 2501 * kMs, Image());
  auto frames = Drain(&sync);
  REQUIRE(frames.size() == 2);
  CHECK_FALSE(frames[1].time_jump_before);
  CHECK(frames[1].imu.front().t_ns == frames[0].imu.back().t_ns);
  CHECK(frames[1].imu.size() == 401);  // 2 s of IMU plus the repeated boundary sample
  CHECK(sync.counters().imu_discarded == 0);
  CHECK(sync.counters().frames_incomplete == 0);
  CHECK(sync.counters().image_time_jumps == 0);
}

TEST_CASE("IMU stalled: frames wait max_imu_wait_ns, are dropped, and flow again", "[sync]") {
  SensorSyncOptions o;  // max_imu_wait 200 ms
  SensorSynchronizer sync(o, {0});
  std::vector<SyncedFrame> frames;
  int64_t imu_until = kT0 - 5 * kMs;
  for (int k = 0; k < 40; ++k) {
    const int64_t t = kT0 + 50 * kMs * k + 2 * kMs;
    const bool stalled = t > kT0 + 500 * kMs && t < kT0 + 1100 * kMs;  // 600 ms stall
    if (!stalled) FeedImu(&sync, imu_until + 5 * kMs, t + 3 * kMs);
    imu_until = t + 3 * kMs;  // samples during the stall never arrive
    sync.AddImage(0, t, Image());
    for (auto& f : Drain(&sync)) frames.push_back(f);
  }
  // Frames at 502..1052 ms (12) are not covered; 502..802 are dropped as newer images pass them
  // by more than 200 ms; 852..1052 are still pending when the IMU resumes (1060 ms, a 605 ms
  // gap) and are released.
  CHECK(sync.counters().frames_dropped_no_imu == 7);
  CHECK(sync.counters().frames_released == 33);
  CHECK(frames.size() == 33);
  CHECK(sync.counters().imu_gaps == 1);
  CHECK(sync.counters().imu_time_jumps == 0);
  // Nothing lost: the frame after the stall carries the IMU across the gap.
  for (std::size_t k = 1; k < frames.size(); ++k) {
    CHECK(frames[k].imu.front().t_ns == frames[k - 1].imu.back().t_ns);
    CHECK(frames[k].imu.back().t_ns >= frames[k].t_imu_ns);
  }
}

TEST_CASE("Duplicates, out-of-order, late and invalid input are dropped and counted", "[sync]") {
  SensorSyncOptions o;
  SensorSynchronizer sync(o, {0, 0});
  FeedImu(&sync, kT0, kT0 + 100 * kMs);
  sync.AddImu(Imu(kT0 + 100 * kMs));  // duplicate
  sync.AddImu(Imu(kT0 + 50 * kMs));   // out of order
  ImuSample bad = Imu(kT0 + 102 * kMs);
  bad.a_I.x() = std::numeric_limits<double>::quiet_NaN();
  sync.AddImu(bad);
  sync.AddImu(Imu(kT0 + 140 * kMs));  // 40 ms gap: counted, forwarded
  sync.AddImage(0, kT0 + 10 * kMs, Image());
  sync.AddImage(0, kT0 + 10 * kMs, Image());  // duplicate
  sync.AddImage(1, kT0 + 10 * kMs, Image());
  sync.AddImage(0, kT0 + 60 * kMs, Image());
  sync.AddImage(0, kT0 + 40 * kMs, Image());  // out of order for cam0
  sync.AddImage(1, kT0 + 60 * kMs, Image());
  sync.AddImage(2, kT0 + 60 * kMs, Image());  // no such camera
  sync.AddImage(-1, kT0 + 60 * kMs, Image());
  sync.AddImage(1, kT0 + 110 * kMs, cv::Mat());                     // empty image
  sync.AddImage(1, std::numeric_limits<int64_t>::max(), Image());  // fine: offset 0
  auto frames = Drain(&sync);
  // The int64 max stamp was a jump for cam1: history cleared.
  CHECK(sync.counters().image_time_jumps == 1);
  CHECK(frames.empty());
  CHECK(sync.counters().frames_dropped_time_jump == 2);

  SensorSynchronizer s2(o, {0, 0});
  FeedImu(&s2, kT0, kT0 + 100 * kMs);
  s2.AddImu(Imu(kT0 + 100 * kMs));
  s2.AddImu(Imu(kT0 + 50 * kMs));
  s2.AddImu(bad);
  s2.AddImu(Imu(kT0 + 140 * kMs));
  s2.AddImage(0, kT0 + 10 * kMs, Image());
  s2.AddImage(0, kT0 + 10 * kMs, Image());
  s2.AddImage(1, kT0 + 10 * kMs, Image());
  frames = Drain(&s2);
  CHECK(frames.size() == 1);
  s2.AddImage(1, kT0 + 10 * kMs + kMs, Image());  // late: its frame was released
  s2.AddImage(0, kT0 + 60 * kMs, Image());
  s2.AddImage(0, kT0 + 40 * kMs, Image());
  s2.AddImage(1, kT0 + 60 * kMs, Image());
  s2.AddImage(2, kT0 + 60 * kMs, Image());
  s2.AddImage(-1, kT0 + 60 * kMs, Image());
  s2.AddImage(1, kT0 + 110 * kMs, cv::Mat());
  SensorSynchronizer s3(o, {std::numeric_limits<int64_t>::max()});
  s3.AddImage(0, 1, Image());  // t_cam + offset overflows
  CHECK(s3.counters().images_invalid == 1);
  for (auto& f : Drain(&s2)) frames.push_back(f);
  REQUIRE(frames.size() == 2);
  const SensorSyncCounters& c = s2.counters();
  CHECK(c.imu_received == 25);
  CHECK(c.imu_duplicates == 1);
  CHECK(c.imu_out_of_order == 1);
  CHECK(c.imu_invalid == 1);
  CHECK(c.imu_gaps == 1);
  CHECK(c.images_received == 10);
  CHECK(c.images_duplicate == 1);
  CHECK(c.images_out_of_order == 1);
  CHECK(c.images_late == 1);
  CHECK(c.images_invalid == 3);
  CHECK(c.frames_released == 2);
  CHECK(Stamps(frames[1].imu) == std::vector<int64_t>{kT0 + 10 * kMs, kT0 + 15 * kMs,
                                                      kT0 + 20 * kMs, kT0 + 25 * kMs,
                                                      kT0 + 30 * kMs, kT0 + 35 * kMs,
                                                      kT0 + 40 * kMs, kT0 + 45 * kMs,
                                                      kT0 + 50 * kMs, kT0 + 55 * kMs,
                                                      kT0 + 60 * kMs});
}

// A whole sensor clock jump by `jump` at frame 20 of 40; the IMU jumps first and old-base images
// (camera latency) arrive after it.
void RunClockJump(int64_t jump) {
  SensorSynchronizer sync(SensorSyncOptions(), {0, 0});
  std::vector<SyncedFrame> frames;
  int64_t base = kT0;
  for (int k = 0; k < 40; ++k) {
    if (k == 20) base += jump;
    const int64_t t = base + 50 * kMs * k + kMs;
    FeedImu(&sync, t - 49 * kMs, t + 4 * kMs);
    if (k == 20) {  // stragglers on the old base, delivered after the IMU jumped
      sync.AddImage(0, t - jump - 20 * kMs, Image());
      sync.AddImage(1, t - jump - 20 * kMs, Image());
    }
    sync.AddImage(0, t, Image());
    sync.AddImage(1, t, Image());
    for (auto& f : Drain(&sync)) frames.push_back(f);
  }
  const SensorSyncCounters& c = sync.counters();
  CHECK(c.imu_time_jumps == 1);
  CHECK(c.image_time_jumps == 2);  // both cameras rejoined the new base
  CHECK(c.images_stale == 2);
  CHECK(c.frames_dropped_time_jump == 0);
  REQUIRE(frames.size() == 40);
  for (std::size_t k = 0; k < frames.size(); ++k) {
    INFO("frame " << k);
    CHECK(frames[k].time_jump_before == (k == 20));
    CHECK(frames[k].imu_overlaps_previous == (k != 0 && k != 20));
    CHECK(frames[k].images[0].data != nullptr);
    CHECK(frames[k].images[1].data != nullptr);
    if (k != 0 && k != 20) {
      CHECK(frames[k].t_imu_ns == frames[k - 1].t_imu_ns + 50 * kMs);
      CHECK(frames[k].imu.front().t_ns == frames[k - 1].imu.back().t_ns);
    }
  }
  // The first frame of the new base only has new-base IMU.
  CHECK(frames[20].imu.front().t_ns == frames[20].t_imu_ns - 49 * kMs);
  CHECK(c.frames_incomplete == 0);
}

TEST_CASE("Time jump of the whole sensor clock by +1 h", "[sync]") {
  RunClockJump(3600LL * 1000 * kMs);
}

TEST_CASE("Time jump of the whole sensor clock by -10 s", "[sync]") {
  RunClockJump(-10LL * 1000 * kMs);
}

TEST_CASE("Backpressure drops the oldest pending frame", "[sync]") {
  SensorSyncOptions o;
  o.max_imu_wait_ns = 900 * kMs;  // never times out here
  o.max_pending_frames = 8;
  SensorSynchronizer sync(o, {0});
  for (int k = 0; k < 12; ++k) sync.AddImage(0, kT0 + 50 * kMs * k, Image());
  CHECK(sync.pending_frames() == 8);
  CHECK(sync.counters().frames_dropped_overflow == 4);
  FeedImu(&sync, kT0, kT0 + 600 * kMs);
  auto frames = Drain(&sync);
  REQUIRE(frames.size() == 8);
  CHECK(frames[0].t_imu_ns == kT0 + 200 * kMs);
  // An image of a dropped frame is late now.
  sync.AddImage(0, kT0 + 150 * kMs, Image());
  CHECK(sync.counters().images_out_of_order + sync.counters().images_late == 1);
}

TEST_CASE("IMU history is bounded while no frame takes the samples", "[sync]") {
  SensorSyncOptions o;
  o.imu_history_ns = 1000 * kMs;
  SensorSynchronizer sync(o, {0});
  FeedImu(&sync, kT0, kT0 + 3000 * kMs);
  sync.AddImage(0, kT0 + 2990 * kMs, Image());
  auto frames = Drain(&sync);
  REQUIRE(frames.size() == 1);
  // The window [newest - 1 s, newest] plus the sample before it, so that it spans the window.
  CHECK(frames[0].imu.front().t_ns == kT0 + 1995 * kMs);
  CHECK(frames[0].imu.back().t_ns == kT0 + 2990 * kMs);
  CHECK(sync.counters().imu_discarded == 399);
}

// Property: a clean 200 Hz IMU and two 20 Hz cameras, each stream in order, the streams delayed
// randomly relative to each other by up to 50 ms. Every frame comes out once, complete, in
// order, and the IMU is handed out contiguously, without loss or repetition beyond the boundary.
TEST_CASE("Random interleavings of a clean stream: every frame once, IMU exact", "[sync]") {
  const unsigned seed = GENERATE(1u, 2u, 3u, 42u, 2024u);
  std::mt19937 rng(seed);
  struct Event {
    int64_t arrival;
    int stream;  // -1 IMU, else camera
    int64_t t;
    int64_t t_imu;
  };
  const std::vector<int64_t> offsets = {0, 700000};  // cam1 stamps 0.7 ms early
  std::vector<Event> events;
  std::vector<ImuSample> imu;
  for (int64_t t = kT0; t <= kT0 + 10100 * kMs; t += 5 * kMs) imu.push_back(Imu(t));
  std::uniform_int_distribution<int64_t> delay(0, 50 * kMs), phase(0, 5000);
  int64_t arrival = 0;
  for (const ImuSample& s : imu) {
    arrival = std::max(arrival, s.t_ns + delay(rng));
    events.push_back({arrival, -1, s.t_ns, s.t_ns});
  }
  std::vector<int64_t> frame_times;
  for (int k = 0; k < 200; ++k) {
    // Sometimes exactly on an IMU stamp (phase 0), else anywhere in between (1 us grid).
    const int64_t p = phase(rng);
    frame_times.push_back(kT0 + 20 * kMs + 50 * kMs * k + (p < 500 ? 0 : p * 1000));
  }
  for (int cam = 0; cam < 2; ++cam) {
    arrival = 0;
    for (int64_t t : frame_times) {
      arrival = std::max(arrival, t + delay(rng));
      events.push_back({arrival, cam, t - offsets[static_cast<std::size_t>(cam)], t});
    }
  }
  std::stable_sort(events.begin(), events.end(),
                   [](const Event& a, const Event& b) { return a.arrival < b.arrival; });
  SensorSynchronizer sync(SensorSyncOptions(), offsets);
  std::vector<SyncedFrame> frames;
  const cv::Mat img = Image();
  for (const Event& e : events) {
    if (e.stream < 0) {
      sync.AddImu(imu[static_cast<std::size_t>((e.t - kT0) / (5 * kMs))]);
    } else {
      sync.AddImage(e.stream, e.t, img);
    }
    for (auto& f : Drain(&sync)) frames.push_back(f);
  }
  REQUIRE(frames.size() == frame_times.size());
  std::vector<int64_t> concatenated;
  for (std::size_t k = 0; k < frames.size(); ++k) {
    INFO("seed " << seed << " frame " << k);
    const SyncedFrame& f = frames[k];
    CHECK(f.t_imu_ns == frame_times[k]);
    CHECK(f.t_cam_ns == std::vector<int64_t>{frame_times[k], frame_times[k] - offsets[1]});
    CHECK(f.images[0].data == img.data);
    CHECK(f.images[1].data == img.data);
    CHECK_FALSE(f.time_jump_before);
    REQUIRE(!f.imu.empty());
    CHECK(f.imu.back().t_ns >= f.t_imu_ns);
    if (f.imu.size() >= 2) CHECK(f.imu[f.imu.size() - 2].t_ns < f.t_imu_ns);
    for (std::size_t j = 1; j < f.imu.size(); ++j) {
      CHECK(f.imu[j].t_ns == f.imu[j - 1].t_ns + 5 * kMs);
    }
    CHECK(f.imu_overlaps_previous == (k > 0));
    if (k > 0) CHECK(f.imu.front().t_ns == frames[k - 1].imu.back().t_ns);
    for (std::size_t j = f.imu_overlaps_previous ? 1 : 0; j < f.imu.size(); ++j) {
      concatenated.push_back(f.imu[j].t_ns);
      CHECK(f.imu[j].omega_I == imu[(static_cast<std::size_t>(f.imu[j].t_ns - kT0)) / (5 * kMs)].omega_I);
    }
  }
  std::vector<int64_t> expected;
  for (const ImuSample& s : imu) {
    if (s.t_ns <= concatenated.back()) expected.push_back(s.t_ns);
  }
  CHECK(concatenated == expected);
  const SensorSyncCounters& c = sync.counters();
  CHECK(c.frames_released == 200);
  CHECK(c.frames_incomplete + c.frames_dropped_no_imu + c.frames_dropped_overflow == 0);
  CHECK(c.imu_duplicates + c.imu_out_of_order + c.imu_gaps + c.imu_discarded == 0);
  CHECK(c.images_duplicate + c.images_out_of_order + c.images_late == 0);
  CHECK(c.imu_time_jumps + c.image_time_jumps == 0);
}

}  // namespace
}  // namespace vilma
