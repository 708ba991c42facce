// A pool of preallocated image buffers for the daemon's per-frame path: the LCM input thread
// decodes each image into a free slot instead of allocating 360 KB per frame.
//
// The slots are ordinary cv::Mat (reference counted), so an image can be shared by the
// synchronizer and the filter like any cv::Mat. The pool is a cv::MatAllocator: when the last
// cv::Mat referring to a slot is released -- in whichever thread: the filter after its update,
// the synchronizer when it drops a late frame -- OpenCV calls Deallocate, which puts the slot
// back on a lock-free free list (boost::lockfree::queue, multi-producer). Acquire is called
// from one thread only (the input thread). No mutex and no heap allocation after construction.
//
// The pool must outlive every cv::Mat it handed out.
#pragma once

#include <atomic>
#include <boost/lockfree/queue.hpp>
#include <cstddef>
#include <cstdint>
#include <functional>
#include <memory>
#include <opencv2/core.hpp>
#include <vector>

namespace vilma::daemon {

class ImagePool : public cv::MatAllocator {
 public:
  // `num_slots` buffers of `slot_bytes` bytes each.
  ImagePool(int num_slots, std::size_t slot_bytes);
  ~ImagePool() override;
  ImagePool(const ImagePool&) = delete;
  ImagePool& operator=(const ImagePool&) = delete;

  // A rows x cols image of `type` in a free slot (contents undefined), or an empty cv::Mat if
  // every slot is in use or the image does not fit a slot. Single caller thread.
  cv::Mat TryAcquire(int rows, int cols, int type);
  // TryAcquire, retried every 0.2 ms until a slot is free, `stop` is set or `max_wait_s`
  // seconds have passed (then an empty cv::Mat). `report(waited_s)` is called every
  // `report_every_s` seconds of waiting (may be empty). The --input-log backpressure.
  cv::Mat AcquireWaiting(int rows, int cols, int type, const std::atomic<bool>& stop,
                         double max_wait_s, double report_every_s,
                         const std::function<void(double)>& report);

  int num_slots() const { return static_cast<int>(slots_.size()); }
  std::size_t slot_bytes() const { return slot_bytes_; }
  // Slots currently free (approximate while other threads release).
  int num_free() const;

  // cv::MatAllocator. Only deallocate is used for pool memory; `allocate` (called by
  // cv::Mat::create when an image of another size is written into a pool Mat) falls back to
  // OpenCV's standard allocator.
  cv::UMatData* allocate(int dims, const int* sizes, int type, void* data, size_t* step,
                         cv::AccessFlag flags, cv::UMatUsageFlags usage) const override;
  bool allocate(cv::UMatData* data, cv::AccessFlag flags, cv::UMatUsageFlags usage) const override;
  void deallocate(cv::UMatData* data) const override;

 private:
  struct Slot {
    std::unique_ptr<uint8_t[]> buffer;
    // Storage for the slot's cv::UMatData, constructed in place on acquire and destroyed on
    // release (OpenCV's allocator would new/delete one per image).
    alignas(cv::UMatData) unsigned char header[sizeof(cv::UMatData)];
    int index = 0;
  };

  std::size_t slot_bytes_;
  std::vector<Slot> slots_;
  mutable boost::lockfree::queue<int, boost::lockfree::fixed_sized<true>> free_;
  mutable std::atomic<int> num_free_{0};
};

}  // namespace vilma::daemon
