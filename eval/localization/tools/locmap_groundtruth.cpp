// vilma-locmap-gt: a localization map of an ASL dataset (e.g. a vilma-sim session) built by the
// map builder driven by the dataset's GROUND-TRUTH states, so that G = the dataset's world frame
// W. For tests and benchmarks of LOC mode (docs/daemon.md "Localization"): localization errors
// are then errors against ground truth, without any alignment.
#include <algorithm>
#include <cstdlib>
#include <iostream>
#include <string>

#include "vilma/core/asl_dataset.h"
#include "vilma/core/error.h"
#include "vilma/core/rig.h"
#include "vilma/mapping/locmap/localization_map_builder.h"
#include "vilma/mapping/map_builder.h"

namespace {

void Usage(std::ostream& out) {
  out << "usage: vilma-locmap-gt DATASET OUT.vlocmap [--seconds S] [--camera C]\n"
         "Builds a localization map from DATASET (ASL folder with rig.yaml and ground truth):\n"
         "map-builder vertices with the ground-truth states (G = the dataset's world frame),\n"
         "keyframe features of camera C (default 0), the first S seconds (default: all).\n";
}

}  // namespace

int main(int argc, char** argv) {
  using namespace vilma;
  std::string dataset, out;
  double seconds = 1e9;
  int camera = 0;
  for (int i = 1; i < argc; ++i) {
    const std::string a = argv[i];
    if (a == "--help" || a == "-h") {
      Usage(std::cout);
      return 0;
    } else if (a == "--seconds" && i + 1 < argc) {
      seconds = std::atof(argv[++i]);
    } else if (a == "--camera" && i + 1 < argc) {
      camera = std::atoi(argv[++i]);
    } else if (dataset.empty()) {
      dataset = a;
    } else if (out.empty()) {
      out = a;
    } else {
      Usage(std::cerr);
      return 2;
    }
  }
  if (dataset.empty() || out.empty() || !(seconds > 0.0) || camera < 0) {
    Usage(std::cerr);
    return 2;
  }
  try {
    const AslDataset ds = AslDataset::Open(dataset);
    const SensorRig rig = LoadSensorRig(dataset + "/rig.yaml");
    if (camera >= static_cast<int>(rig.cameras.size()) ||
        camera >= static_cast<int>(ds.cameras().size())) {
      throw InputError(FormatInputError(dataset, "--camera", "a camera of the rig"));
    }
    mapping::MapBuilderOptions options;
    options.cameras = {camera};
    mapping::MapBuilder builder(rig, options, 42, "groundtruth");
    const auto& imu = ds.imu();
    const auto& gt = ds.ground_truth();
    const auto& frames = ds.cameras()[static_cast<std::size_t>(camera)].frames;
    if (frames.empty() || gt.empty()) {
      throw InputError(FormatInputError(dataset, "cameras / ground truth", "images and ground truth"));
    }
    const int64_t offset = rig.cameras[static_cast<std::size_t>(camera)].time_offset_ns;
    const int64_t t_end = frames.front().t_ns + static_cast<int64_t>(seconds * 1e9);
    std::size_t next_imu = 0;
    for (const auto& frame : frames) {
      if (frame.t_ns > t_end) break;
      const int64_t t = frame.t_ns + offset;
      while (next_imu < imu.size() && imu[next_imu].t_ns <= t) builder.AddImu(imu[next_imu++]);
      if (next_imu < imu.size()) builder.AddImu(imu[next_imu++]);
      // The ground-truth state at exactly this time (the simulator writes one per frame).
      const auto it = std::lower_bound(gt.begin(), gt.end(), t,
                                       [](const GroundTruthState& g, int64_t tt) { return g.t_ns < tt; });
      if (it == gt.end() || it->t_ns != t) continue;
      mapping::FrameState s;
      s.t_ns = t;
      s.T_M_I = Transformation(it->q_W_I, it->p_W_I);
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
    }
    while (next_imu < imu.size()) builder.AddImu(imu[next_imu++]);
    builder.Finish();
    const localizer::LocalizationMap map = mapping::BuildLocalizationMap(builder.map());
    localizer::SaveLocalizationMap(map, out);
    std::cout << "vilma-locmap-gt: " << builder.stats().vertices << " vertices, "
              << map.num_landmarks() << " landmarks, " << map.num_descriptors()
              << " descriptors -> " << out << "\n";
    return map.num_landmarks() > 0 ? 0 : 1;
  } catch (const std::exception& e) {
    std::cerr << "vilma-locmap-gt: error: " << e.what() << "\n";
    return 1;
  }
}
