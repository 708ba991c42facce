#include "vilma/eval/localization/ground_truth_map.h"

#include <algorithm>
#include <chrono>
#include <iomanip>
#include <sstream>

#include "vilma/core/asl_dataset.h"
#include "vilma/core/error.h"
#include "vilma/core/rig.h"
#include "vilma/core/timing.h"
#include "vilma/mapping/locmap/localization_map_builder.h"
#include "vilma/mapping/map_builder.h"

namespace vilma::eval {

std::string GroundTruthMapOptions::Validate() const {
  if (camera < 0) return "camera: expected an index >= 0";
  if (!(seconds > 0.0)) return "seconds: expected a duration > 0 [s]";
  const std::string e = map_builder.Validate();
  if (!e.empty()) return "map_builder." + e;
  return "";
}

std::string GroundTruthMapSummary::BriefReport() const {
  std::ostringstream s;
  s << vertices << " vertices, " << map.num_landmarks() << " landmarks, "
    << map.num_descriptors() << " descriptors";
  return s.str();
}

std::string GroundTruthMapSummary::FullReport() const {
  std::ostringstream s;
  s << BriefReport() << "\n  frames     " << frames << " given to the map builder\n"
    << std::fixed << std::setprecision(2) << "  time       " << build_s << " s\n";
  return s.str();
}

GroundTruthMapSummary BuildGroundTruthLocalizationMap(const std::string& dataset_path,
                                                      const GroundTruthMapOptions& options) {
  ThrowIfInvalid(options.Validate(), dataset_path, "ground-truth map options");
  const auto t0 = std::chrono::steady_clock::now();
  const AslDataset ds = AslDataset::Open(dataset_path);
  const SensorRig rig = LoadSensorRig(dataset_path + "/rig.yaml");
  const int camera = options.camera;
  if (camera >= static_cast<int>(rig.cameras.size()) ||
      camera >= static_cast<int>(ds.cameras().size())) {
    throw InputError(FormatInputError(dataset_path, "--camera", "a camera of the rig"));
  }
  mapping::MapBuilderOptions builder_options = options.map_builder;
  builder_options.cameras = {camera};
  mapping::MapBuilder builder(rig, builder_options, 42, "groundtruth");
  const auto& imu = ds.imu();
  const auto& gt = ds.ground_truth();
  const auto& frames = ds.cameras()[static_cast<std::size_t>(camera)].frames;
  if (frames.empty() || gt.empty()) {
    throw InputError(
        FormatInputError(dataset_path, "cameras / ground truth", "images and ground truth"));
  }
  GroundTruthMapSummary summary;
  // t_imu = t_cam + time_offset: the ground truth and the IMU are on the IMU clock.
  const int64_t offset = rig.cameras[static_cast<std::size_t>(camera)].time_offset_ns;
  const int64_t t_end = frames.front().t_ns + static_cast<int64_t>(options.seconds * 1e9);
  std::size_t next_imu = 0;
  for (const auto& frame : frames) {
    if (frame.t_ns > t_end) break;
    const int64_t t = frame.t_ns + offset;
    while (next_imu < imu.size() && imu[next_imu].t_ns <= t) builder.AddImu(imu[next_imu++]);
    if (next_imu < imu.size()) builder.AddImu(imu[next_imu++]);
    // The ground-truth state at exactly this time (the simulator writes one per frame).
    const auto it = std::lower_bound(
        gt.begin(), gt.end(), t, [](const GroundTruthState& g, int64_t tt) { return g.t_ns < tt; });
    if (it == gt.end() || it->t_ns != t) continue;
    mapping::FrameState s;
    s.t_ns = t;
    s.T_M_I = Transformation(it->q_W_I, it->p_W_I);  // M = W: the map is in the world frame
    s.v_M = it->v_W;
    s.gyro_bias = it->b_g;
    s.accel_bias = it->b_a;
    std::vector<cv::Mat> images(rig.cameras.size());
    if (builder.WantsFrame(t)) {
      images[static_cast<std::size_t>(camera)] = AslDataset::LoadImage(frame.image_path);
    } else {
      images.clear();
    }
    builder.AddFrame(s, images);
    ++summary.frames;
  }
  while (next_imu < imu.size()) builder.AddImu(imu[next_imu++]);
  builder.Finish();
  summary.map = mapping::BuildLocalizationMap(builder.map());
  summary.vertices = static_cast<int>(builder.stats().vertices);
  summary.build_s = MsSince(t0) * 1e-3;
  return summary;
}

}  // namespace vilma::eval
