// vilma-sim: synthetic visual-inertial datasets (ASL/EuRoC layout) from a textured world.
#include <cstdlib>
#include <exception>
#include <iostream>
#include <string>

#include "vilma/core/error.h"
#include "vilma/sim/simulator.h"
#ifdef VILMA_SIM_LIVE
#include "live.h"
#endif

namespace {

void PrintHelp() {
  std::cout <<
      R"(Usage: vilma-sim PRESET|WORLD.yaml --out DIR [options]
       vilma-sim PRESET|WORLD.yaml --live [--lcm-url URL] [--channel-suffix S] [--rate R] [options]

Renders a synthetic visual-inertial sequence (EuRoC VI-sensor rig: 752x480 cameras at 20 Hz,
ADIS16448-like IMU at 200 Hz) and writes it as an ASL/EuRoC dataset folder with ground truth:
DIR/mav0/{cam0,cam1,imu0,state_groundtruth_estimate0}, EuRoC sensor.yaml files, DIR/rig.yaml
(vilma sensor rig) and DIR/sim.yaml (the parameters used).

Presets: room (8x8x3 m Vicon-room-like), room-fast (same room, aggressive motion),
         hall (30x20x10 m machine-hall-like), street (outdoor block, ~156 m loop).

Options:
  --out DIR            output folder (created; existing files are overwritten)
  --session K          session number (default 0): same world and frame, other path/lighting
  --seconds T          sequence length in seconds (default 60), with a 3 s static start
  --seed N             seed of world, trajectories and noise (default 1)
  --revisit S0         sessions > 0: follow session 0's path (as made with --seconds S0)
                       with smooth offsets of ~0.6 m and ~15 deg, forwards or backwards,
                       instead of an independent path (re-localization datasets)
  --stereo             also render cam1 (EuRoC cam1, ~11 cm baseline)
  --time-offset-ns D   camera time shift t_imu = t_cam + D (default 0)
  --motion-blur N      average N renders over the exposure (default 1: off)
  --exposure S         exposure time for motion blur in seconds (default 0.004)
  --pixel-noise S      Gaussian pixel noise sigma in grey levels (default 2)
  --no-imu-noise       exact IMU (no white noise, no bias random walk, zero biases)
  --live               publish on LCM in real time instead of writing files: GRAY8
                       vilma.image_t on CAM0 (CAM1), vilma.imu_t on IMU
  --lcm-url URL        LCM provider (default $LCM_DEFAULT_URL or udpm://239.255.76.67:7667?ttl=0)
  --channel-suffix S   appended to the channel names (e.g. _SIM)
  --rate R             playback speed factor for --live (default 1 = real time)
  --help               this text
)";
}

bool ParseInt64(const std::string& s, long long* out) {
  char* end = nullptr;
  *out = std::strtoll(s.c_str(), &end, 10);
  return !s.empty() && *end == '\0';
}
bool ParseDouble(const std::string& s, double* out) {
  char* end = nullptr;
  *out = std::strtod(s.c_str(), &end);
  return !s.empty() && *end == '\0';
}

}  // namespace

int main(int argc, char** argv) {
  vilma::sim::SimOptions options;
  std::string out_dir;
  std::string world;
  bool live = false;
  std::string lcm_url, channel_suffix;
  double rate = 1.0;
  for (int i = 1; i < argc; ++i) {
    const std::string arg = argv[i];
    auto value = [&](const char* name) -> std::string {
      if (i + 1 >= argc) {
        std::cerr << "vilma-sim: " << name << " needs a value (see --help)\n";
        std::exit(2);
      }
      return argv[++i];
    };
    auto bad = [&](const std::string& name, const std::string& v, const char* what) {
      std::cerr << "vilma-sim: " << name << ": expected " << what << ", got '" << v << "'\n";
      std::exit(2);
    };
    long long n = 0;
    double d = 0.0;
    if (arg == "--help" || arg == "-h") {
      PrintHelp();
      return 0;
    } else if (arg == "--out") {
      out_dir = value("--out");
    } else if (arg == "--session") {
      const std::string v = value("--session");
      if (!ParseInt64(v, &n) || n < 0) bad(arg, v, "a session number >= 0");
      options.session = static_cast<int>(n);
    } else if (arg == "--revisit") {
      const std::string v = value("--revisit");
      if (!ParseDouble(v, &d)) bad(arg, v, "seconds of session 0");
      options.revisit_seconds = d;
    } else if (arg == "--seconds") {
      const std::string v = value("--seconds");
      if (!ParseDouble(v, &d)) bad(arg, v, "seconds");
      options.seconds = d;
    } else if (arg == "--seed") {
      const std::string v = value("--seed");
      if (!ParseInt64(v, &n) || n < 0) bad(arg, v, "a non-negative integer");
      options.seed = static_cast<uint64_t>(n);
    } else if (arg == "--stereo") {
      options.stereo = true;
    } else if (arg == "--time-offset-ns") {
      const std::string v = value("--time-offset-ns");
      if (!ParseInt64(v, &n)) bad(arg, v, "nanoseconds");
      options.camera_time_offset_ns = n;
    } else if (arg == "--motion-blur") {
      const std::string v = value("--motion-blur");
      if (!ParseInt64(v, &n)) bad(arg, v, "a sample count");
      options.motion_blur_samples = static_cast<int>(n);
    } else if (arg == "--exposure") {
      const std::string v = value("--exposure");
      if (!ParseDouble(v, &d)) bad(arg, v, "seconds");
      options.exposure_s = d;
    } else if (arg == "--pixel-noise") {
      const std::string v = value("--pixel-noise");
      if (!ParseDouble(v, &d)) bad(arg, v, "grey levels");
      options.noise_sigma = d;
    } else if (arg == "--no-imu-noise") {
      options.imu = vilma::sim::ImuSimOptions::NoiseFree();
    } else if (arg == "--live") {
      live = true;
    } else if (arg == "--lcm-url") {
      lcm_url = value("--lcm-url");
    } else if (arg == "--channel-suffix") {
      channel_suffix = value("--channel-suffix");
    } else if (arg == "--rate") {
      const std::string v = value("--rate");
      if (!ParseDouble(v, &d)) bad(arg, v, "a speed factor");
      rate = d;
    } else if (!arg.empty() && arg[0] == '-') {
      std::cerr << "vilma-sim: unknown option '" << arg << "' (see --help)\n";
      return 2;
    } else if (world.empty()) {
      world = arg;
    } else {
      std::cerr << "vilma-sim: unexpected argument '" << arg << "' (see --help)\n";
      return 2;
    }
  }
  if (world.empty() || (out_dir.empty() && !live)) {
    std::cerr << "vilma-sim: need a PRESET or WORLD.yaml and --out DIR or --live (see --help)\n";
    return 2;
  }
#ifndef VILMA_SIM_LIVE
  if (live) {
    std::cerr << "vilma-sim: --live is not available in this build (no vilma_lcm_io)\n";
    return 2;
  }
#endif
  if (!live && (!lcm_url.empty() || !channel_suffix.empty())) {
    std::cerr << "vilma-sim: --lcm-url and --channel-suffix need --live\n";
    return 2;
  }
  options.world = world;
  try {
    std::cerr << "vilma-sim: world " << world << ", session " << options.session << ", seed "
              << options.seed << ", " << options.seconds << " s" << (options.stereo ? ", stereo" : "")
              << " -> " << (live ? "LCM" : out_dir) << "\n";
    vilma::sim::Simulator sim(options);
    const auto& r = sim.trajectory_report();
    std::cerr << "trajectory: mean speed " << r.mean_speed << " m/s, max speed " << r.max_speed
              << " m/s, max rate " << r.max_angular_rate << " rad/s, min view depth "
              << r.min_view_depth << " m, clearance violations " << r.collision_samples << "\n";
#ifdef VILMA_SIM_LIVE
    if (live) {
      vilma::sim::LiveOptions lo;
      lo.lcm_url = lcm_url;
      lo.channel_suffix = channel_suffix;
      lo.rate = rate;
      return vilma::sim::PublishLive(&sim, lo, std::cerr);
    }
#endif
    const vilma::sim::DatasetSummary s = sim.WriteDataset(out_dir, &std::cerr);
    std::cerr << "wrote " << s.num_images << " images, " << s.num_imu_samples
              << " IMU samples in " << s.total_seconds << " s; rendering " << s.frames_per_second()
              << " frames/s (one core)\n";
  } catch (const vilma::InputError& e) {
    std::cerr << "vilma-sim: " << e.what() << "\n";
    return 1;
  } catch (const std::exception& e) {
    std::cerr << "vilma-sim: error: " << e.what() << "\n";
    return 1;
  }
  return 0;
}
