// vilma-estimatord: the realtime visual-inertial estimator daemon (docs/daemon.md).
#include <signal.h>

#include <atomic>
#include <cstdio>
#include <cstdlib>
#include <iostream>
#include <opencv2/core/utility.hpp>
#include <string>
#include <thread>
#include <vector>

#include "vilma/core/arg_cursor.h"
#include "vilma/core/error.h"
#include "vilma/core/heap.h"
#include "vilma/core/rig.h"
#include "vilma/daemon/daemon_options.h"
#include "vilma/daemon/estimator_daemon.h"

namespace {

constexpr int kExitOk = 0, kExitInput = 1, kExitUsage = 2, kExitMapNotSaved = 3;

void PrintHelp() {
  std::cout
      << "usage: vilma-estimatord [--config daemon.yaml] [--rig rig.yaml] [--lcm-url URL]\n"
         "                        [--channel-suffix S] [--input-log FILE] [--save-map DIR]\n"
         "                        [--localization-map FILE|MAPDIR] [--stereo] [--print-config]\n"
         "                        [--fault-stall-filter-after N] [--fault-reset-filter-at N]\n"
         "                        [--help]\n"
         "\n"
         "Realtime visual-inertial odometry on LCM: subscribes to the camera and IMU channels,\n"
         "publishes VILMA_ODOM (pose_t T_M_I, every frame) and VILMA_STATUS (status_t, 1 Hz).\n"
         "Runs under systemd as Type=notify with a watchdog (config/systemd/, docs/daemon.md).\n"
         "\n"
         "  --config FILE       daemon options (default: built-in = config/daemon.yaml)\n"
         "  --rig FILE          sensor rig YAML (overrides 'rig' of the config; required)\n"
         "  --lcm-url URL       LCM provider (default $LCM_DEFAULT_URL or\n"
         "                      udpm://239.255.76.67:7667?ttl=0; recv_buf_size is added)\n"
         "  --channel-suffix S  appended to every channel name\n"
         "  --input-log FILE    read an lcm-logger file instead of subscribing: log order, no\n"
         "                      pacing, no drops (blocking), same output on every run; output on\n"
         "                      --lcm-url; exits at the end of the log\n"
         "  --save-map DIR      build a VI-map mission (map-builder stage, mapping.* options) and\n"
         "                      save it into DIR (absent or empty) at the end of the log or on\n"
         "                      SIGTERM; the map builder's Finish and the save come after the\n"
         "                      pipeline's flush and take longer for long missions (about 1 s\n"
         "                      per 10 min of mapping; TimeoutStopSec in the systemd unit)\n"
         "  --localization-map FILE|MAPDIR   LOC mode: localize against this localization map\n"
         "                      file or VI-map folder (localization.* options); publishes\n"
         "                      VILMA_POSE (T_G_I) every frame once T_G_M is known\n"
         "  --stereo            also use the second camera (stereo: true; the estimator's\n"
         "                      stereo.camera, default 1, on channels.cameras): photometric\n"
         "                      updates in both images and stereo-matched initial depths; a\n"
         "                      frame whose second image is missing is updated with the VIO\n"
         "                      camera only (counted: frames_without_stereo)\n"
         "  --print-config      print the effective options and exit\n"
         "  --fault-stall-filter-after N   test: the filter thread stalls after N frames\n"
         "                      (the systemd watchdog is then no longer petted)\n"
         "  --fault-reset-filter-at N      test: the filter resets at its N-th frame, as on a\n"
         "                      failed health check (the map builder starts a new mission)\n"
         "\n"
         "SIGTERM / SIGINT: stop, flush, finish the mission, exit 0. Exit status: 0 OK, 1 bad\n"
         "input (file, field), 2 bad command line, 3 the map could not be saved (--save-map).\n";
}

}  // namespace

int main(int argc, char** argv) {
  // Large transient buffers (the localizer's per-query work, a mission delta's encoding) are
  // mmapped and so returned when freed: with glibc's dynamic threshold each thread arena kept
  // the largest burst it had served (an hour soak: RSS +5.1 %, in steps of up to 4.7 MB in an
  // arena with nothing in use; vilma/core/heap.h, docs/reliability.md "Soak").
  vilma::FixMallocMmapThreshold();
  std::string config_path, rig_path, lcm_url, suffix, input_log, save_map, loc_map;
  bool have_url = false, have_suffix = false, print_config = false, stereo = false;
  long long stall_after = -1;
  long long reset_at = -1;
  const std::vector<std::string> args(argv + 1, argv + argc);
  try {
    // Frame counts of the fault-injection options (tests).
    const auto frame_count = [](vilma::ArgCursor& arg) {
      const std::string v = arg.Value();
      std::size_t used = 0;
      long long n = -1;
      try {
        n = std::stoll(v, &used);
      } catch (const std::exception&) {
        used = 0;
      }
      if (used != v.size() || n < 0) {
        throw vilma::UsageError(arg.name() + ": expected a frame count >= 0, got '" + v + "'");
      }
      return n;
    };
    for (vilma::ArgCursor arg(args); arg.Next();) {
      const std::string& a = arg.name();
      if (a == "--help" || a == "-h") {
        arg.Flag();
        PrintHelp();
        return kExitOk;
      } else if (a == "--config") {
        config_path = arg.Value();
      } else if (a == "--rig") {
        rig_path = arg.Value();
      } else if (a == "--lcm-url") {
        lcm_url = arg.Value();
        have_url = true;
      } else if (a == "--channel-suffix") {
        suffix = arg.Value();
        have_suffix = true;
      } else if (a == "--input-log") {
        input_log = arg.Value();
      } else if (a == "--save-map") {
        save_map = arg.Value();
        if (save_map.empty()) throw vilma::UsageError("--save-map: expected a folder");
      } else if (a == "--localization-map") {
        loc_map = arg.Value();
        if (loc_map.empty()) {
          throw vilma::UsageError("--localization-map: expected a file or folder");
        }
      } else if (a == "--stereo") {
        stereo = arg.Flag();
      } else if (a == "--print-config") {
        print_config = arg.Flag();
      } else if (a == "--fault-stall-filter-after") {
        stall_after = frame_count(arg);
      } else if (a == "--fault-reset-filter-at") {
        reset_at = frame_count(arg);
      } else {
        throw vilma::UsageError("unknown argument '" + arg.word() + "'");
      }
    }
  } catch (const vilma::UsageError& e) {
    std::cerr << "vilma-estimatord: " << e.what() << "\n(see 'vilma-estimatord --help')\n";
    return kExitUsage;
  }

  vilma::daemon::DaemonOptions options;
  vilma::SensorRig rig;
  std::unique_ptr<vilma::daemon::EstimatorDaemon> daemon;
  // Signals are taken by a thread of our own (sigtimedwait), not by a handler: every other
  // thread inherits the blocked mask, and the stop request runs in normal thread context.
  sigset_t signals;
  sigemptyset(&signals);
  sigaddset(&signals, SIGTERM);
  sigaddset(&signals, SIGINT);
  pthread_sigmask(SIG_BLOCK, &signals, nullptr);
  try {
    if (!config_path.empty()) options = vilma::daemon::LoadDaemonOptions(config_path);
    if (!rig_path.empty()) options.rig = rig_path;
    if (have_url) options.lcm_url = lcm_url;
    if (have_suffix) options.channel_suffix = suffix;
    options.input_log = input_log;
    if (!save_map.empty()) {
      options.mapping.enabled = true;
      options.mapping.save_dir = save_map;
    }
    if (!loc_map.empty()) {
      options.localization.enabled = true;
      options.localization.map = loc_map;
    }
    if (stereo) options.stereo = true;
    options.fault_stall_filter_after = stall_after;
    options.fault_reset_filter_at = reset_at;
    vilma::ThrowIfInvalid(options.Validate(), config_path.empty() ? "command line" : config_path);
    if (options.rig.empty()) {
      throw vilma::InputError("no sensor rig: give --rig FILE (or 'rig' in --config)");
    }
    rig = vilma::LoadSensorRig(options.rig);
    std::cout << "vilma-estimatord: effective configuration\n"
              << vilma::daemon::DaemonOptionsToYaml(options) << std::flush;
    if (print_config) return kExitOk;
    cv::setNumThreads(1);  // one core for the filter, deterministic
    daemon = std::make_unique<vilma::daemon::EstimatorDaemon>(options, rig);
  } catch (const vilma::InputError& e) {
    std::cerr << "vilma-estimatord: error: " << e.what() << "\n";
    return kExitInput;
  } catch (const std::exception& e) {
    std::cerr << "vilma-estimatord: error: " << e.what() << "\n";
    return kExitInput;
  }

  std::atomic<bool> finished{false};
  std::thread signal_thread([&] {
    while (!finished.load()) {
      timespec timeout{0, 100000000};
      const int sig = sigtimedwait(&signals, nullptr, &timeout);
      if (sig == SIGTERM || sig == SIGINT) {
        std::fprintf(stderr, "vilma-estimatord: %s: stopping\n",
                     sig == SIGTERM ? "SIGTERM" : "SIGINT");
        daemon->RequestStop();
      }
    }
  });
  const vilma::daemon::DaemonSummary summary = daemon->Run();
  finished.store(true);
  signal_thread.join();
  std::cout << summary.FullReport("vilma-estimatord: ") << std::flush;
  if (!summary.map_error.empty()) return kExitMapNotSaved;
  return kExitOk;
}
