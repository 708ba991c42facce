#include "vilma/core/timing.h"

#include <catch2/catch.hpp>
#include <thread>

namespace vilma {
namespace {

TEST_CASE("Percentile is the nearest-rank quantile", "[timing]") {
  CHECK(Percentile({}, 0.5) == 0.0);
  CHECK(Percentile({7.0}, 0.9) == 7.0);
  // Unsorted input; index round(q * (n - 1)) of the sorted values 1..5.
  const std::vector<double> v = {5.0, 1.0, 4.0, 2.0, 3.0};
  CHECK(Percentile(v, 0.0) == 1.0);
  CHECK(Percentile(v, 0.5) == 3.0);
  CHECK(Percentile(v, 0.9) == 5.0);   // 3.6 -> 4
  CHECK(Percentile(v, 0.6) == 3.0);   // 2.4 -> 2
  CHECK(Percentile(v, 0.625) == 4.0); // 2.5 rounds away from zero -> 3
  CHECK(Percentile(v, 1.0) == 5.0);
  CHECK(Percentile(v, 2.0) == 5.0);   // clamped
}

TEST_CASE("MsSince counts wall time, ThreadCpuMs only this thread's work", "[timing]") {
  const auto t0 = std::chrono::steady_clock::now();
  const double cpu0 = ThreadCpuMs();
  std::this_thread::sleep_for(std::chrono::milliseconds(30));
  const double wall_ms = MsSince(t0);
  const double cpu_ms = ThreadCpuMs() - cpu0;
  CHECK(wall_ms >= 30.0);
  CHECK(cpu_ms >= 0.0);
  CHECK(cpu_ms < 0.5 * wall_ms);  // sleeping costs (almost) no CPU
}

}  // namespace
}  // namespace vilma
