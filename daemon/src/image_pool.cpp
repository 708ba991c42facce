#include "vilma/daemon/image_pool.h"

#include <chrono>
#include <new>
#include <stdexcept>
#include <thread>

namespace vilma::daemon {

ImagePool::ImagePool(int num_slots, std::size_t slot_bytes)
    : slot_bytes_(slot_bytes), slots_(static_cast<std::size_t>(num_slots)), free_(static_cast<std::size_t>(num_slots)) {
  if (num_slots < 1 || slot_bytes == 0) throw std::invalid_argument("ImagePool: empty pool");
  for (int i = 0; i < num_slots; ++i) {
    Slot& s = slots_[static_cast<std::size_t>(i)];
    // 64-byte aligned rows are not needed: cv::Mat accepts any step; zeroing touches the pages
    // now rather than at the first frames.
    s.buffer.reset(new uint8_t[slot_bytes]());
    s.index = i;
    if (!free_.push(i)) throw std::runtime_error("ImagePool: free list too small");
  }
  num_free_.store(num_slots);
}

ImagePool::~ImagePool() = default;

int ImagePool::num_free() const { return num_free_.load(std::memory_order_relaxed); }

cv::Mat ImagePool::TryAcquire(int rows, int cols, int type) {
  const std::size_t bytes =
      static_cast<std::size_t>(rows) * static_cast<std::size_t>(cols) * CV_ELEM_SIZE(type);
  if (rows <= 0 || cols <= 0 || bytes > slot_bytes_) return cv::Mat();
  int index = -1;
  if (!free_.pop(index)) return cv::Mat();
  num_free_.fetch_sub(1, std::memory_order_relaxed);
  Slot& s = slots_[static_cast<std::size_t>(index)];
  cv::UMatData* u = new (s.header) cv::UMatData(this);
  u->data = u->origdata = s.buffer.get();
  u->size = bytes;
  u->userdata = &s;
  // A header on the slot's memory (no ownership), then given the slot's UMatData so that
  // copies share the reference count and the last release comes back to deallocate().
  cv::Mat image(rows, cols, type, s.buffer.get());
  image.allocator = this;
  image.u = u;
  u->refcount = 1;
  return image;
}

cv::Mat ImagePool::AcquireWaiting(int rows, int cols, int type, const std::atomic<bool>& stop,
                                  double max_wait_s, double report_every_s,
                                  const std::function<void(double)>& report) {
  using Clock = std::chrono::steady_clock;
  const Clock::time_point start = Clock::now();
  const auto seconds_since_start = [&] {
    return std::chrono::duration<double>(Clock::now() - start).count();
  };
  double next_report_s = report_every_s;
  cv::Mat slot = TryAcquire(rows, cols, type);
  while (slot.empty() && !stop.load() && seconds_since_start() < max_wait_s) {
    std::this_thread::sleep_for(std::chrono::microseconds(200));
    slot = TryAcquire(rows, cols, type);
    const double waited_s = seconds_since_start();
    if (slot.empty() && report && waited_s >= next_report_s) {
      report(waited_s);
      next_report_s += report_every_s;
    }
  }
  return slot;
}

cv::UMatData* ImagePool::allocate(int dims, const int* sizes, int type, void* data, size_t* step,
                                  cv::AccessFlag flags, cv::UMatUsageFlags usage) const {
  return cv::Mat::getStdAllocator()->allocate(dims, sizes, type, data, step, flags, usage);
}

bool ImagePool::allocate(cv::UMatData* data, cv::AccessFlag, cv::UMatUsageFlags) const {
  return data != nullptr;
}

void ImagePool::deallocate(cv::UMatData* u) const {
  if (u == nullptr) return;
  auto* slot = static_cast<Slot*>(u->userdata);
  u->~UMatData();
  // Cannot fail: the free list holds one node per slot.
  free_.push(slot->index);
  num_free_.fetch_add(1, std::memory_order_relaxed);
}

}  // namespace vilma::daemon
