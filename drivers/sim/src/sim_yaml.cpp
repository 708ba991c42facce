#include "vilma/sim/sim_yaml.h"

#include <filesystem>
#include <sstream>

#include "vilma/core/error.h"
#include "vilma/core/yaml_io.h"

namespace vilma {
namespace sim {

SimOptions ReadSimYaml(const std::string& path) {
  const YamlNode y = YamlNode::LoadFile(path);
  SimOptions o;
  o.world = y.Get<std::string>("world");
  o.session = y.Get<int>("session");
  o.seconds = y.Get<double>("seconds");
  const int64_t seed = y.Get<int64_t>("seed");
  if (seed < 0) y.Fail("seed", ">= 0");
  o.seed = static_cast<uint64_t>(seed);
  o.revisit_seconds = y.GetOr<double>("revisit_seconds", o.revisit_seconds);
  o.stereo = y.Get<bool>("stereo");
  o.camera_time_offset_ns = y.GetOr<int64_t>("camera_time_offset_ns", o.camera_time_offset_ns);
  o.motion_blur_samples = y.GetOr<int>("motion_blur_samples", o.motion_blur_samples);
  o.noise_sigma = y.GetOr<double>("noise_sigma", o.noise_sigma);
  o.imu_draw = y.GetOr<int>("imu_draw", o.imu_draw);
  return o;
}

std::string CheckSameImages(const std::string& images_dir, const SimOptions& options,
                            int num_frames) {
  namespace fs = std::filesystem;
  const std::string path = (fs::path(images_dir) / "sim.yaml").string();
  if (!fs::exists(path)) {
    return FormatInputError(path, "", "expected a vilma-sim dataset's sim.yaml (missing)");
  }
  for (const char* cam : {"cam0", "cam1"}) {
    if (std::string(cam) == "cam1" && !options.stereo) break;
    const fs::path dir = fs::path(images_dir) / "mav0" / cam;
    if (!fs::is_directory(dir)) {
      return FormatInputError(dir.string(), "", "expected an image folder (missing)");
    }
  }
  try {
    const YamlNode y = YamlNode::LoadFile(path);
    auto differs = [&](const std::string& key, const std::string& theirs,
                       const std::string& ours) -> std::string {
      if (theirs == ours) return "";
      return FormatInputError(path, key,
                              "expected " + ours + " (the requested rendering's), found " + theirs);
    };
    auto num = [](auto v) {
      std::ostringstream s;
      s.precision(17);
      s << v;
      return s.str();
    };
    // Each value as the file's type reads it, compared as text of the same precision.
    const std::string checks[][3] = {
        {"world", y.Get<std::string>("world"), options.world},
        {"seed", num(y.Get<int64_t>("seed")), num(static_cast<int64_t>(options.seed))},
        {"session", num(y.Get<int>("session")), num(options.session)},
        {"seconds", num(y.Get<double>("seconds")), num(options.seconds)},
        {"stereo", y.Get<bool>("stereo") ? "true" : "false", options.stereo ? "true" : "false"},
        {"revisit_seconds", num(y.Get<double>("revisit_seconds")), num(options.revisit_seconds)},
        {"camera_time_offset_ns", num(y.Get<int64_t>("camera_time_offset_ns")),
         num(options.camera_time_offset_ns)},
        {"motion_blur_samples", num(y.Get<int>("motion_blur_samples")),
         num(options.motion_blur_samples)},
        {"noise_sigma", num(y.Get<double>("noise_sigma")), num(options.noise_sigma)},
        {"frames", num(y.Get<int>("frames")), num(num_frames)},
    };
    for (const auto& c : checks) {
      const std::string e = differs(c[0], c[1], c[2]);
      if (!e.empty()) return e;
    }
  } catch (const InputError& e) {
    return e.what();
  }
  return "";
}

}  // namespace sim
}  // namespace vilma
