// vilma-frame-latency: how long after a camera frame's end of exposure its image_t arrives at
// an LCM subscriber (scripts/bench-drivers.sh, docs/drivers.md "Latency").
//
// The end of exposure is utime + exposure_us / 2 (drivers stamp mid-exposure). Receive times
// are CLOCK_REALTIME, the robot clock of utime, so the figure is meaningful where the driver's
// stamps are on this host's clock: any driver on this machine (vilma-aravis maps the camera
// clock onto it; with --fake the camera clock *is* this clock).
#include <time.h>

#include <algorithm>
#include <atomic>
#include <cmath>
#include <cstdio>
#include <iostream>
#include <lcm/lcm-cpp.hpp>
#include <string>
#include <vector>
#include <vilma/image_t.hpp>

#include "vilma/core/arg_cursor.h"
#include "vilma/core/validate.h"
#include "vilma/drivers/lcm_url.h"

namespace {

constexpr int kExitOk = 0, kExitRuntime = 1, kExitUsage = 2;

const char kUsage[] = R"(Usage: vilma-frame-latency [options]

Subscribes to an image channel for a while and prints how long after each frame's end of
exposure (utime + exposure_us / 2, on CLOCK_REALTIME) it arrived here: count, rate, latency
p50 / p99 / max [ms]. For drivers on this host (their utime is this host's clock).

Options:
  --channel NAME     image channel (default CAM0)
  --lcm-url URL      LCM provider (default $LCM_DEFAULT_URL, else
                     udpm://239.255.76.67:7667?ttl=0; recv_buf_size is added)
  --seconds T        listen this long (default 10)
  --skip N           leave out the first N frames (default 5: start-up)
  --min-frames N     exit 1 if fewer frames arrived (default 1)
  --help             this text

Exit status: 0 measured, 1 too few frames or LCM unusable, 2 bad command line.
)";

int64_t RealtimeNs() {
  timespec ts{};
  clock_gettime(CLOCK_REALTIME, &ts);
  return static_cast<int64_t>(ts.tv_sec) * 1000000000 + ts.tv_nsec;
}

double Quantile(std::vector<double> v, double q) {
  if (v.empty()) return 0.0;
  const auto k = static_cast<std::size_t>(std::lround(q * static_cast<double>(v.size() - 1)));
  std::nth_element(v.begin(), v.begin() + static_cast<std::ptrdiff_t>(k), v.end());
  return v[k];
}

struct Collector {
  std::vector<double> latency_ms;
  std::vector<int64_t> utimes;
  int skip = 0;
  int seen = 0;
  void On(const lcm::ReceiveBuffer*, const std::string&, const vilma::image_t* msg) {
    const int64_t now_ns = RealtimeNs();
    if (seen++ < skip) return;
    const int64_t exposure_end_ns = msg->utime * 1000 + int64_t{msg->exposure_us} * 500;
    latency_ms.push_back(static_cast<double>(now_ns - exposure_end_ns) * 1e-6);
    utimes.push_back(msg->utime);
  }
};

int ParseCount(vilma::ArgCursor& arg) {
  const std::string text = arg.Value();
  std::size_t used = 0;
  int n = -1;
  try {
    n = std::stoi(text, &used);
  } catch (const std::exception&) {
    used = 0;
  }
  if (used != text.size() || n < 0) {
    throw vilma::UsageError(arg.name() + ": expected a count >= 0, got '" + text + "'");
  }
  return n;
}

}  // namespace

int main(int argc, char** argv) {
  std::string channel = "CAM0";
  std::string url;
  double seconds = 10.0;
  int skip = 5;
  int min_frames = 1;
  try {
    const std::vector<std::string> args(argv + 1, argv + argc);
    for (vilma::ArgCursor arg(args); arg.Next();) {
      if (arg.name() == "--help" || arg.name() == "-h") {
        arg.Flag();
        std::cout << kUsage;
        return kExitOk;
      } else if (arg.name() == "--channel") {
        channel = arg.Value();
        const std::string problem = vilma::ValidateChannelName(channel);
        if (!problem.empty()) throw vilma::UsageError("--channel: " + problem);
      } else if (arg.name() == "--lcm-url") {
        url = arg.Value();
      } else if (arg.name() == "--seconds") {
        const std::string text = arg.Value();
        char* end = nullptr;
        seconds = std::strtod(text.c_str(), &end);
        if (text.empty() || *end != '\0' || !(seconds > 0.0) || !std::isfinite(seconds)) {
          throw vilma::UsageError("--seconds: expected a number > 0, got '" + text + "'");
        }
      } else if (arg.name() == "--skip") {
        skip = ParseCount(arg);
      } else if (arg.name() == "--min-frames") {
        min_frames = ParseCount(arg);
      } else {
        throw vilma::UsageError("unknown argument '" + arg.word() + "'");
      }
    }
  } catch (const vilma::UsageError& e) {
    std::cerr << "vilma-frame-latency: " << e.what() << "\n(see 'vilma-frame-latency --help')\n";
    return kExitUsage;
  }
  const std::string resolved = vilma::WithDefaultRecvBufSize(vilma::ResolveLcmUrl(url));
  lcm::LCM lcm(resolved);
  if (!lcm.good()) {
    std::cerr << "vilma-frame-latency: cannot open LCM at " << resolved << "\n";
    return kExitRuntime;
  }
  Collector collector;
  collector.skip = skip;
  lcm.subscribe(channel, &Collector::On, &collector);
  const int64_t end_ns = RealtimeNs() + static_cast<int64_t>(seconds * 1e9);
  while (RealtimeNs() < end_ns) lcm.handleTimeout(50);

  const std::size_t n = collector.latency_ms.size();
  if (n < static_cast<std::size_t>(std::max(min_frames, 1))) {
    std::cerr << "vilma-frame-latency: " << n << " frames on " << channel << " (expected >= "
              << std::max(min_frames, 1) << ")\n";
    return kExitRuntime;
  }
  const double span_s =
      static_cast<double>(collector.utimes.back() - collector.utimes.front()) * 1e-6;
  const double rate_hz = n > 1 && span_s > 0 ? static_cast<double>(n - 1) / span_s : 0.0;
  const double max_ms =
      *std::max_element(collector.latency_ms.begin(), collector.latency_ms.end());
  std::printf("channel %s: %zu frames, %.2f Hz, latency from end of exposure: p50 %.2f ms, "
              "p99 %.2f ms, max %.2f ms\n",
              channel.c_str(), n, rate_hz, Quantile(collector.latency_ms, 0.5),
              Quantile(collector.latency_ms, 0.99), max_ms);
  return kExitOk;
}
