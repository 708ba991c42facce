#include "vilma/daemon/image_pool.h"

#include <atomic>
#include <catch2/catch.hpp>
#include <chrono>
#include <thread>
#include <vector>

namespace vilma::daemon {
namespace {

TEST_CASE("image pool: slots are handed out until none is free, and come back on release") {
  ImagePool pool(3, 64 * 48);
  std::vector<cv::Mat> held;
  for (int i = 0; i < 3; ++i) {
    cv::Mat m = pool.TryAcquire(48, 64, CV_8UC1);
    REQUIRE(!m.empty());
    CHECK(m.rows == 48);
    CHECK(m.cols == 64);
    m.setTo(i);
    held.push_back(m);
  }
  CHECK(pool.num_free() == 0);
  CHECK(pool.TryAcquire(48, 64, CV_8UC1).empty());
  CHECK(pool.TryAcquire(480, 752, CV_8UC1).empty());  // too large for a slot anyway

  // A copy shares the slot: it stays in use until the last reference goes.
  cv::Mat copy = held[1];
  held[1].release();
  CHECK(pool.num_free() == 0);
  CHECK(copy.at<uint8_t>(0, 0) == 1);
  const uint8_t* slot_memory = copy.data;
  copy.release();
  CHECK(pool.num_free() == 1);
  cv::Mat again = pool.TryAcquire(48, 64, CV_8UC1);
  CHECK(again.data == slot_memory);  // the same buffer, no allocation

  // copyTo into a pool image of the same size writes into the slot.
  cv::Mat source(48, 64, CV_8UC1, cv::Scalar(7));
  source.copyTo(again);
  CHECK(again.data == slot_memory);
  CHECK(again.at<uint8_t>(47, 63) == 7);
  again.release();
  held.clear();
  CHECK(pool.num_free() == 3);
}

TEST_CASE("image pool: images released on other threads return to the pool") {
  ImagePool pool(4, 100);
  for (int round = 0; round < 200; ++round) {
    std::vector<cv::Mat> images;
    for (int i = 0; i < 4; ++i) images.push_back(pool.TryAcquire(10, 10, CV_8UC1));
    for (const cv::Mat& m : images) REQUIRE(!m.empty());
    std::thread a([&] { images[0].release(); images[1].release(); });
    std::thread b([&] { images[2].release(); images[3].release(); });
    a.join();
    b.join();
    REQUIRE(pool.num_free() == 4);
  }
}

TEST_CASE("image pool: AcquireWaiting waits for a release, gives up after max_wait_s, stops on request") {
  using Clock = std::chrono::steady_clock;
  const auto seconds_since = [](Clock::time_point t) {
    return std::chrono::duration<double>(Clock::now() - t).count();
  };
  ImagePool pool(1, 100);
  std::atomic<bool> stop{false};
  cv::Mat held = pool.TryAcquire(10, 10, CV_8UC1);
  REQUIRE(!held.empty());

  // Released by another thread after 0.3 s; the wait of up to 5 s takes it, and the report
  // (every 0.1 s) saw the wait grow.
  std::vector<double> reports;
  Clock::time_point start = Clock::now();
  std::thread releaser([&] {
    std::this_thread::sleep_for(std::chrono::milliseconds(300));
    held.release();
  });
  cv::Mat taken = pool.AcquireWaiting(10, 10, CV_8UC1, stop, 5.0, 0.1,
                                      [&](double waited_s) { reports.push_back(waited_s); });
  releaser.join();
  REQUIRE(!taken.empty());
  CHECK(seconds_since(start) >= 0.29);
  REQUIRE(reports.size() >= 2);
  CHECK(reports.front() >= 0.1);
  for (std::size_t i = 1; i < reports.size(); ++i) CHECK(reports[i] > reports[i - 1]);

  // Nothing released: empty after max_wait_s.
  start = Clock::now();
  CHECK(pool.AcquireWaiting(10, 10, CV_8UC1, stop, 0.2, 10.0, nullptr).empty());
  CHECK(seconds_since(start) >= 0.2);

  // A stop request ends the wait at once (long before max_wait_s).
  stop.store(true);
  start = Clock::now();
  CHECK(pool.AcquireWaiting(10, 10, CV_8UC1, stop, 60.0, 10.0, nullptr).empty());
  CHECK(seconds_since(start) < 30.0);
  taken.release();
  CHECK(pool.num_free() == 1);
}

}  // namespace
}  // namespace vilma::daemon
