#include "vilma/console/vio_command.h"

#include <algorithm>
#include <chrono>
#include <cmath>
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
#include "vilma/eval/trajectory.h"
#include "vilma/estimator/given_state_io.h"
#include "vilma/estimator/vio_pipeline.h"
#include "vilma/mapping/map_builder.h"
#include "vilma/mapstore/id.h"
#include "vilma/mapstore/consistency.h"
#include "vilma/mapstore/map_io.h"

namespace vilma::console {
namespace {

}  // namespace

void PrintVioHelp(std::ostream& out) {
  out << "usage: vilma vio DATASET --out TRAJ.txt [--config FILE | --profile NAME] [--rig RIG.yaml]\n"
         "                 [--camera INDEX] [--log-timing FILE] [--log-state FILE] [--print-config]\n"
         "                 [--save-map DIR [--map-config FILE]] [--initial-state FILE]\n"
         "                 [--stereo [--stereo-camera INDEX]]\n"
         "\n"
         "Runs the ROVIO-style visual-inertial odometry over an ASL/EuRoC dataset folder,\n"
         "single-threaded and deterministically, and writes the IMU pose T_M_I of every frame\n"
         "as TUM text (t [s] in the IMU clock, x y z qx qy qz qw).\n"
         "\n"
         "  --out FILE          trajectory output (required)\n"
         "  --config FILE       filter options YAML (default: a built-in profile, --profile);\n"
         "                      keys the file leaves out keep the profile's values\n"
         "  --profile NAME      built-in filter options (with --config: the values of the keys\n"
         "                      the file leaves out): default (the simulator-tuned defaults =\n"
         "                      config/estimator.yaml), euroc (real EuRoC images =\n"
         "                      config/estimator_euroc.yaml), or auto (the\n"
         "                      default): euroc when the rig comes from the dataset's EuRoC\n"
         "                      sensor.yaml files (a real recording: no rig.yaml, no --rig),\n"
         "                      else default (the simulator writes rig.yaml). Printed as\n"
         "                      'options' (docs/estimator.md, \"Options for real images\")\n"
         "  --rig FILE          sensor rig YAML (default: DATASET/rig.yaml if present, else the\n"
         "                      EuRoC sensor.yaml files of DATASET)\n"
         "  --camera INDEX      camera of the rig to use (default 0): the VIO camera, in which\n"
         "                      the features are anchored\n"
         "  --stereo            also use a second camera (stereo.enabled: true): photometric\n"
         "                      updates in both images and stereo-matched initial depths; the\n"
         "                      frames are the synchronized pairs (docs/estimator.md, \"Stereo\")\n"
         "  --stereo-camera INDEX  the second camera (stereo.camera; default: the config's, 1)\n"
         "  --log-timing FILE   per-frame CSV: t_ns,ms,features,updated,rejected,added\n"
         "  --log-state FILE    per-frame CSV of the state behind the pose: velocity v_M,\n"
         "                      biases b_g, b_a, their standard deviations and the yaw's\n"
         "                      (to tell a yaw / gyro-bias drift from a velocity drift)\n"
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
    } else if (a == "--profile") {
      o.profile = next();
    } else if (a == "--rig") {
      o.rig_path = next();
    } else if (a == "--log-timing") {
      o.timing_path = next();
    } else if (a == "--log-state") {
      o.state_path = next();
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
    } else if (a == "--stereo") {
      o.stereo = arg.Flag();
    } else if (a == "--stereo-camera") {
      o.stereo_camera = arg.IntValue(0);
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
    if (o.stereo_camera >= 0 && !o.stereo) throw UsageError("--stereo-camera: only with --stereo");
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
    SensorRig rig;
    std::string rig_source;
    bool rig_from_sensor_yaml = false;
    if (!o.rig_path.empty()) {
      rig = LoadSensorRig(o.rig_path);
      rig_source = o.rig_path;
    } else if (std::filesystem::exists(std::filesystem::path(o.dataset) / "rig.yaml")) {
      rig_source = (std::filesystem::path(o.dataset) / "rig.yaml").string();
      rig = LoadSensorRig(rig_source);
    } else {
      rig = ImportEurocRig(o.dataset);
      rig_source = o.dataset + " (EuRoC sensor.yaml)";
      rig_from_sensor_yaml = true;
    }
    // Filter options: a built-in profile, and over it --config's keys (an absent key keeps
    // the profile's value, so a partial file on real data changes only what it names). "auto"
    // takes the real-image profile for a dataset described only by its EuRoC sensor.yaml files
    // (real recordings; the simulator writes rig.yaml): the defaults are tuned on our renders
    // and miss issue 17's targets on real EuRoC images (docs/estimator.md, "Options for real
    // images").
    const bool automatic = o.profile == "auto";
    const std::string profile = automatic ? (rig_from_sensor_yaml ? "euroc" : "default") : o.profile;
    estimator::FilterOptions options = estimator::FilterOptionsProfile(profile);
    std::string options_source =
        "built-in profile " + profile +
        (automatic ? rig_from_sensor_yaml ? " (auto: rig from EuRoC sensor.yaml, a real recording)"
                                          : " (auto: vilma rig)"
                   : std::string());
    if (!o.config_path.empty()) {
      options = estimator::LoadFilterOptions(o.config_path, options);
      options_source = o.config_path + " over the " + options_source;
    }
    if (o.stereo) options.stereo.enabled = true;
    if (o.stereo_camera >= 0) options.stereo.camera = o.stereo_camera;
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
    if (options.stereo.enabled && options.stereo.camera == o.camera) {
      throw InputError(FormatInputError("--stereo-camera", std::to_string(options.stereo.camera),
                                        "a camera other than --camera"));
    }
    if (o.print_config) {
      out << "# filter options: " << options_source << "\n" << estimator::FilterOptionsToYaml(options);
    }
    if (o.print_config && !o.save_map_dir.empty()) {
      out << "# map builder\n" << mapping::MapBuilderOptionsToYaml(map_options);
    }
    estimator::VioPipelineOptions pipeline_options;
    pipeline_options.vio_camera = o.camera;
    pipeline_options.filter = options;
    // Synchronized like vilma-estimatord (core's SensorSynchronizer, its default options): the
    // VIO camera, the stereo camera, and with --save-map every camera of the dataset.
    std::vector<int> cameras{o.camera};
    if (options.stereo.enabled) cameras.push_back(options.stereo.camera);
    if (!o.save_map_dir.empty()) {
      for (std::size_t c = 0; c < rig.cameras.size() && c < dataset.cameras().size(); ++c) {
        cameras.push_back(static_cast<int>(c));
      }
    }
    std::sort(cameras.begin(), cameras.end());
    cameras.erase(std::unique(cameras.begin(), cameras.end()), cameras.end());
    for (int c : cameras) {
      if (c >= static_cast<int>(dataset.cameras().size())) {
        throw InputError(FormatInputError(o.dataset, "cam" + std::to_string(c),
                                          "a camera folder (stereo.camera)"));
      }
    }
    pipeline_options.cameras = cameras;
    estimator::VioPipeline pipeline(rig, pipeline_options);
    const auto& frames = dataset.cameras()[static_cast<std::size_t>(o.camera)].frames;
    const auto& imu = dataset.imu();
    const int64_t offset_ns = rig.cameras[static_cast<std::size_t>(o.camera)].time_offset_ns;
    std::string start_note = "from the sensors";
    if (!o.initial_state_path.empty() && !frames.empty()) {
      estimator::GivenStateSource source;
      const estimator::GivenState given = estimator::LoadGivenState(
          o.initial_state_path, frames.front().t_ns + offset_ns, &source);
      pipeline.stage().StartFrom(given);
      start_note = "given: " + o.initial_state_path + " (velocity " +
                   (source.velocity_from_file ? "and biases from the file" : "from differences") +
                   (source.biases_from_file ? "" : ", biases 0") + ")";
    }

    // Map building (--save-map): one builder, fed the IMU samples the filter got and the
    // filter's state at every frame with a pose, with the images of the synchronized frame
    // (a camera missing from the frame gets no features in that vertex).
    std::unique_ptr<mapping::MapBuilder> builder;
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
    }
    double map_ms = 0.0;

    // Arrival order as vilma-replay writes a log (ArrivalOrder, asl_dataset.h).
    const std::vector<AslEvent> events = ArrivalOrder(dataset, cameras);

    Trajectory trajectory;
    std::vector<double> frame_ms;
    frame_ms.reserve(frames.size());
    std::ostringstream timing;
    timing << "t_ns,ms,features,updated,rejected,added\n";
    std::ostringstream state_log;
    state_log << std::setprecision(9)
              << "t_ns,vx,vy,vz,bgx,bgy,bgz,bax,bay,baz,s_bgx,s_bgy,s_bgz,s_bax,s_bay,s_baz,"
                 "s_yaw\n";
    int resets = 0;
    estimator::VioFrameOutput r;
    auto consume = [&](estimator::VioFrameOutput& output) {
      if (builder) {
        for (const ImuSample& s : output.imu) builder->AddImu(s);
      }
      const estimator::FrameResult& f = output.filter;
      if (f.reset) {
        ++resets;
        err << "vilma vio: reset at t = " << f.t_ns << " ns: " << f.reset_reason << "\n";
      }
      if (!output.pose.tracking()) return;
      const estimator::VioPose& pose = output.pose;
      if (builder) {
        mapping::FrameState state;
        state.t_ns = pose.t_ns;
        state.T_M_I = pose.T_M_I;
        if (!builder->WantsFrame(pose.t_ns)) {
          builder->AddFrame(state, {});  // counted as skipped by the vertex rate; no images
        } else {
          const auto tm = std::chrono::steady_clock::now();
          state.v_M = pose.v_M;
          state.gyro_bias = pose.gyro_bias;
          state.accel_bias = pose.accel_bias;
          builder->AddFrame(state, output.images);
          map_ms += std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - tm)
                        .count();
        }
      }
      frame_ms.push_back(output.filter_ms);
      timing << pose.t_ns << "," << output.filter_ms << "," << f.num_features << ","
             << f.num_updated << "," << f.num_rejected << "," << f.num_added << "\n";
      if (!o.state_path.empty()) {
        // The bias sigmas come from the filter as it is now: NextOutput hands out each frame
        // right after the filter processed it, so they are this frame's.
        const Eigen::VectorXd d = pipeline.stage().filter().covariance().diagonal();
        state_log << pose.t_ns;
        for (int i = 0; i < 3; ++i) state_log << "," << pose.v_M[i];
        for (int i = 0; i < 3; ++i) state_log << "," << pose.gyro_bias[i];
        for (int i = 0; i < 3; ++i) state_log << "," << pose.accel_bias[i];
        for (int i = 0; i < 6; ++i) {
          state_log << "," << std::sqrt(std::max(0.0, d[estimator::kIdxBg + i]));
        }
        // Rotation about M's z (the pose covariance's rotation is global).
        state_log << "," << std::sqrt(std::max(0.0, pose.covariance(5, 5))) << "\n";
      }
      if (trajectory.empty() || pose.t_ns > trajectory.t_ns.back()) {
        trajectory.Add(pose.t_ns, pose.T_M_I);
      }
    };
    const auto wall_start = std::chrono::steady_clock::now();
    for (const AslEvent& e : events) {
      if (e.stream < 0) {
        pipeline.AddImu(imu[e.index]);
      } else {
        const CameraFrame& frame =
            dataset.cameras()[static_cast<std::size_t>(e.stream)].frames[e.index];
        pipeline.AddImage(e.stream, frame.t_ns, AslDataset::LoadImage(frame.image_path));
      }
      while (pipeline.NextOutput(&r)) consume(r);
    }
    const double wall_s =
        std::chrono::duration<double>(std::chrono::steady_clock::now() - wall_start).count();
    if (trajectory.empty()) {
      throw InputError(FormatInputError(o.dataset, "", "enough IMU data to initialize"));
    }
    WriteTrajectoryFile(o.out_path, trajectory, TrajectoryFormat::kTum);
    if (!o.timing_path.empty()) WriteFileAtomically(o.timing_path, timing.str());
    if (!o.state_path.empty()) WriteFileAtomically(o.state_path, state_log.str());
    const double duration_s =
        frames.size() > 1 ? static_cast<double>(frames.back().t_ns - frames.front().t_ns) * 1e-9
                          : 0.0;
    const estimator::VioFilter& filter = pipeline.stage().filter();
    const estimator::FilterStats& s = filter.stats();
    const SensorSyncCounters& sc = pipeline.sync_counters();
    out << std::fixed << std::setprecision(2) << "vilma vio: " << o.dataset << "\n"
        << "  rig              " << rig_source << "\n"
        << "  options          " << options_source << "\n"
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
        << "  resets           " << resets << "\n"
        << "  sync             " << sc.frames_released << " frames released ("
        << sc.frames_incomplete << " incomplete), dropped: " << sc.frames_dropped_no_imu
        << " no IMU, " << sc.frames_dropped_overflow << " overflow; " << sc.images_duplicate
        << " duplicate, " << sc.images_out_of_order << " out-of-order, " << sc.images_late
        << " late images\n";
    if (options.features.median_depth_init) {
      out << "  median depth     " << s.median_depth_inits
          << " new features started at the tracked features' median inverse depth (before "
             "their own stereo match)\n";
    }
    if (options.stereo.enabled) {
      out << "  stereo           camera " << options.stereo.camera << ": " << s.stereo_updates
          << " updates accepted, " << s.stereo_rejections << " not; " << s.stereo_matches
          << " initial depths matched, " << s.stereo_match_failures << " not; "
          << pipeline.stage().counters().frames_without_stereo << " frames without it; "
          << s.stereo_disagreement_removals << " features removed (C1 and C2 disagreeing)\n";
      // Why initial depths were not matched (estimator/stereo.h StereoMatchFailure).
      const auto& why = s.stereo_match_failure_reasons;
      auto reason = [&why](estimator::StereoMatchFailure f) {
        return why[static_cast<std::size_t>(f)];
      };
      out << "  stereo unmatched " << reason(estimator::StereoMatchFailure::kNoSample)
          << " no sample, " << reason(estimator::StereoMatchFailure::kNotConverged)
          << " not converged, " << reason(estimator::StereoMatchFailure::kResidual)
          << " residual, " << reason(estimator::StereoMatchFailure::kNoDepth) << " no depth >= 0, "
          << reason(estimator::StereoMatchFailure::kEpipolar) << " off the epipolar curve, "
          << reason(estimator::StereoMatchFailure::kAmbiguous) << " ambiguous\n";
      // Features that started without a stereo depth: how many the second camera's update
      // caught later, and what the session-38 options converted (docs/estimator.md).
      out << "  stereo later     " << s.unmatched_taking_c2
          << " features without an initial depth took a C2 update later (after "
          << (s.unmatched_taking_c2 > 0
                  ? static_cast<double>(s.unmatched_c2_updates_before) / s.unmatched_taking_c2
                  : 0.0)
          << " updates on average); " << s.stereo_candidates_skipped
          << " candidates skipped unmatched; deferred matches " << s.deferred_matches
          << " applied, " << s.deferred_match_gated << " gated out, " << s.deferred_match_failures
          << " tries unmatched\n";
      if (options.stereo.probation_frames > 0) {
        out << "  probation        " << s.probation_passes
            << " stereo depths confirmed by the VIO camera's flow, " << s.probation_removals
            << " features removed\n";
      }
    }
    if (options.features.refresh_patch_every > 0) {
      out << "  patch refresh    " << s.patch_refreshes << " templates re-extracted, "
          << s.patch_refresh_rejections << " kept (outside the image or score too low)\n";
    }
    if (builder) {
      // The rest of the IMU stream (still in the synchronizer) completes the last edge.
      for (const ImuSample& sample : imu) {
        if (sample.t_ns > pipeline.last_forwarded_imu_ns()) builder->AddImu(sample);
      }
      const mapstore::VIMap& map = builder->Finish();
      const mapstore::MapSaveSummary saved = mapstore::SaveMap(map, o.save_map_dir);
      const mapstore::ConsistencyReport report = mapstore::CheckMapConsistency(map);
      out << "vilma vio: map " << o.save_map_dir << " (mission " << builder->mission_id().Hex()
          << ")\n"
          << builder->stats().FullReport("  ") << "  builder wall     " << map_ms
          << " ms in AddFrame incl. loading the other cameras' images\n"
          << "  saved            " << saved.files_written << " files, " << saved.bytes_written
          << " bytes\n"
          << "  consistency      " << report.BriefReport() << "\n";
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
