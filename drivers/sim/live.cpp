#include "live.h"

#include <chrono>
#include <condition_variable>
#include <deque>
#include <lcm/lcm-cpp.hpp>
#include <mutex>
#include <ostream>
#include <thread>

#include "vilma/drivers/lcm_convert.h"
#include "vilma/drivers/lcm_url.h"

namespace vilma {
namespace sim {

std::string LiveOptions::Validate() const {
  if (!(rate > 0.0 && rate <= 100.0)) return "--rate: expected a factor in (0, 100]";
  for (const char* base : {"CAM0", "CAM1", "IMU"}) {
    const std::string e = ValidateChannelName(ChannelName(base, channel_suffix));
    if (!e.empty()) return "--channel-suffix: " + e;
  }
  return "";
}

namespace {

struct RenderedFrame {
  int index = 0;
  std::vector<cv::Mat> images;  // one per camera
};

}  // namespace

int PublishLive(Simulator* sim, const LiveOptions& options, std::ostream& log) {
  const std::string error = options.Validate();
  if (!error.empty()) {
    log << "vilma-sim: " << error << "\n";
    return 2;
  }
  const std::string url = ResolveLcmUrl(options.lcm_url);
  lcm::LCM lcm(url);
  if (!lcm.good()) {
    log << "vilma-sim: cannot open LCM at '" << url << "'\n";
    return 1;
  }
  const int num_cameras = static_cast<int>(sim->rig().cameras.size());
  std::vector<std::string> cam_channels;
  for (int c = 0; c < num_cameras; ++c)
    cam_channels.push_back(ChannelName("CAM" + std::to_string(c), options.channel_suffix));
  const std::string imu_channel = ChannelName("IMU", options.channel_suffix);
  log << "vilma-sim: publishing on " << url << ": " << imu_channel;
  for (const auto& c : cam_channels) log << ", " << c;
  log << " at " << options.rate << "x real time\n";

  // Renderer thread: keeps up to 4 frames ready.
  std::mutex mutex;
  std::condition_variable cv;
  std::deque<RenderedFrame> ready;
  bool stop = false;
  std::thread renderer([&] {
    for (int i = 0; i < sim->num_frames(); ++i) {
      RenderedFrame f;
      f.index = i;
      f.images.resize(num_cameras);
      for (int c = 0; c < num_cameras; ++c) sim->RenderFrame(c, i, &f.images[c]);
      std::unique_lock<std::mutex> lock(mutex);
      cv.wait(lock, [&] { return stop || ready.size() < 4; });
      if (stop) return;
      ready.push_back(std::move(f));
      cv.notify_all();
    }
  });

  using Clock = std::chrono::steady_clock;
  const auto wall_start = Clock::now();
  const int64_t t_start = sim->start_time_ns();
  auto wait_until = [&](int64_t t_ns) {
    const double wall_s = static_cast<double>(t_ns - t_start) * 1e-9 / options.rate;
    std::this_thread::sleep_until(wall_start + std::chrono::duration_cast<Clock::duration>(
                                                   std::chrono::duration<double>(wall_s)));
  };
  const auto& imu = sim->imu().samples;
  const int32_t exposure_us = static_cast<int32_t>(sim->options().exposure_s * 1e6);
  size_t k = 0;
  int64_t imu_seq = 0;
  image_t msg;
  for (int i = 0; i < sim->num_frames(); ++i) {
    const int64_t t_frame = sim->frame_time_ns(i);
    // IMU samples up to and including the frame time come first.
    for (; k < imu.size() && imu[k].t_ns <= t_frame; ++k) {
      wait_until(imu[k].t_ns);
      const imu_t m = ImuToMessage(imu[k], imu_seq++);
      lcm.publish(imu_channel, &m);
    }
    RenderedFrame f;
    {
      std::unique_lock<std::mutex> lock(mutex);
      cv.wait(lock, [&] { return !ready.empty(); });
      f = std::move(ready.front());
      ready.pop_front();
      cv.notify_all();
    }
    wait_until(t_frame);
    for (int c = 0; c < num_cameras; ++c) {
      const std::string e = MakeImageMessage(f.images[c], image_t::GRAY8, t_frame, i, c, &msg);
      if (!e.empty()) {
        log << "vilma-sim: " << e << "\n";
        continue;
      }
      msg.exposure_us = exposure_us;
      lcm.publish(cam_channels[c], &msg);
    }
    if (i % 200 == 0) log << "frame " << i + 1 << "/" << sim->num_frames() << "\n" << std::flush;
  }
  for (; k < imu.size(); ++k) {
    wait_until(imu[k].t_ns);
    const imu_t m = ImuToMessage(imu[k], imu_seq++);
    lcm.publish(imu_channel, &m);
  }
  {
    std::lock_guard<std::mutex> lock(mutex);
    stop = true;
  }
  cv.notify_all();
  renderer.join();
  log << "vilma-sim: published " << sim->num_frames() << " frames x " << num_cameras
      << " cameras and " << imu.size() << " IMU samples\n";
  return 0;
}

}  // namespace sim
}  // namespace vilma
