// The harness of the vilma-usb-imu end-to-end tests (usb_imu_pty_test.cpp, and the figures of
// usb_imu_pty_bench_test.cpp): a simulated MicroStrain IMU on a pseudo-terminal's master side
// (usb_imu_sim_device.h) with a drifting clock and injected faults, an LCM subscriber of IMU and
// VILMA_STATUS_IMU, and the checks of the received samples against the simulator's truth.
// Included only where the driver is built (VILMA_HAVE_DRIVER_USB_IMU).
#pragma once

#include <catch2/catch.hpp>

#include <fcntl.h>
#include <poll.h>
#include <signal.h>
#include <pty.h>
#include <time.h>
#include <unistd.h>

#include <algorithm>
#include <atomic>
#include <cmath>
#include <fstream>
#include <lcm/lcm-cpp.hpp>
#include <map>
#include <mutex>
#include <thread>
#include <vilma/imu_t.hpp>
#include <vilma/status_t.hpp>

#include "drivers/usb_imu_sim_device.h"
#include "integration/process_util.h"

namespace vilma::usb_imu::pty_test {

const std::string kProgram = std::string(VILMA_BINARY_DIR) + "/bin/vilma-usb-imu";
constexpr int64_t kMs = 1000000;

inline int64_t RealtimeNs() {
  timespec t{};
  clock_gettime(CLOCK_REALTIME, &t);
  return static_cast<int64_t>(t.tv_sec) * 1000000000 + t.tv_nsec;
}

inline int64_t SteadyNs() {
  return std::chrono::duration_cast<std::chrono::nanoseconds>(
             std::chrono::steady_clock::now().time_since_epoch())
      .count();
}

// The sample index a received imu_t carries (SimReadings: accel x = 0.001 g * (k % 4000)).
inline int64_t IndexOf(const imu_t& m) {
  return std::llround(m.linear_acceleration[0] / kStandardGravity / 0.001);
}

// Every value of sample k as SimReadings made it (float precision; gyro z may carry the
// simulator's 1e-6 rad/s nudges).
inline bool ValuesMatch(const imu_t& m, int64_t k) {
  double accel[3];
  double gyro[3];
  test::SimReadings(k, accel, gyro);
  for (int i = 0; i < 3; ++i) {
    if (std::abs(m.linear_acceleration[i] - accel[i] * kStandardGravity) > 1e-5) return false;
    if (std::abs(m.angular_velocity[i] - gyro[i]) > (i == 2 ? 1e-4 : 1e-6)) return false;
  }
  return true;
}

struct Faults {
  int garbage_every = 0;    // 13 bytes of noise before every Nth packet
  int corrupt_every = 0;    // flip a payload byte of every Nth packet
  int truncate_every = 0;   // send only the first half of every Nth packet
};

// A simulated IMU on a pty's master; the driver opens `link` (a symlink to the slave, like a
// /dev/serial/by-id name). Replug() closes the pty and makes a new one behind the link.
class PtyImu {
 public:
  PtyImu(std::string link, const test::SimMipDeviceOptions& options, double drift_ppm,
         Faults faults)
      : link_(std::move(link)), options_(options), drift_(drift_ppm * 1e-6), faults_(faults) {
    REQUIRE(OpenPty());
    thread_ = std::thread([this] { Run(); });
  }
  ~PtyImu() {
    stop_ = true;
    thread_.join();
    if (master_ >= 0) ::close(master_);
  }
  // Stream for `seconds` after the driver configured the device, then fall silent.
  void set_stream_seconds(double seconds) { stream_seconds_ = seconds; }
  // The device vanishes for `gap_s` and comes back as a new pty (its clock restarted).
  void ReplugAfter(double stream_s, double gap_s) {
    replug_after_s_ = stream_s;
    replug_gap_s_ = gap_s;
  }
  // The device vanishes now, for `gap_s` (from the test's thread while the simulator runs).
  void UnplugNow(double gap_s) {
    replug_gap_s_ = gap_s;
    unplug_now_ = true;
  }

  std::mutex mutex;
  std::map<int64_t, int64_t> truth_ns;  // k -> CLOCK_REALTIME of the sample's event
  int64_t emitted = 0;
  int64_t corrupted = 0;
  int64_t truncated = 0;
  int64_t garbage_bytes = 0;
  std::vector<int64_t> lost;  // indices of corrupted and truncated samples
  int replugs = 0;
  bool replug_failed = false;

 private:
  // A new pty behind the link and a freshly powered device (no Catch macros: also runs on the
  // simulator's thread).
  bool OpenPty() {
    int slave = -1;
    char name[256] = {};
    if (::openpty(&master_, &slave, name, nullptr, nullptr) != 0) return false;
    ::close(slave);  // the driver opens it by the link
    // Not inherited by the driver (forked from this process): else it keeps the pty alive.
    ::fcntl(master_, F_SETFD, FD_CLOEXEC);
    const std::string tmp = link_ + ".new";
    ::unlink(tmp.c_str());
    if (::symlink(name, tmp.c_str()) != 0 || ::rename(tmp.c_str(), link_.c_str()) != 0) {
      return false;
    }
    device_ = std::make_unique<test::SimMipDevice>(options_);
    stream_start_ns_ = 0;
    j_ = 0;
    return true;
  }

  void Write(const std::vector<uint8_t>& bytes) {
    std::size_t done = 0;
    while (done < bytes.size() && !stop_) {
      const ssize_t n = ::write(master_, bytes.data() + done, bytes.size() - done);
      if (n > 0) {
        done += static_cast<std::size_t>(n);
      } else {
        std::this_thread::sleep_for(std::chrono::milliseconds(1));
      }
    }
  }

  void Run() {
    uint8_t buffer[512];
    const int64_t rt0 = RealtimeNs();
    const int64_t st0 = SteadyNs();
    while (!stop_) {
      pollfd p{master_, POLLIN, 0};
      if (::poll(&p, 1, 1) > 0 && (p.revents & POLLIN)) {
        const ssize_t n = ::read(master_, buffer, sizeof(buffer));  // EIO until the slave opens
        if (n > 0) Write(device_->OnHostBytes(buffer, static_cast<std::size_t>(n)));
      }
      if (!device_->streaming()) continue;
      const int64_t now = SteadyNs();
      if (stream_start_ns_ == 0) stream_start_ns_ = now;
      const double streamed_s = static_cast<double>(now - stream_start_ns_) * 1e-9;
      if ((replug_after_s_ > 0.0 && streamed_s >= replug_after_s_) || unplug_now_.exchange(false)) {
        ::close(master_);
        master_ = -1;
        const int64_t back_ns = SteadyNs() + static_cast<int64_t>(replug_gap_s_ * 1e9);
        while (!stop_ && SteadyNs() < back_ns) {
          std::this_thread::sleep_for(std::chrono::milliseconds(5));
        }
        if (stop_) return;
        options_.device_start_ns += 777 * kMs;  // rebooted: another clock origin
        const bool opened = OpenPty();
        replug_after_s_ = 0.0;
        std::lock_guard<std::mutex> lock(mutex);
        ++replugs;
        replug_failed = !opened;
        if (!opened) return;
        continue;
      }
      if (stream_seconds_ > 0.0 && streamed_s >= stream_seconds_) continue;
      // Sample j of this run is due at stream start + j host periods; the device stamps it
      // with its own clock, which runs (1 + drift) fast.
      const auto period_ns = static_cast<int64_t>(1e9 / device_->rate_hz());
      while (stream_start_ns_ + j_ * period_ns <= now) {
        const int64_t event_steady = stream_start_ns_ + j_ * period_ns;
        const int64_t device_ns =
            device_->device_start_ns() +
            std::llround(static_cast<double>(j_ * period_ns) * (1.0 + drift_));
        std::vector<uint8_t> bytes = device_->DataPacket(k_, device_ns);
        bool faulted = false;
        std::lock_guard<std::mutex> lock(mutex);
        if (faults_.garbage_every > 0 && k_ % faults_.garbage_every == 5) {
          std::vector<uint8_t> noise(13);
          for (std::size_t i = 0; i < noise.size(); ++i) noise[i] = static_cast<uint8_t>(0x10 + 7 * i);
          Write(noise);
          garbage_bytes += 13;
        }
        if (faults_.corrupt_every > 0 && k_ % faults_.corrupt_every == 7) {
          bytes[12] ^= 0x20;
          ++corrupted;
          faulted = true;
        } else if (faults_.truncate_every > 0 && k_ % faults_.truncate_every == 11) {
          bytes.resize(bytes.size() / 2);
          ++truncated;
          faulted = true;
        }
        Write(bytes);
        if (faulted) lost.push_back(k_);
        truth_ns[k_] = rt0 + (event_steady - st0);
        ++emitted;
        ++k_;
        ++j_;
      }
    }
  }

  std::string link_;
  test::SimMipDeviceOptions options_;
  double drift_;
  Faults faults_;
  int master_ = -1;
  std::unique_ptr<test::SimMipDevice> device_;
  std::atomic<bool> stop_{false};
  std::thread thread_;
  double stream_seconds_ = 0.0;
  double replug_after_s_ = 0.0;
  std::atomic<double> replug_gap_s_{0.0};
  std::atomic<bool> unplug_now_{false};
  int64_t stream_start_ns_ = 0;
  int64_t j_ = 0;  // sample of this run
  int64_t k_ = 0;  // sample overall (the values)
};

// Collects IMU and VILMA_STATUS_IMU of one LCM URL on a thread of its own (the URL asks for a
// large receive buffer: a subscriber starved for a second on a loaded machine loses nothing).
class Subscriber {
 public:
  explicit Subscriber(const std::string& url) : lcm_(url) {
    REQUIRE(lcm_.good());
    lcm_.subscribe("IMU", &Subscriber::OnImu, this);
    lcm_.subscribe("VILMA_STATUS_IMU", &Subscriber::OnStatus, this);
    thread_ = std::thread([this] {
      while (!stop_) lcm_.handleTimeout(20);
    });
  }
  ~Subscriber() { Stop(); }
  void Stop() {
    if (stop_.exchange(true)) return;
    thread_.join();
  }
  // Read while the thread runs.
  std::size_t imu_count() {
    std::lock_guard<std::mutex> lock(mutex_);
    return imus.size();
  }
  bool has_status() {
    std::lock_guard<std::mutex> lock(mutex_);
    return !statuses.empty();
  }
  status_t last_status() {
    std::lock_guard<std::mutex> lock(mutex_);
    return statuses.back();
  }
  // After Stop() (or under the lock above).
  std::vector<imu_t> imus;
  std::vector<status_t> statuses;

 private:
  void OnImu(const lcm::ReceiveBuffer*, const std::string&, const imu_t* m) {
    std::lock_guard<std::mutex> lock(mutex_);
    imus.push_back(*m);
  }
  void OnStatus(const lcm::ReceiveBuffer*, const std::string&, const status_t* m) {
    std::lock_guard<std::mutex> lock(mutex_);
    statuses.push_back(*m);
  }
  lcm::LCM lcm_;
  std::atomic<bool> stop_{false};
  std::mutex mutex_;
  std::thread thread_;
};

inline int64_t Counter(const status_t& s, const std::string& name) {
  for (int i = 0; i < s.num_counters; ++i) {
    if (s.counter_names[i] == name) return s.counter_values[i];
  }
  return -1;
}

inline double Metric(const status_t& s, const std::string& name) {
  for (int i = 0; i < s.num_metrics; ++i) {
    if (s.metric_names[i] == name) return s.metric_values[i];
  }
  return NAN;
}

inline int RunDriver(const std::string& url, std::vector<std::string> args, Subscriber* sub,
              const std::string& log, double timeout_s = 30.0) {
  std::vector<std::string> argv = {kProgram, "--lcm-url", url, "--status-period-s", "0.25"};
  argv.insert(argv.end(), args.begin(), args.end());
  vilma::test::ChildProcess child(argv, log);
  const int status = child.Wait(timeout_s);
  std::this_thread::sleep_for(std::chrono::milliseconds(200));  // the last datagrams
  sub->Stop();
  return status;
}

inline double Percentile(std::vector<double> v, double q) {
  if (v.empty()) return NAN;
  std::sort(v.begin(), v.end());
  return v[static_cast<std::size_t>(q * static_cast<double>(v.size() - 1))];
}

// Stamps strictly increasing, values right, indices increasing; returns |stamp - truth| [ms]
// of every sample 0.5 s after the first one received.
inline std::vector<double> CheckSamples(const std::vector<imu_t>& imus, PtyImu* imu) {
  std::vector<double> errors_ms;
  std::lock_guard<std::mutex> lock(imu->mutex);
  int64_t last_utime = 0;
  int64_t last_k = -1;
  int bad_values = 0;
  for (const imu_t& m : imus) {
    const int64_t k = IndexOf(m);
    if (!ValuesMatch(m, k)) ++bad_values;
    CHECK(m.utime > last_utime);
    CHECK(k > last_k);
    last_utime = m.utime;
    last_k = k;
    const auto truth = imu->truth_ns.find(k);
    REQUIRE(truth != imu->truth_ns.end());
    if (m.utime * 1000 - imus.front().utime * 1000 > 500 * kMs) {
      errors_ms.push_back(std::abs(static_cast<double>(m.utime * 1000 - truth->second)) * 1e-6);
    }
  }
  CHECK(bad_values == 0);
  return errors_ms;
}

}  // namespace vilma::usb_imu::pty_test
