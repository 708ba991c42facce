// vilma-lcm-rates: subscribes to all channels of an LCM bus and prints per-channel rates and
// counts every second, and a final table with the messages lost (seq gaps of vilma.image_t /
// vilma.imu_t). Used by scripts/bench-replay.sh and scripts/demo.sh.
#include <atomic>
#include <chrono>
#include <cmath>
#include <csignal>
#include <cstdlib>
#include <iostream>
#include <lcm/lcm-cpp.hpp>
#include <string>
#include <vector>

#include "vilma/core/arg_cursor.h"
#include "vilma/drivers/lcm_rates.h"
#include "vilma/drivers/lcm_url.h"

namespace {

std::atomic<bool> g_stop{false};
void OnSignal(int) { g_stop = true; }

const char kUsage[] = R"(Usage: vilma-lcm-rates [options]

Prints per-channel message rates and counts of an LCM bus every second, and a final table
(messages, MB, msg/s, MB/s, lost = gaps in the seq of vilma.image_t / vilma.imu_t).

Options:
  --lcm-url URL         LCM provider (default $LCM_DEFAULT_URL, else
                        udpm://239.255.76.67:7667?ttl=0)
  --recv-buf-size BYTES UDP receive buffer added to a udpm URL that has none
                        (default 8388608; 0 = leave the URL as is; see docs/lcm.md)
  --channels REGEX      channels to watch (default .*)
  --duration S          stop after S seconds (default 0 = until Ctrl-C)
  --expect-count N      stop when N messages arrived; exit status 4 if fewer arrived
  --idle-timeout S      stop S seconds after the last message (default 0 = never)
  --quiet               no per-second lines, only the final table
  --help                this text

Exit status: 0 on success, 1 when LCM cannot be opened, 2 on bad options, 4 when
--expect-count messages did not arrive.
)";

struct Options {
  std::string lcm_url;
  long long recv_buf_size = vilma::kRecommendedRecvBufSize;
  std::string channels = ".*";
  double duration_s = 0.0;
  long long expect_count = -1;
  double idle_timeout_s = 0.0;
  bool quiet = false;
};

// Returns an error message; "help" for --help.
std::string Parse(int argc, char** argv, Options* o) {
  const std::vector<std::string> args(argv + 1, argv + argc);
  try {
    for (vilma::ArgCursor arg(args); arg.Next();) {
      const std::string& name = arg.name();
      if (name == "--help" || name == "-h") {
        return "help";
      } else if (name == "--quiet") {
        o->quiet = arg.Flag();
      } else if (name == "--lcm-url") {
        o->lcm_url = arg.Value();
      } else if (name == "--channels") {
        o->channels = arg.Value();
      } else if (name == "--recv-buf-size") {
        o->recv_buf_size = arg.Int64Value(0);
      } else if (name == "--duration") {
        o->duration_s = arg.DoubleValueIn(0.0, 1e9);
      } else if (name == "--expect-count") {
        o->expect_count = arg.Int64Value(0);
      } else if (name == "--idle-timeout") {
        o->idle_timeout_s = arg.DoubleValueIn(0.0, 1e9);
      } else {
        return "unknown option " + arg.word();
      }
    }
  } catch (const vilma::UsageError& e) {
    return e.what();
  }
  return "";
}

struct Context {
  vilma::LcmRateMonitor* monitor;
  std::chrono::steady_clock::time_point start;
};

void OnMessage(const lcm::ReceiveBuffer* rbuf, const std::string& channel, Context* context) {
  const double t_s =
      std::chrono::duration<double>(std::chrono::steady_clock::now() - context->start).count();
  context->monitor->OnMessage(channel, rbuf->data, static_cast<int>(rbuf->data_size), t_s);
}

}  // namespace

int main(int argc, char** argv) {
  Options options;
  const std::string error = Parse(argc, argv, &options);
  if (error == "help") {
    std::cout << kUsage;
    return 0;
  }
  if (!error.empty()) {
    std::cerr << "vilma-lcm-rates: " << error << "\n(see vilma-lcm-rates --help)\n";
    return 2;
  }
  std::string url = vilma::ResolveLcmUrl(options.lcm_url);
  if (options.recv_buf_size > 0) url = vilma::WithDefaultRecvBufSize(url, options.recv_buf_size);
  lcm::LCM lcm(url);
  if (!lcm.good()) {
    std::cerr << "vilma-lcm-rates: cannot open LCM URL " << url << "\n";
    return 1;
  }
  std::signal(SIGINT, OnSignal);
  std::signal(SIGTERM, OnSignal);

  vilma::LcmRateMonitor monitor;
  using Clock = std::chrono::steady_clock;
  Context context{&monitor, Clock::now()};
  lcm.subscribeFunction(options.channels, &OnMessage, &context);
  std::cout << "vilma-lcm-rates: listening on " << url << "\n" << std::flush;

  Clock::time_point next_report = context.start + std::chrono::seconds(1);
  Clock::time_point last_message = context.start;
  int64_t last_count = 0;
  while (!g_stop) {
    lcm.handleTimeout(50);  // [ms]
    const Clock::time_point now = Clock::now();
    const int64_t count = monitor.total_messages();
    if (count != last_count) {
      last_count = count;
      last_message = now;
    }
    if (now >= next_report) {
      if (!options.quiet) {
        const double t = std::chrono::duration<double>(now - context.start).count();
        std::cout << "t=" << static_cast<int>(std::lround(t)) << " s\n"
                  << monitor.PeriodicReport(1.0) << std::flush;
      }
      next_report += std::chrono::seconds(1);
    }
    if (options.expect_count >= 0 && count >= options.expect_count) break;
    if (options.duration_s > 0 &&
        std::chrono::duration<double>(now - context.start).count() >= options.duration_s) {
      break;
    }
    if (options.idle_timeout_s > 0 && count > 0 &&
        std::chrono::duration<double>(now - last_message).count() >= options.idle_timeout_s) {
      break;
    }
  }
  std::cout << monitor.FullReport();
  if (options.expect_count >= 0) {
    const long long missing = options.expect_count - monitor.total_messages();
    std::cout << "EXPECTED " << options.expect_count << " missing=" << (missing > 0 ? missing : 0)
              << "\n";
    std::cout.flush();
    return missing > 0 ? 4 : 0;
  }
  return 0;
}
