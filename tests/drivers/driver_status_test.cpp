#include "vilma/drivers/driver_status.h"

#include <catch2/catch.hpp>
#include <chrono>
#include <lcm/lcm-cpp.hpp>
#include <thread>
#include <vector>

#include "vilma/core/error.h"

namespace vilma {
namespace {

int64_t CounterOf(const status_t& msg, const std::string& name) {
  for (int i = 0; i < msg.num_counters; ++i) {
    if (msg.counter_names[i] == name) return msg.counter_values[i];
  }
  FAIL("no counter " << name);
  return -1;
}

double MetricOf(const status_t& msg, const std::string& name) {
  for (int i = 0; i < msg.num_metrics; ++i) {
    if (msg.metric_names[i] == name) return msg.metric_values[i];
  }
  FAIL("no metric " << name);
  return -1;
}

TEST_CASE("DriverStatus reports the standard counters and metrics from the start", "[status]") {
  DriverStatus status("vilma-test");
  const status_t msg = status.Build(0, 1234);
  CHECK(msg.node == "vilma-test");
  CHECK(msg.utime == 1234);
  CHECK(msg.state == status_t::STARTING);
  REQUIRE(msg.num_counters == 6);
  CHECK(msg.counter_names[0] == "published");
  CHECK(msg.counter_names[1] == "dropped");
  CHECK(msg.counter_names[2] == "malformed");
  CHECK(msg.counter_names[3] == "reconnects");
  CHECK(msg.counter_names[4] == "timestamp_resets");
  CHECK(msg.counter_names[5] == "publish_errors");
  for (int64_t v : msg.counter_values) CHECK(v == 0);
  REQUIRE(msg.num_metrics == 3);
  CHECK(MetricOf(msg, "rate_hz") == 0.0);
  CHECK(MetricOf(msg, "latency_p50_ms") == 0.0);
  CHECK(MetricOf(msg, "latency_p99_ms") == 0.0);
  CHECK(static_cast<int>(msg.counter_names.size()) == msg.num_counters);
  CHECK(static_cast<int>(msg.metric_values.size()) == msg.num_metrics);
}

TEST_CASE("DriverStatus counters, metrics and state", "[status]") {
  DriverStatus status("vilma-test");
  status.Increment(kStatusDropped, 3);
  status.Increment(kStatusDropped);
  status.Increment("missing_packets", 7);
  status.SetCounter("buffers", 12);
  status.SetCounter("buffers", 10);
  status.SetMetric("gain_db", 4.5);
  status.SetMetric(kStatusRateHz, 99.0);  // computed metrics are not overridden
  status.SetState(status_t::DEGRADED, "device lost, reconnecting");
  CHECK(status.Counter(kStatusDropped) == 4);
  CHECK(status.Counter("never") == 0);
  CHECK(status.Metric("gain_db") == 4.5);
  CHECK(status.state() == status_t::DEGRADED);
  CHECK(status.message() == "device lost, reconnecting");

  const status_t msg = status.Build(0, 0);
  CHECK(msg.state == status_t::DEGRADED);
  CHECK(msg.message == "device lost, reconnecting");
  CHECK(CounterOf(msg, "dropped") == 4);
  CHECK(CounterOf(msg, "missing_packets") == 7);
  CHECK(CounterOf(msg, "buffers") == 10);
  REQUIRE(msg.num_counters == 8);
  CHECK(msg.counter_names[6] == "missing_packets");  // creation order
  CHECK(msg.counter_names[7] == "buffers");
  CHECK(MetricOf(msg, "gain_db") == 4.5);
  CHECK(MetricOf(msg, "rate_hz") == 0.0);
  CHECK(msg.num_metrics == 4);
}

TEST_CASE("DriverStatus rate over its window and latency percentiles", "[status]") {
  DriverStatusOptions options;
  options.rate_window_s = 1.0;
  options.latency_window = 100;
  DriverStatus status("vilma-test", options);
  // 20 Hz for 3 s; latencies 1..60 ms cycling.
  const int64_t period_ns = 50000000;
  for (int i = 0; i < 60; ++i) {
    status.RecordPublished(i * period_ns, 1.0 + i);
  }
  status.RecordPublished(60 * period_ns, -1.0);  // counted, latency not recorded
  const int64_t now = 60 * period_ns;
  status_t msg = status.Build(now, 0);
  CHECK(CounterOf(msg, "published") == 61);
  // 21 publishes in [now - 1 s, now]: 20 intervals over 1 s.
  CHECK(MetricOf(msg, "rate_hz") == Approx(20.0).epsilon(1e-9));
  // 60 latencies 1..60: nearest-rank p50 at index round(0.5*59)=30 -> 31; p99 index 58 -> 59.
  CHECK(MetricOf(msg, "latency_p50_ms") == 31.0);
  CHECK(MetricOf(msg, "latency_p99_ms") == 59.0);

  // Only the last 100 latencies count: 200 more of 5 ms.
  for (int i = 0; i < 200; ++i) status.RecordPublished(now + (i + 1) * period_ns, 5.0);
  msg = status.Build(now + 200 * period_ns, 0);
  CHECK(MetricOf(msg, "latency_p50_ms") == 5.0);
  CHECK(MetricOf(msg, "latency_p99_ms") == 5.0);
  // A driver that stops publishing falls to 0 Hz once the window has passed.
  msg = status.Build(now + 200 * period_ns + 1500000000, 0);
  CHECK(MetricOf(msg, "rate_hz") == 0.0);
}

TEST_CASE("DriverStatus counts from several threads", "[status]") {
  DriverStatus status("vilma-test");
  std::vector<std::thread> threads;
  for (int t = 0; t < 4; ++t) {
    threads.emplace_back([&status, t] {
      for (int i = 0; i < 10000; ++i) {
        status.Increment(kStatusMalformed);
        status.RecordPublished(i, 0.5);
        if (i % 1000 == 0) status.Build(i, 0);
        if (t == 0 && i % 100 == 0) status.SetState(status_t::OK, "ok");
      }
    });
  }
  for (auto& thread : threads) thread.join();
  CHECK(status.Counter(kStatusMalformed) == 40000);
  CHECK(status.Counter(kStatusPublished) == 40000);
}

TEST_CASE("DriverStatus options are validated", "[status]") {
  DriverStatusOptions options;
  CHECK(options.Validate().empty());
  options.rate_window_s = 0.0;
  CHECK(options.Validate() == "rate_window_s: expected > 0");
  CHECK_THROWS_AS(DriverStatus("x", options), InputError);
  options = DriverStatusOptions();
  options.latency_window = 0;
  CHECK(options.Validate() == "latency_window: expected >= 1");
}

TEST_CASE("Status channel names", "[status]") {
  CHECK(DefaultStatusChannel("CAM0") == "VILMA_STATUS_CAM0");
  CHECK(DefaultStatusChannel("IMU") == "VILMA_STATUS_IMU");
}

struct Received {
  std::vector<status_t> messages;
  void On(const lcm::ReceiveBuffer*, const std::string&, const status_t* msg) {
    messages.push_back(*msg);
  }
};

TEST_CASE("StatusPublisher publishes periodically and STOPPING last", "[status]") {
  lcm::LCM lcm("memq://");
  REQUIRE(lcm.good());
  Received received;
  lcm.subscribe("VILMA_STATUS_CAM0", &Received::On, &received);
  DriverStatus status("vilma-test");
  status.SetState(status_t::OK, "streaming");
  status.Increment(kStatusReconnects, 2);
  {
    StatusPublisher publisher(&status, &lcm, "VILMA_STATUS_CAM0", 0.02);
    publisher.Start();
    std::this_thread::sleep_for(std::chrono::milliseconds(110));
    publisher.Stop();
    publisher.Stop();  // idempotent
    CHECK(publisher.published() >= 4);
    CHECK(publisher.published() <= 8);
  }
  // memq delivers on handle(); drain everything queued.
  while (lcm.handleTimeout(0) > 0) {
  }
  REQUIRE(received.messages.size() >= 4);
  for (size_t i = 0; i + 1 < received.messages.size(); ++i) {
    CHECK(received.messages[i].state == status_t::OK);
    CHECK(CounterOf(received.messages[i], "reconnects") == 2);
  }
  CHECK(received.messages.back().state == status_t::STOPPING);

  // A driver that ends in ERROR keeps ERROR in its last report.
  status.SetState(status_t::ERROR, "device gone");
  received.messages.clear();
  StatusPublisher publisher(&status, &lcm, "VILMA_STATUS_CAM0", 10.0);
  publisher.Start();
  publisher.Stop();
  while (lcm.handleTimeout(0) > 0) {
  }
  REQUIRE(received.messages.size() == 2);  // the first report at Start, the last at Stop
  CHECK(received.messages.back().state == status_t::ERROR);
  CHECK_THROWS_AS(StatusPublisher(&status, &lcm, "X", 0.0), InputError);
}

}  // namespace
}  // namespace vilma
