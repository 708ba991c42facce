// Percentiles of the latest samples of a latency, for VILMA_STATUS. Owned by one thread (the
// publisher); preallocated, no allocation per sample or per report.
#pragma once

#include <algorithm>
#include <cstddef>
#include <vector>

namespace vilma::daemon {

class LatencyWindow {
 public:
  explicit LatencyWindow(std::size_t capacity = 512) : values_(capacity), scratch_(capacity) {}

  void Add(double value) {
    values_[next_] = value;
    next_ = (next_ + 1) % values_.size();
    if (count_ < values_.size()) ++count_;
  }
  // The q-quantile (0..1, nearest rank) of the samples in the window; 0 if empty.
  double Percentile(double q) const {
    if (count_ == 0) return 0.0;
    std::copy(values_.begin(), values_.begin() + static_cast<std::ptrdiff_t>(count_), scratch_.begin());
    const std::size_t k = std::min(count_ - 1, static_cast<std::size_t>(q * static_cast<double>(count_ - 1) + 0.5));
    std::nth_element(scratch_.begin(), scratch_.begin() + static_cast<std::ptrdiff_t>(k),
                     scratch_.begin() + static_cast<std::ptrdiff_t>(count_));
    return scratch_[k];
  }
  std::size_t count() const { return count_; }

 private:
  std::vector<double> values_;
  mutable std::vector<double> scratch_;
  std::size_t next_ = 0;
  std::size_t count_ = 0;
};

}  // namespace vilma::daemon
