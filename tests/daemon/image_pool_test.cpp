#include "vilma/daemon/image_pool.h"

#include <catch2/catch.hpp>
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

}  // namespace
}  // namespace vilma::daemon
