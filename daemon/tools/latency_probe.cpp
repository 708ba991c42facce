// vilma-latency-probe: end-to-end latency of vilma-estimatord as seen by another process on the
// same host (scripts/bench-daemon.sh). It listens to the camera channel and to VILMA_ODOM and
// takes, per frame, (receive time of the VILMA_ODOM message) - (receive time of the image with
// the same utime), both on this process's steady clock. For replayed or simulated data the
// image utime is dataset time, not the wall clock, so "utime -> published" is measured from the
// moment the image is on the bus instead (this includes LCM transport of the image, decoding,
// synchronization, the filter update and publishing). Requires a rig with zero camera time
// offset (pose utime = image utime).
#include <algorithm>
#include <atomic>
#include <chrono>
#include <cstdio>
#include <iostream>
#include <lcm/lcm-cpp.hpp>
#include <map>
#include <string>
#include <vector>

#include <vilma/pose_t.hpp>
#include <vilma/status_t.hpp>

#include "vilma/core/arg_cursor.h"

#include "vilma/core/timing.h"
#include "vilma/drivers/lcm_convert.h"
#include "vilma/drivers/lcm_safe_decode.h"
#include "vilma/drivers/lcm_url.h"

namespace {

using vilma::Percentile;

int64_t SteadyNs() {
  return std::chrono::duration_cast<std::chrono::nanoseconds>(
             std::chrono::steady_clock::now().time_since_epoch())
      .count();
}

struct Probe {
  std::map<int64_t, int64_t> image_recv_ns;  // utime -> receive time
  std::vector<double> latency_ms;
  int64_t images = 0, odom = 0, unmatched = 0, last_odom_ns = 0;
  std::vector<double> cpu_loads;
  std::map<std::string, int64_t> last_counters;

  void OnImage(const lcm::ReceiveBuffer* rbuf, const std::string&) {
    int64_t utime = 0, seq = 0;
    if (!vilma::PeekUtimeAndSeq(rbuf->data, static_cast<int>(rbuf->data_size), &utime, &seq)) return;
    image_recv_ns[utime] = SteadyNs();
    ++images;
  }
  // Raw subscriptions: lcm-gen's typed decoders throw (or allocate what a count claims) on
  // hostile bytes, which would end the probe (lcm_safe_decode.h). Malformed messages are counted.
  int64_t malformed = 0;
  void OnOdomBytes(const lcm::ReceiveBuffer* rbuf, const std::string&) {
    vilma::pose_t msg;
    bool ok = false;
    try {
      ok = msg.decode(rbuf->data, 0, static_cast<int>(rbuf->data_size)) ==
           static_cast<int>(rbuf->data_size);
    } catch (const std::exception&) {  // a string length lcm-gen does not check
    }
    if (!ok) {
      ++malformed;
      return;
    }
    OnOdom(&msg);
  }
  void OnStatusBytes(const lcm::ReceiveBuffer* rbuf, const std::string&) {
    vilma::status_t msg;
    if (!vilma::DecodeStatusMessage(rbuf->data, static_cast<int>(rbuf->data_size), &msg).empty()) {
      ++malformed;
      return;
    }
    OnStatus(&msg);
  }
  void OnOdom(const vilma::pose_t* msg) {
    const int64_t now = SteadyNs();
    last_odom_ns = now;
    ++odom;
    const auto it = image_recv_ns.find(msg->utime);
    if (it == image_recv_ns.end()) {
      ++unmatched;
      return;
    }
    latency_ms.push_back(static_cast<double>(now - it->second) * 1e-6);
    image_recv_ns.erase(image_recv_ns.begin(), std::next(it));
  }
  void OnStatus(const vilma::status_t* msg) {
    for (int i = 0; i < msg->num_counters; ++i) last_counters[msg->counter_names[i]] = msg->counter_values[i];
    for (int i = 0; i < msg->num_metrics; ++i) {
      // Only reports while frames flow (the first and the last include idle time).
      if (msg->metric_names[i] == "cpu_load" && msg->state == vilma::status_t::OK) {
        cpu_loads.push_back(msg->metric_values[i]);
      }
    }
  }
};

}  // namespace

int main(int argc, char** argv) {
  std::string url, camera = "CAM0", odom = "VILMA_ODOM", status = "VILMA_STATUS";
  double idle_timeout_s = 3.0, max_s = 600.0;
  const std::vector<std::string> args(argv + 1, argv + argc);
  try {
    for (vilma::ArgCursor arg(args); arg.Next();) {
      const std::string& a = arg.name();
      if (a == "--help" || a == "-h") {
        std::cout << "usage: vilma-latency-probe [--lcm-url URL] [--camera-channel CAM0]\n"
                     "                           [--idle-timeout S] [--max-seconds S]\n"
                     "Prints the end-to-end latency of vilma-estimatord (image on the bus ->\n"
                     "VILMA_ODOM received) p50/p99/max, the daemon's CPU load from VILMA_STATUS\n"
                     "and its drop counters. Ends S seconds after the last VILMA_ODOM.\n";
        return 0;
      } else if (a == "--lcm-url") {
        url = arg.Value();
      } else if (a == "--camera-channel") {
        camera = arg.Value();
      } else if (a == "--idle-timeout") {
        idle_timeout_s = arg.DoubleValueIn(0.0, 1e6);
      } else if (a == "--max-seconds") {
        max_s = arg.DoubleValueIn(0.0, 1e7);
      } else {
        throw vilma::UsageError("unknown argument '" + arg.word() + "'");
      }
    }
  } catch (const vilma::UsageError& e) {
    std::cerr << "vilma-latency-probe: " << e.what() << " (see --help)\n";
    return 2;
  }
  lcm::LCM lcm(vilma::WithDefaultRecvBufSize(vilma::ResolveLcmUrl(url)));
  if (!lcm.good()) {
    std::cerr << "vilma-latency-probe: cannot open LCM\n";
    return 1;
  }
  Probe probe;
  lcm.subscribe(camera, &Probe::OnImage, &probe);
  lcm.subscribe(odom, &Probe::OnOdomBytes, &probe);
  lcm.subscribe(status, &Probe::OnStatusBytes, &probe);
  std::cout << "listening" << std::endl;
  const int64_t start = SteadyNs();
  while (true) {
    lcm.handleTimeout(50);
    const int64_t now = SteadyNs();
    if (probe.odom > 0 && now - probe.last_odom_ns > static_cast<int64_t>(idle_timeout_s * 1e9)) break;
    if (now - start > static_cast<int64_t>(max_s * 1e9)) break;
  }
  double cpu = 0.0;
  for (double c : probe.cpu_loads) cpu += c;
  if (!probe.cpu_loads.empty()) cpu /= static_cast<double>(probe.cpu_loads.size());
  std::printf("images %lld odom %lld matched %zu\n", static_cast<long long>(probe.images),
              static_cast<long long>(probe.odom), probe.latency_ms.size());
  std::printf("latency_ms p50 %.2f p99 %.2f max %.2f\n", Percentile(probe.latency_ms, 0.5),
              Percentile(probe.latency_ms, 0.99), Percentile(probe.latency_ms, 1.0));
  std::printf("status_cpu_load %.3f\n", cpu);
  std::printf("probe_malformed %lld\n", static_cast<long long>(probe.malformed));
  for (const char* name : {"drops", "malformed_messages", "frames_filtered", "images_received",
                           "imu_received", "filter_resets"}) {
    std::printf("%s %lld\n", name, static_cast<long long>(probe.last_counters[name]));
  }
  return 0;
}
