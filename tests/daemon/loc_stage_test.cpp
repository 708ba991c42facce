// The localization query scheduler (daemon/src/loc_stage.h): which tracking frames go to the
// localizer.
#include "loc_stage.h"

#include <catch2/catch.hpp>

namespace vilma::daemon {

TEST_CASE("loc scheduler: every N-th frame, N = ceil(camera rate / max rate)", "[daemon][localization]") {
  struct Case {
    double camera_hz, max_hz;
    int64_t every_n;
  };
  for (const Case c : {Case{20, 2, 10}, Case{25, 3, 9}, Case{20, 20, 1}, Case{20, 100, 1},
                       Case{20, 3, 7}}) {
    INFO(c.camera_hz << " Hz camera, " << c.max_hz << " Hz at most");
    LocQueryScheduler counting(c.camera_hz, c.max_hz, true);
    CHECK(counting.every_n() == c.every_n);
    const int64_t period = static_cast<int64_t>(1e9 / c.camera_hz);
    int wanted = 0;
    for (int i = 0; i < 100; ++i) {
      const bool w = counting.Wanted(i * period);
      CHECK(w == (i % c.every_n == 0));
      if (w) counting.Queried(i * period);
      wanted += w;
    }
    // Never more often than the maximum rate.
    CHECK(wanted / (100.0 / c.camera_hz) <= c.max_hz + 1e-9 + c.camera_hz / 100.0);
  }
}

TEST_CASE("loc scheduler: live, (N - 1/2) camera periods since the last query absorb jitter",
          "[daemon][localization]") {
  LocQueryScheduler live(20.0, 2.0, false);
  CHECK(live.min_dt_ns() == 475'000'000);  // 9.5 periods of 50 ms
  // 2 ms stamp jitter: still every 10th frame.
  int64_t last = -1;
  for (int i = 0; i < 100; ++i) {
    const int64_t t = 1'000'000'000 + i * int64_t{50'000'000} + (i % 2 ? 2'000'000 : -2'000'000);
    if (live.Wanted(t)) {
      CHECK(i % 10 == 0);
      live.Queried(t);
      last = i;
    }
  }
  CHECK(last == 90);
  // A frame that was wanted but could not be queried (localizer busy) does not count: the
  // next frame is wanted.
  LocQueryScheduler busy(20.0, 2.0, false);
  CHECK(busy.Wanted(0));
  CHECK(busy.Wanted(50'000'000));
  busy.Queried(50'000'000);
  CHECK_FALSE(busy.Wanted(100'000'000));
  // Without a camera rate: 1 / max_rate_hz.
  LocQueryScheduler no_rate(0.0, 4.0, false);
  CHECK(no_rate.every_n() == 1);
  CHECK(no_rate.min_dt_ns() == 250'000'000);
}

}  // namespace vilma::daemon
