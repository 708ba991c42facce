#include "vilma/drivers/driver_status.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <lcm/lcm-cpp.hpp>

#include "vilma/core/error.h"
#include "vilma/core/time.h"

namespace vilma {

std::string DefaultStatusChannel(const std::string& data_channel_base) {
  return "VILMA_STATUS_" + data_channel_base;
}

std::string DriverStatusOptions::Validate() const {
  if (!(std::isfinite(rate_window_s) && rate_window_s > 0.0)) return "rate_window_s: expected > 0";
  if (latency_window < 1) return "latency_window: expected >= 1";
  return "";
}

DriverStatus::DriverStatus(std::string node, const DriverStatusOptions& options)
    : node_(std::move(node)), options_(options) {
  ThrowIfInvalid(options_.Validate(), "DriverStatusOptions");
  latencies_ms_.resize(static_cast<std::size_t>(options_.latency_window));
  // The standard counters come first in every report, in this order.
  for (const char* name : {kStatusPublished, kStatusDropped, kStatusMalformed, kStatusReconnects,
                           kStatusTimestampResets, kStatusPublishErrors}) {
    counters_.emplace_back(name, 0);
  }
}

template <typename T>
std::size_t DriverStatus::Slot(std::vector<std::pair<std::string, T>>* entries,
                               const std::string& name) {
  for (std::size_t i = 0; i < entries->size(); ++i) {
    if ((*entries)[i].first == name) return i;
  }
  entries->emplace_back(name, T{});
  return entries->size() - 1;
}

void DriverStatus::Increment(const std::string& name, int64_t by) {
  std::lock_guard<std::mutex> lock(mutex_);
  counters_[Slot(&counters_, name)].second += by;
}

void DriverStatus::SetCounter(const std::string& name, int64_t value) {
  std::lock_guard<std::mutex> lock(mutex_);
  counters_[Slot(&counters_, name)].second = value;
}

int64_t DriverStatus::Counter(const std::string& name) const {
  std::lock_guard<std::mutex> lock(mutex_);
  for (const auto& entry : counters_) {
    if (entry.first == name) return entry.second;
  }
  return 0;
}

void DriverStatus::SetMetric(const std::string& name, double value) {
  std::lock_guard<std::mutex> lock(mutex_);
  metrics_[Slot(&metrics_, name)].second = value;
}

double DriverStatus::Metric(const std::string& name) const {
  std::lock_guard<std::mutex> lock(mutex_);
  for (const auto& entry : metrics_) {
    if (entry.first == name) return entry.second;
  }
  return 0.0;
}

void DriverStatus::SetState(int32_t state, const std::string& message) {
  std::lock_guard<std::mutex> lock(mutex_);
  state_ = state;
  message_ = message;
}

int32_t DriverStatus::state() const {
  std::lock_guard<std::mutex> lock(mutex_);
  return state_;
}

std::string DriverStatus::message() const {
  std::lock_guard<std::mutex> lock(mutex_);
  return message_;
}

void DriverStatus::RecordPublished(int64_t publish_steady_ns, double latency_ms) {
  const auto window_ns = static_cast<int64_t>(options_.rate_window_s * 1e9);
  std::lock_guard<std::mutex> lock(mutex_);
  counters_[Slot(&counters_, kStatusPublished)].second += 1;
  publish_times_ns_.push_back(publish_steady_ns);
  while (!publish_times_ns_.empty() && publish_times_ns_.front() < publish_steady_ns - window_ns) {
    publish_times_ns_.pop_front();
  }
  if (std::isfinite(latency_ms) && latency_ms >= 0.0) {
    latencies_ms_[latency_next_] = latency_ms;
    latency_next_ = (latency_next_ + 1) % latencies_ms_.size();
    latency_count_ = std::min(latency_count_ + 1, latencies_ms_.size());
  }
}

namespace {

// Nearest-rank q-quantile of `values` (reordered); 0 if empty.
double Quantile(std::vector<double>* values, double q) {
  if (values->empty()) return 0.0;
  const auto k = static_cast<std::size_t>(
      std::lround(q * static_cast<double>(values->size() - 1)));
  std::nth_element(values->begin(), values->begin() + static_cast<std::ptrdiff_t>(k),
                   values->end());
  return (*values)[k];
}

}  // namespace

status_t DriverStatus::Build(int64_t now_steady_ns, int64_t utime) const {
  const auto window_ns = static_cast<int64_t>(options_.rate_window_s * 1e9);
  std::lock_guard<std::mutex> lock(mutex_);
  status_t msg;
  msg.utime = utime;
  msg.node = node_;
  msg.state = state_;
  msg.message = message_;
  for (const auto& entry : counters_) {
    msg.counter_names.push_back(entry.first);
    msg.counter_values.push_back(entry.second);
  }
  msg.num_counters = static_cast<int32_t>(msg.counter_names.size());

  // Rate: (n - 1) intervals between the n publishes within the window before now; a driver
  // that stopped publishing falls to 0 Hz once its last publish leaves the window.
  double rate_hz = 0.0;
  int64_t first_ns = 0;
  int64_t last_ns = 0;
  int n = 0;
  for (int64_t t : publish_times_ns_) {
    if (t < now_steady_ns - window_ns) continue;
    if (n == 0) first_ns = t;
    last_ns = t;
    ++n;
  }
  if (n >= 2 && last_ns > first_ns) {
    rate_hz = static_cast<double>(n - 1) * 1e9 / static_cast<double>(last_ns - first_ns);
  }
  std::vector<double> latencies(latencies_ms_.begin(),
                                latencies_ms_.begin() + static_cast<std::ptrdiff_t>(latency_count_));
  const double p50 = Quantile(&latencies, 0.50);
  const double p99 = Quantile(&latencies, 0.99);

  auto add_metric = [&msg](const std::string& name, double value) {
    msg.metric_names.push_back(name);
    msg.metric_values.push_back(value);
  };
  add_metric(kStatusRateHz, rate_hz);
  add_metric(kStatusLatencyP50Ms, p50);
  add_metric(kStatusLatencyP99Ms, p99);
  for (const auto& entry : metrics_) {
    if (entry.first == kStatusRateHz || entry.first == kStatusLatencyP50Ms ||
        entry.first == kStatusLatencyP99Ms) {
      continue;  // computed above
    }
    add_metric(entry.first, entry.second);
  }
  msg.num_metrics = static_cast<int32_t>(msg.metric_names.size());
  return msg;
}

// ---------------------------------------------------------------------------------------------

namespace {
int64_t SteadyNowNs() {
  return std::chrono::duration_cast<std::chrono::nanoseconds>(
             std::chrono::steady_clock::now().time_since_epoch())
      .count();
}
}  // namespace

StatusPublisher::StatusPublisher(const DriverStatus* status, lcm::LCM* lcm, std::string channel,
                                 double period_s)
    : status_(status), lcm_(lcm), channel_(std::move(channel)), period_s_(period_s) {
  if (!(std::isfinite(period_s_) && period_s_ > 0.0)) {
    throw InputError("StatusPublisher: period_s: expected > 0");
  }
}

StatusPublisher::~StatusPublisher() { Stop(); }

void StatusPublisher::Start() {
  std::lock_guard<std::mutex> lock(mutex_);
  if (running_) return;
  stop_ = false;
  running_ = true;
  thread_ = std::thread([this] { Run(); });
}

void StatusPublisher::Stop() {
  {
    std::lock_guard<std::mutex> lock(mutex_);
    if (!running_) return;
    stop_ = true;
  }
  wake_.notify_all();
  thread_.join();
  std::lock_guard<std::mutex> lock(mutex_);
  running_ = false;
}

bool StatusPublisher::PublishNow() const {
  const status_t msg = status_->Build(SteadyNowNs(), WallClockUtime());
  const bool ok = lcm_->publish(channel_, &msg) == 0;
  if (ok) ++published_;
  return ok;
}

void StatusPublisher::Run() {
  const auto period = std::chrono::nanoseconds(static_cast<int64_t>(period_s_ * 1e9));
  auto next = std::chrono::steady_clock::now();
  // The first report goes out at Start() even if Stop() follows at once.
  PublishNow();
  std::unique_lock<std::mutex> lock(mutex_);
  for (;;) {
    next += period;
    if (wake_.wait_until(lock, next, [this] { return stop_; })) break;
    lock.unlock();
    PublishNow();
    lock.lock();
  }
  lock.unlock();
  // The last word: STOPPING, unless the driver ends in ERROR (then that is what operators need).
  status_t msg = status_->Build(SteadyNowNs(), WallClockUtime());
  if (msg.state != status_t::ERROR) msg.state = status_t::STOPPING;
  if (lcm_->publish(channel_, &msg) == 0) ++published_;
}

}  // namespace vilma
