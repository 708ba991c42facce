#include "vilma/core/clock_sync.h"

#include <algorithm>
#include <catch2/catch.hpp>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <random>
#include <vector>

#include "vilma/core/error.h"

namespace vilma {
namespace {

constexpr int64_t kUs = 1000;
constexpr int64_t kMs = 1000 * kUs;
constexpr int64_t kS = 1000 * kMs;

// A simulated sensor: it samples every `period_ns` of its own clock, which runs
// (1 + drift_ppm 1e-6) times as fast as the host clock and is offset from it; each sample
// reaches the host after a random transport delay. The truth of every sample is the host time
// of the event it stamps.
struct SimOptions {
  double drift_ppm = 0.0;
  int64_t device_offset_ns = -123456789012;  // device clock = host clock * (1 + drift) + this
  int64_t host_start_ns = 1700000000 * kS;   // a realistic CLOCK_REALTIME
  int64_t period_ns = 5 * kMs;               // 200 Hz on the device clock
  double seconds = 60.0;
  enum class Jitter { kExponential, kUniform } jitter = Jitter::kExponential;
  double jitter_ms = 1.0;          // exponential mean, or the width of the uniform
  double spike_probability = 0.01; // a 10-30 ms delay spike on this share of the samples
  int burst_every = 0;             // every N samples, a burst of 20 delayed 20 ms .. 1 ms
  // Steps at sample `step_at` (0: none): of the device clock [ns] (negative: back) and of the
  // host clock [ns] (an NTP step).
  int step_at = 0;
  int64_t device_step_ns = 0;
  int64_t host_step_ns = 0;
  bool device_restart = false;  // at step_at the device clock restarts from zero
  uint32_t seed = 1;
};

struct SimResult {
  std::vector<double> abs_error_us;  // |mapped - true| of every evaluated sample
  ClockSyncStats stats;
};

// Feeds the simulated pairs to a ClockSync and maps each sample's device stamp right after its
// own pair went in (what a driver does). Samples within `settle_s` of the start and of a step
// are not evaluated (the filter restarts there).
SimResult Simulate(const SimOptions& sim, const ClockSyncOptions& options = {},
                   double settle_s = 2.0) {
  ClockSync sync(options);
  std::mt19937 rng(sim.seed);
  std::exponential_distribution<double> exponential(1.0 / sim.jitter_ms);
  std::uniform_real_distribution<double> uniform01(0.0, 1.0);
  const double rate = 1.0 + sim.drift_ppm * 1e-6;
  const auto samples = static_cast<int>(sim.seconds * 1e9 / static_cast<double>(sim.period_ns));
  SimResult result;
  // Relative times in double (exact to well below 1 ns over minutes); absolute ones in int64.
  const double device_period_as_host_ns = static_cast<double>(sim.period_ns) / rate;
  double event_rel_ns = 0.0;  // true host time of the event - host_start_ns
  int64_t device_base_ns = sim.host_start_ns + sim.device_offset_ns;  // device stamp at rel 0
  int64_t host_step_ns = 0;
  for (int k = 0; k < samples; ++k) {
    if (k > 0) event_rel_ns += device_period_as_host_ns;
    if (sim.step_at > 0 && k == sim.step_at) {
      device_base_ns += sim.device_step_ns;
      host_step_ns = sim.host_step_ns;
      // Restarted from zero: the device stamp of this event is 0.
      if (sim.device_restart) device_base_ns = -std::llround(event_rel_ns * rate);
    }
    const int64_t device_ns = device_base_ns + std::llround(event_rel_ns * rate);
    // What the host clock read at the event (after a host step it reads step more).
    const int64_t host_event_reading_ns =
        sim.host_start_ns + std::llround(event_rel_ns) + host_step_ns;
    double delay_ms = sim.jitter == SimOptions::Jitter::kExponential
                          ? exponential(rng)
                          : sim.jitter_ms * uniform01(rng);
    if (uniform01(rng) < sim.spike_probability) delay_ms += 10.0 + 20.0 * uniform01(rng);
    if (sim.burst_every > 0 && k % sim.burst_every < 20 && k > sim.burst_every) {
      delay_ms += 20.0 - static_cast<double>(k % sim.burst_every);
    }
    const int64_t arrival_ns =
        host_event_reading_ns + static_cast<int64_t>(std::llround(delay_ms * 1e6));
    sync.AddObservation(device_ns, arrival_ns);
    const double t_s = static_cast<double>(k) * static_cast<double>(sim.period_ns) * 1e-9;
    const double since_step_s =
        sim.step_at > 0 && k >= sim.step_at
            ? static_cast<double>(k - sim.step_at) * static_cast<double>(sim.period_ns) * 1e-9
            : t_s;
    if (t_s >= settle_s && since_step_s >= settle_s) {
      const int64_t error_ns = sync.DeviceToHostNs(device_ns) - host_event_reading_ns;
      result.abs_error_us.push_back(std::abs(static_cast<double>(error_ns)) * 1e-3);
    }
  }
  result.stats = sync.stats();
  return result;
}

double Percentile(std::vector<double> v, double q) {
  REQUIRE(!v.empty());
  std::sort(v.begin(), v.end());
  const auto i = static_cast<std::size_t>(std::lround(q * static_cast<double>(v.size() - 1)));
  return v[i];
}

TEST_CASE("ClockSyncOptions reject bad values naming the field", "[clock_sync]") {
  ClockSyncOptions o;
  CHECK(o.Validate().empty());
  o.window_s = 0.0;
  CHECK(o.Validate() == "window_s: expected > 0");
  o = {};
  o.min_skew_span_s = 20.0;
  CHECK(o.Validate() == "min_skew_span_s: expected < window_s");
  o = {};
  o.outlier_threshold_ms = -1.0;
  CHECK(o.Validate() == "outlier_threshold_ms: expected > 0");
  CHECK_THROWS_AS(ClockSync(o), InputError);
}

TEST_CASE("ClockSync without pairs maps identity, one pair gives the offset", "[clock_sync]") {
  ClockSync sync;
  CHECK_FALSE(sync.IsValid());
  CHECK(sync.DeviceToHostNs(42) == 42);
  sync.AddObservation(1000, 5000);
  CHECK_FALSE(sync.IsValid());
  CHECK(sync.DeviceToHostNs(2000) == 6000);
  CHECK(sync.stats().observations == 1);
}

TEST_CASE("ClockSync recovers offset and skew exactly without jitter", "[clock_sync]") {
  SimOptions sim;
  sim.drift_ppm = 50.0;
  sim.jitter_ms = 1e-9;
  sim.spike_probability = 0.0;
  sim.seconds = 20.0;
  const SimResult r = Simulate(sim);
  CHECK(Percentile(r.abs_error_us, 1.0) < 0.01);  // 10 ns: rounding only
  // d(host - device)/d(device) = 1 / (1 + 50e-6) - 1.
  CHECK(r.stats.skew_ppm == Approx(1e6 * (1.0 / (1.0 + 50e-6) - 1.0)).margin(0.01));
  CHECK(r.stats.resets == 0);
  CHECK(r.stats.valid);
}

// The target: residual offset error <= 0.1 ms at 1 ms jitter. Exponential delays of
// 1 ms mean plus 1 % spikes of 10-30 ms, drift 0 and +-50 ppm, several seeds; the bound asserted
// is the worst over all evaluated samples (after 2 s of warm-up).
TEST_CASE("ClockSync residual offset error at 1 ms jitter is below 0.1 ms", "[clock_sync]") {
  const double drift = GENERATE(0.0, 50.0, -50.0);
  const uint32_t seed = GENERATE(1u, 2u, 3u);
  const auto jitter = GENERATE(SimOptions::Jitter::kExponential, SimOptions::Jitter::kUniform);
  SimOptions sim;
  sim.drift_ppm = drift;
  sim.seed = seed;
  sim.jitter = jitter;
  sim.jitter_ms = jitter == SimOptions::Jitter::kExponential ? 1.0 : 2.0;  // both 1 ms mean
  const SimResult r = Simulate(sim);
  INFO("drift " << drift << " ppm, seed " << seed << ", p99 " << Percentile(r.abs_error_us, 0.99)
                << " us, max " << Percentile(r.abs_error_us, 1.0) << " us");
  // Measured (these seeds): max 33.4 us, median 2.6 us at worst; the issue asks <= 100 us.
  CHECK(Percentile(r.abs_error_us, 1.0) <= 50.0);
  CHECK(Percentile(r.abs_error_us, 0.5) <= 5.0);
  CHECK(r.stats.resets == 0);
  CHECK(r.stats.outliers > 0);  // the 1 % spikes above 10 ms
}

TEST_CASE("ClockSync ignores bursts of delayed samples (no reset)", "[clock_sync]") {
  SimOptions sim;
  sim.drift_ppm = 30.0;
  sim.burst_every = 400;  // 20 samples delayed 20..1 ms every 2 s, as a USB hiccup
  const SimResult r = Simulate(sim);
  CHECK(r.stats.resets == 0);
  CHECK(Percentile(r.abs_error_us, 1.0) <= 100.0);
}

TEST_CASE("ClockSync restarts after clock jumps and converges again", "[clock_sync]") {
  SimOptions sim;
  sim.drift_ppm = -40.0;
  sim.step_at = 6000;  // at 30 s
  SECTION("device clock steps forward 1 s") { sim.device_step_ns = 1 * kS; }
  SECTION("device clock steps back 0.3 s (less than it ran)") { sim.device_step_ns = -300 * kMs; }
  SECTION("device clock restarts from zero") { sim.device_restart = true; }
  SECTION("host clock steps forward 0.2 s (NTP)") { sim.host_step_ns = 200 * kMs; }
  SECTION("host clock steps back 0.2 s (NTP)") { sim.host_step_ns = -200 * kMs; }
  const SimResult r = Simulate(sim);
  CHECK(r.stats.resets == 1);
  CHECK(Percentile(r.abs_error_us, 1.0) <= 100.0);
}

TEST_CASE("ClockSync keeps a bounded window", "[clock_sync]") {
  ClockSyncOptions options;
  options.window_s = 2.0;
  options.min_skew_span_s = 0.5;
  options.max_window_observations = 300;
  ClockSync sync(options);
  for (int64_t k = 0; k < 5000; ++k) sync.AddObservation(k * 5 * kMs, k * 5 * kMs + 7 * kMs);
  const ClockSyncStats s = sync.stats();
  CHECK(s.window_size <= 330);  // 10 % eviction slack
  CHECK(s.window_size >= 300);
  CHECK(s.offset_ns == 7 * kMs);
  sync.Reset();
  CHECK_FALSE(sync.IsValid());
  CHECK(sync.stats().observations == 5000);
}

TEST_CASE("ClockSync treats a repeated device stamp by its least delayed arrival",
          "[clock_sync]") {
  ClockSync sync;
  for (int64_t k = 0; k < 20; ++k) sync.AddObservation(k * kMs, k * kMs + 3 * kMs);
  sync.AddObservation(19 * kMs, 19 * kMs + 2 * kMs);
  CHECK(sync.stats().window_size == 20);
  CHECK(sync.DeviceToHostNs(0) == 2 * kMs);  // offset-only (short span): the least delay
}

TEST_CASE("ClockSync survives a frozen device clock with bounded memory", "[clock_sync]") {
  ClockSyncOptions options;
  options.max_window_observations = 100;
  ClockSync sync(options);
  for (int64_t k = 0; k < 200; ++k) sync.AddObservation(k * 5 * kMs, k * 5 * kMs + kMs);
  // The device clock stops at 1 s while the host runs on: every pair is an ever larger outlier.
  for (int64_t k = 0; k < 1000; ++k) sync.AddObservation(kS, kS + k * 5 * kMs + 20 * kMs);
  const ClockSyncStats s = sync.stats();
  // 100 stuck pairs restart the filter from them; they share one device stamp, so the new
  // window holds one pair (the least delayed) and stays invalid: drivers publish nothing
  // stamped by a frozen clock.
  CHECK(s.resets == 1);
  CHECK(s.outliers == 100);
  CHECK(s.window_size == 1);
  CHECK_FALSE(sync.IsValid());
  CHECK(sync.DeviceToHostNs(kS) == kS + 20 * kMs);
}

TEST_CASE("MeasureRealtimeMinusMonotonicNs agrees with a naive reading", "[clock_sync]") {
  const int64_t a = MeasureRealtimeMinusMonotonicNs();
  const int64_t naive =
      std::chrono::duration_cast<std::chrono::nanoseconds>(
          std::chrono::system_clock::now().time_since_epoch())
          .count() -
      std::chrono::duration_cast<std::chrono::nanoseconds>(
          std::chrono::steady_clock::now().time_since_epoch())
          .count();
  const int64_t b = MeasureRealtimeMinusMonotonicNs(64);
  CHECK(std::abs(a - naive) < 1 * kMs);
  CHECK(std::abs(a - b) < 100 * kUs);  // unless NTP stepped the clock in between
}

// The table of docs/drivers.md and docs/benchmarks.md (scripts/bench-clock-sync.sh runs this
// hidden test): 200 Hz, 60 s, 1 % spikes of 10-30 ms, jitter scale x drift, 3 seeds each.
TEST_CASE("ClockSync residual error table", "[.clock_sync_bench]") {
  std::printf("| jitter (exp. mean) | drift | median [us] | p99 [us] | max [us] |\n");
  std::printf("|---|---|---|---|---|\n");
  for (double jitter_ms : {0.1, 1.0, 5.0}) {
    for (double drift : {0.0, 50.0}) {
      std::vector<double> all;
      for (uint32_t seed = 1; seed <= 3; ++seed) {
        SimOptions sim;
        sim.jitter_ms = jitter_ms;
        sim.drift_ppm = drift;
        sim.seed = seed;
        const SimResult r = Simulate(sim);
        all.insert(all.end(), r.abs_error_us.begin(), r.abs_error_us.end());
      }
      std::printf("| %.1f ms | %.0f ppm | %.1f | %.1f | %.1f |\n", jitter_ms, drift,
                  Percentile(all, 0.5), Percentile(all, 0.99), Percentile(all, 1.0));
    }
  }
}

}  // namespace
}  // namespace vilma
