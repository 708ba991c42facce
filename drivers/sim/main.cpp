// vilma-sim: synthetic visual-inertial datasets (ASL/EuRoC layout) from a textured world.
#include <cstdlib>
#include <exception>
#include <iostream>
#include <string>
#include <vector>

#include "vilma/core/arg_cursor.h"
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
  --imu-draw N         another realization of the IMU noise and biases with the same world,
                       path and images (default 0: the session's own; N >= 1: the IMU's
                       random stream DeriveSeed(DeriveSeed(seed, 2000 + session), N)); every
                       world's session-0 set of one seed shares draw 0 (docs/simulator.md)
  --images-from DIR    do not render: link DIR/mav0/cam0 (cam1) into --out, where DIR is a
                       rendering with the same world, seed, session, seconds, stereo (and
                       revisit, time offset, blur, pixel noise) per its sim.yaml, else exit 1
                       naming the file and field; writes the IMU (e.g. of --imu-draw),
                       ground truth, rig.yaml and sim.yaml in a second or two
  --live               publish on LCM in real time instead of writing files: GRAY8
                       vilma.image_t on CAM0 (CAM1), vilma.imu_t on IMU
  --lcm-url URL        LCM provider (default $LCM_DEFAULT_URL or udpm://239.255.76.67:7667?ttl=0)
  --channel-suffix S   appended to the channel names (e.g. _SIM)
  --rate R             playback speed factor for --live (default 1 = real time)
  --help               this text
)";
}

}  // namespace

int main(int argc, char** argv) {
  vilma::sim::SimOptions options;
  std::string out_dir;
  std::string world;
  std::string images_from;
  bool live = false;
  std::string lcm_url, channel_suffix;
  double rate = 1.0;
  const std::vector<std::string> args(argv + 1, argv + argc);
  try {
    for (vilma::ArgCursor arg(args); arg.Next();) {
      const std::string& name = arg.name();
      if (name == "--help" || name == "-h") {
        PrintHelp();
        return 0;
      } else if (name == "--out") {
        out_dir = arg.Value();
      } else if (name == "--session") {
        options.session = arg.IntValue(0);
      } else if (name == "--revisit") {
        options.revisit_seconds = arg.DoubleValue();
      } else if (name == "--seconds") {
        options.seconds = arg.DoubleValue();
      } else if (name == "--seed") {
        options.seed = static_cast<uint64_t>(arg.Int64Value(0));
      } else if (name == "--stereo") {
        options.stereo = arg.Flag();
      } else if (name == "--time-offset-ns") {
        options.camera_time_offset_ns = arg.Int64Value();
      } else if (name == "--motion-blur") {
        options.motion_blur_samples = arg.IntValue();
      } else if (name == "--exposure") {
        options.exposure_s = arg.DoubleValue();
      } else if (name == "--pixel-noise") {
        options.noise_sigma = arg.DoubleValue();
      } else if (name == "--no-imu-noise") {
        arg.Flag();
        options.imu = vilma::sim::ImuSimOptions::NoiseFree();
      } else if (name == "--imu-draw") {
        options.imu_draw = arg.IntValue(0);
      } else if (name == "--images-from") {
        images_from = arg.Value();
      } else if (name == "--live") {
        live = arg.Flag();
      } else if (name == "--lcm-url") {
        lcm_url = arg.Value();
      } else if (name == "--channel-suffix") {
        channel_suffix = arg.Value();
      } else if (name == "--rate") {
        rate = arg.DoubleValue();
      } else if (arg.is_option()) {
        throw vilma::UsageError("unknown option '" + arg.word() + "'");
      } else if (world.empty()) {
        world = name;
      } else {
        throw vilma::UsageError("unexpected argument '" + arg.word() + "'");
      }
    }
  } catch (const vilma::UsageError& e) {
    std::cerr << "vilma-sim: " << e.what() << " (see --help)\n";
    return 2;
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
  if (live && !images_from.empty()) {
    std::cerr << "vilma-sim: --images-from writes a folder; it does not combine with --live\n";
    return 2;
  }
  if (!live && (!lcm_url.empty() || !channel_suffix.empty())) {
    std::cerr << "vilma-sim: --lcm-url and --channel-suffix need --live\n";
    return 2;
  }
  options.world = world;
  try {
    std::cerr << "vilma-sim: world " << world << ", session " << options.session << ", seed "
              << options.seed << ", " << options.seconds << " s" << (options.stereo ? ", stereo" : "")
              << (options.imu_draw != 0 ? ", IMU draw " + std::to_string(options.imu_draw) : "")
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
    if (!images_from.empty()) {
      const vilma::sim::DatasetSummary s = sim.WriteDatasetWithImagesFrom(out_dir, images_from);
      std::cerr << "wrote " << s.num_imu_samples << " IMU samples in " << s.total_seconds
                << " s; images of " << s.num_frames << " frames linked from " << images_from
                << "\n";
      return 0;
    }
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
