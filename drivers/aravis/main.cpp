// vilma-aravis: a GenICam camera (GigE Vision / USB3 Vision, Aravis 0.8) on LCM. See
// `vilma-aravis --help` and docs/drivers.md; the logic is in vilma_driver_aravis (src/).
#include <signal.h>

#include <atomic>
#include <iostream>
#include <lcm/lcm-cpp.hpp>
#include <string>
#include <thread>
#include <vector>

#include <arv.h>

#include "vilma/core/arg_cursor.h"
#include "vilma/core/error.h"
#include "vilma/drivers/aravis/aravis_driver.h"
#include "vilma/drivers/lcm_url.h"

namespace {
constexpr int kExitOk = 0, kExitRuntime = 1, kExitUsage = 2;
}  // namespace

int main(int argc, char** argv) {
  vilma::aravis::AravisCommandLine command_line;
  try {
    command_line = vilma::aravis::ParseAravisCommandLine(std::vector<std::string>(argv + 1, argv + argc));
  } catch (const vilma::UsageError& e) {
    std::cerr << "vilma-aravis: " << e.what() << "\n(see 'vilma-aravis --help')\n";
    return kExitUsage;
  } catch (const vilma::InputError& e) {
    std::cerr << "vilma-aravis: " << e.what() << "\n";
    return kExitUsage;
  }
  if (command_line.help) {
    std::cout << vilma::aravis::AravisUsage();
    return kExitOk;
  }
  const vilma::aravis::AravisOptions& options = command_line.options;
  if (command_line.print_config) {
    std::cout << vilma::aravis::AravisOptionsToYaml(options);
    return kExitOk;
  }
  if (command_line.list) {
    std::string error;
    try {
      std::cout << vilma::aravis::ListCameras(options, &error) << std::flush;
    } catch (const std::exception& e) {
      error = e.what();
    }
    arv_shutdown();
    if (!error.empty()) {
      std::cerr << "vilma-aravis: " << error << "\n";
      return kExitRuntime;
    }
    return kExitOk;
  }

  // Signals are taken by a thread of our own (sigtimedwait): Aravis's threads and LCM's inherit
  // the blocked mask, and the stop request is an atomic read by the capture loop.
  sigset_t signals;
  sigemptyset(&signals);
  sigaddset(&signals, SIGTERM);
  sigaddset(&signals, SIGINT);
  pthread_sigmask(SIG_BLOCK, &signals, nullptr);
  std::atomic<bool> stop{false};
  std::atomic<bool> finished{false};
  std::thread signal_thread([&] {
    while (!finished.load()) {
      timespec timeout{0, 100000000};
      const int sig = sigtimedwait(&signals, nullptr, &timeout);
      if (sig == SIGTERM || sig == SIGINT) {
        std::cerr << "vilma-aravis: " << (sig == SIGTERM ? "SIGTERM" : "SIGINT") << ": stopping\n";
        stop.store(true);
      }
    }
  });

  std::cout << "vilma-aravis: effective configuration\n"
            << vilma::aravis::AravisOptionsToYaml(options) << std::flush;
  const std::string url = vilma::ResolveLcmUrl(options.lcm_url);
  int exit_code = kExitOk;
  {
    lcm::LCM lcm(url);
    if (!lcm.good()) {
      std::cerr << "vilma-aravis: cannot open LCM at " << url
                << " (multicast route? see docs/lcm.md)\n";
      exit_code = kExitRuntime;
    } else {
      const vilma::aravis::AravisRunSummary summary =
          vilma::aravis::RunAravisDriver(options, &lcm, &stop, &std::cout);
      if (!summary.error.empty()) {
        std::cerr << "vilma-aravis: error: " << summary.error << "\n";
        exit_code = kExitRuntime;
      }
    }
  }
  finished.store(true);
  signal_thread.join();
  arv_shutdown();
  return exit_code;
}
