#include "vilma/console/vio_command.h"

#include <algorithm>
#include <chrono>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <iomanip>
#include <memory>
#include <unordered_map>
#include <opencv2/core/utility.hpp>
#include <sstream>

#include "vilma/core/asl_dataset.h"
#include "vilma/core/error.h"
#include "vilma/core/rig.h"
#include "vilma/core/timing.h"
#include "vilma/core/trajectory.h"
#include "vilma/estimator/given_state_io.h"
#include "vilma/estimator/vio_filter.h"
#include "vilma/mapping/map_builder.h"
#include "vilma/mapstore/id.h"
#include "vilma/mapstore/consistency.h"
#include "vilma/mapstore/map_io.h"

namespace vilma::console {
namespace {

}  // namespace

void PrintVioHelp(std::ostream& out) {
  out << "usage: vilma vio DATASET --out TRAJ.txt [--config FILE] [--rig RIG.yaml]\n"
         "                 [--camera INDEX] [--log-timing FILE] [--print-config]\n"
         "                 [--save-map DIR [--map-config FILE]] [--initial-state FILE]\n"
         "\n"
         "Runs the ROVIO-style visual-inertial odometry over an ASL/EuRoC dataset folder,\n"
         "single-threaded and deterministically, and writes the IMU pose T_M_I of every frame\n"
         "as TUM text (t [s] in the IMU clock, x y z qx qy qz qw).\n"
         "\n"
         "  --out FILE          trajectory output (required)\n"
         "  --config FILE       filter options YAML (default: the built-in defaults, which are\n"
         "                      config/estimator.yaml)\n"
         "  --rig FILE          sensor rig YAML (default: DATASET/rig.yaml if present, else the\n"
         "                      EuRoC sensor.yaml files of DATASET)\n"
         "  --camera INDEX      camera of the rig to use (default 0)\n"
         "  --log-timing FILE   per-frame CSV: t_ns,ms,features,updated,rejected,added\n"
         "  --print-config      print the effective filter options (and map builder options)\n"
         "  --save-map DIR      also build a VI-map mission (vertices, IMU edges, keyframe\n"
         "                      features of every camera of the dataset, landmarks) and save it\n"
         "                      as a map folder in DIR; prints the builder statistics\n"
         "  --map-config FILE   map builder options YAML (default: the built-in defaults, which\n"
         "                      are config/map_builder.yaml)\n"
         "  --initial-state FILE  start from the state of FILE at the first frame instead of\n"
         "                      initializing from the sensors: an ASL ground truth CSV\n"
         "                      (state_groundtruth_estimate0/data.csv: pose, velocity, biases)\n"
         "                      or any TUM/EuRoC trajectory of T_W_I (velocity from position\n"
         "                      differences, biases 0); W must be gravity-aligned (z up). The\n"
         "                      output is then in W. Default: a static start (IMU at rest) or\n"
         "                      a moving start (visual-inertial alignment over the first\n"
         "                      init.dynamic.window_s of frames; see docs/estimator.md)\n";
}

VioCommandOptions ParseVioArgs(const std::vector<std::string>& args) {
  VioCommandOptions o;
  for (ArgCursor arg(args); arg.Next();) {
    const std::string& a = arg.name();
    auto next = [&arg] { return arg.Value(); };
    if (a == "--help" || a == "-h") {
      o.help = arg.Flag();
    } else if (a == "--out") {
      o.out_path = next();
    } else if (a == "--config") {
      o.config_path = next();
    } else if (a == "--rig") {
      o.rig_path = next();
    } else if (a == "--log-timing") {
      o.timing_path = next();
    } else if (a == "--save-map") {
      o.save_map_dir = next();
    } else if (a == "--map-config") {
      o.map_config_path = next();
    } else if (a == "--initial-state") {
      o.initial_state_path = next();
    } else if (a == "--print-config") {
      o.print_config = arg.Flag();
    } else if (a == "--camera") {
      o.camera = arg.IntValue(0);
    } else if (a.rfind("-", 0) == 0) {
      throw UsageError("unknown option '" + a + "'");
    } else if (o.dataset.empty()) {
      o.dataset = a;
    } else {
      throw UsageError("unexpected argument '" + a + "' (one DATASET only)");
    }
  }
  if (!o.help) {
    if (o.dataset.empty()) throw UsageError("expected a DATASET folder");
    if (o.out_path.empty()) throw UsageError("--out: required");
    if (!o.map_config_path.empty() && o.save_map_dir.empty()) {
      throw UsageError("--map-config: only with --save-map");
    }
  }
  return o;
}

int RunVioCommand(const std::vector<std::string>& args, std::ostream& out, std::ostream& err) {
  VioCommandOptions o;
  try {
    o = ParseVioArgs(args);
  } catch (const UsageError& e) {
    err << "vilma vio: " << e.what() << "\n(see 'vilma vio --help')\n";
    return kExitUsage;
  }
  if (o.help) {
    PrintVioHelp(out);
    return kExitOk;
  }
  try {
    cv::setNumThreads(1);  // one core, deterministic
    estimator::FilterOptions options;
    if (!o.config_path.empty()) options = estimator::LoadFilterOptions(o.config_path);
    SensorRig rig;
    std::string rig_source;
    if (!o.rig_path.empty()) {
      rig = LoadSensorRig(o.rig_path);
      rig_source = o.rig_path;
    } else if (std::filesystem::exists(std::filesystem::path(o.dataset) / "rig.yaml")) {
      rig_source = (std::filesystem::path(o.dataset) / "rig.yaml").string();
      rig = LoadSensorRig(rig_source);
    } else {
      rig = ImportEurocRig(o.dataset);
      rig_source = o.dataset + " (EuRoC sensor.yaml)";
    }
    const AslDataset dataset = AslDataset::Open(o.dataset);
    if (o.camera >= static_cast<int>(dataset.cameras().size())) {
      throw InputError(FormatInputError(o.dataset, "cam" + std::to_string(o.camera),
                                        "a camera folder with that index"));
    }
    if (dataset.imu().empty()) {
      throw InputError(FormatInputError(o.dataset, "imu0/data.csv", "IMU samples"));
    }
    mapping::MapBuilderOptions map_options;
    if (!o.map_config_path.empty()) map_options = mapping::LoadMapBuilderOptions(o.map_config_path);
    if (o.print_config) out << estimator::FilterOptionsToYaml(options);
    if (o.print_config && !o.save_map_dir.empty()) {
      out << "# map builder\n" << mapping::MapBuilderOptionsToYaml(map_options);
    }
    estimator::VioFilter filter(rig, o.camera, options);
    const auto& frames = dataset.cameras()[static_cast<std::size_t>(o.camera)].frames;
    const auto& imu = dataset.imu();
    const int64_t offset_ns = rig.cameras[static_cast<std::size_t>(o.camera)].time_offset_ns;
    std::string start_note = "from the sensors";
    if (!o.initial_state_path.empty() && !frames.empty()) {
      estimator::GivenStateSource source;
      const estimator::GivenState given = estimator::LoadGivenState(
          o.initial_state_path, frames.front().t_ns + offset_ns, &source);
      filter.StartFrom(given);
      start_note = "given: " + o.initial_state_path + " (velocity " +
                   (source.velocity_from_file ? "and biases from the file" : "from differences") +
                   (source.biases_from_file ? "" : ", biases 0") + ")";
    }

    // Map building (--save-map): one builder, fed the same IMU samples as the filter and the
    // filter's state at every frame with a pose. Images of the other cameras are the frames
    // with the same camera time stamp (synchronized rig); a camera without one at that time
    // gets no features in that vertex.
    std::unique_ptr<mapping::MapBuilder> builder;
    std::vector<std::unordered_map<int64_t, std::string>> camera_frames;
    if (!o.save_map_dir.empty()) {
      if (dataset.cameras().size() < rig.cameras.size() && map_options.cameras.empty()) {
        // Only the cameras the dataset has.
        for (std::size_t c = 0; c < dataset.cameras().size(); ++c) {
          map_options.cameras.push_back(static_cast<int>(c));
        }
      }
      builder = std::make_unique<mapping::MapBuilder>(
          rig, map_options,
          // From the IMU file: deterministic per dataset, distinct across sessions.
          mapstore::SeedFromFileContent(o.dataset + "/mav0/imu0/data.csv"),
          std::filesystem::path(o.dataset).lexically_normal().filename().string());
      camera_frames.resize(rig.cameras.size());
      for (std::size_t c = 0; c < rig.cameras.size() && c < dataset.cameras().size(); ++c) {
        for (const CameraFrame& f : dataset.cameras()[c].frames) {
          camera_frames[c].emplace(f.t_ns, f.image_path);
        }
      }
    }
    std::vector<cv::Mat> map_images;
    double map_ms = 0.0;

    Trajectory trajectory;
    std::vector<double> frame_ms;
    frame_ms.reserve(frames.size());
    std::ostringstream timing;
    timing << "t_ns,ms,features,updated,rejected,added\n";
    std::size_t next_imu = 0;
    int resets = 0;
    const auto wall_start = std::chrono::steady_clock::now();
    for (const CameraFrame& frame : frames) {
      const cv::Mat image = AslDataset::LoadImage(frame.image_path);
      // Feed every IMU sample up to the frame's IMU time (plus one beyond for interpolation).
      const int64_t t_imu = frame.t_ns + offset_ns;
      while (next_imu < imu.size() && imu[next_imu].t_ns <= t_imu) {
        if (builder) builder->AddImu(imu[next_imu]);
        filter.AddImu(imu[next_imu++]);
      }
      if (next_imu < imu.size()) {
        if (builder) builder->AddImu(imu[next_imu]);
        filter.AddImu(imu[next_imu++]);
      }
      const auto t0 = std::chrono::steady_clock::now();
      const estimator::FrameResult r = filter.AddImage(frame.t_ns, image);
      const double ms =
          std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0)
              .count();
      if (r.reset) {
        ++resets;
        err << "vilma vio: reset at t = " << r.t_ns << " ns: " << r.reset_reason << "\n";
      }
      if (!r.pose_valid) continue;
      if (builder && !builder->WantsFrame(r.t_ns)) {
        mapping::FrameState state;  // counted as skipped by the vertex rate; no images needed
        state.t_ns = r.t_ns;
        state.T_M_I = r.T_M_I;
        builder->AddFrame(state, {});
      } else if (builder) {
        const auto tm = std::chrono::steady_clock::now();
        map_images.assign(rig.cameras.size(), cv::Mat());
        for (std::size_t c = 0; c < rig.cameras.size(); ++c) {
          if (static_cast<int>(c) == o.camera) {
            map_images[c] = image;
            continue;
          }
          const auto it = camera_frames[c].find(frame.t_ns);
          if (it != camera_frames[c].end()) map_images[c] = AslDataset::LoadImage(it->second);
        }
        mapping::FrameState state;
        state.t_ns = r.t_ns;
        state.T_M_I = r.T_M_I;
        state.v_M = filter.state().v_W;
        state.gyro_bias = filter.state().b_g;
        state.accel_bias = filter.state().b_a;
        builder->AddFrame(state, map_images);
        map_ms += std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - tm)
                      .count();
      }
      frame_ms.push_back(ms);
      timing << r.t_ns << "," << ms << "," << r.num_features << "," << r.num_updated << ","
             << r.num_rejected << "," << r.num_added << "\n";
      if (trajectory.empty() || r.t_ns > trajectory.t_ns.back()) trajectory.Add(r.t_ns, r.T_M_I);
    }
    const double wall_s =
        std::chrono::duration<double>(std::chrono::steady_clock::now() - wall_start).count();
    if (trajectory.empty()) {
      throw InputError(FormatInputError(o.dataset, "", "enough IMU data to initialize"));
    }
    WriteTrajectoryFile(o.out_path, trajectory, TrajectoryFormat::kTum);
    if (!o.timing_path.empty()) WriteFileAtomically(o.timing_path, timing.str());
    const double duration_s =
        frames.size() > 1 ? static_cast<double>(frames.back().t_ns - frames.front().t_ns) * 1e-9
                          : 0.0;
    const estimator::FilterStats& s = filter.stats();
    out << std::fixed << std::setprecision(2) << "vilma vio: " << o.dataset << "\n"
        << "  rig              " << rig_source << "\n"
        << "  frames           " << frames.size() << " (" << trajectory.size()
        << " poses written to " << o.out_path << ")\n"
        << "  duration         " << duration_s << " s\n"
        << "  ms/frame         p50 " << Percentile(frame_ms, 0.5) << "  p99 "
        << Percentile(frame_ms, 0.99) << "  max " << Percentile(frame_ms, 1.0) << "\n"
        << "  wall time        " << wall_s << " s (images loaded from disk included)\n"
        << "  real-time factor " << (wall_s > 0 ? duration_s / wall_s : 0.0) << "x\n"
        << "  updates          " << s.updates << " accepted, " << s.rejections << " rejected\n"
        << "  IMU              " << s.imu_samples << " samples, " << s.imu_duplicates
        << " dropped (duplicate/out of order), " << s.imu_gaps << " gaps\n"
        << "  camera time      offset " << std::setprecision(3)
        << static_cast<double>(offset_ns) * 1e-6 << " ms (rig)"
        << (options.estimate_time_offset
                ? ", estimated correction " + std::to_string(filter.state().td * 1e3) + " ms"
                : std::string())
        << "\n" << std::setprecision(2)
        << "  start            " << start_note << "\n"
        << "  initializations  " << s.static_starts << " static, " << s.moving_starts
        << " moving (" << s.dynamic_starts << " by alignment, " << s.fallback_starts
        << " mean-accelerometer fallback), " << s.given_starts << " given\n"
        << "  alignment        " << s.dynamic_init.attempts << " attempts, "
        << s.dynamic_init.accepted << " accepted; rejected: " << s.dynamic_init.too_few_features
        << " few features, " << s.dynamic_init.low_parallax << " low parallax, "
        << s.dynamic_init.solver_failed << " solver, " << s.dynamic_init.large_residual
        << " residuals, " << s.dynamic_init.gravity_mismatch << " |g|, "
        << s.dynamic_init.uncertain << " uncertain\n"
        << "  resets           " << resets << "\n";
    if (builder) {
      // The rest of the IMU stream completes the last edge.
      while (next_imu < imu.size()) builder->AddImu(imu[next_imu++]);
      const mapstore::VIMap& map = builder->Finish();
      const mapstore::MapSaveSummary saved = mapstore::SaveMap(map, o.save_map_dir);
      const mapstore::ConsistencyReport report = mapstore::CheckMapConsistency(map);
      out << "vilma vio: map " << o.save_map_dir << " (mission " << builder->mission_id().Hex()
          << ")\n"
          << builder->stats().ToString("  ") << "  builder wall     " << map_ms
          << " ms in AddFrame incl. loading the other cameras' images\n"
          << "  saved            " << saved.files_written << " files, " << saved.bytes_written
          << " bytes\n"
          << "  consistency      " << report.ToString() << "\n";
      if (!report.ok()) {
        err << "vilma vio: error: the built map is not consistent\n";
        return kExitInputError;
      }
    }
  } catch (const InputError& e) {
    err << "vilma vio: error: " << e.what() << "\n";
    return kExitInputError;
  }
  return kExitOk;
}

}  // namespace vilma::console
