// Sensor rig YAML (core/rig.h): cameras, distortion models, extrinsics, IMU noise.
#include <cstddef>
#include <cstdint>
#include <exception>
#include <string>

#include "vilma/core/rig.h"
#include <fstream>
#include <vector>
#include "fuzz_util.h"

// Seeds: the rig files given in $VILMA_FUZZ_RIG_FILES (colon-separated; scripts/fuzz.sh passes
// config/*rig*.yaml) and their canonical rewrite.
extern "C" int LLVMFuzzerInitialize(int*, char***) {
  vilma::fuzz::WriteSeedsIfAsked([] {
    std::vector<std::string> seeds;
    const char* files = std::getenv("VILMA_FUZZ_RIG_FILES");
    std::string list = files ? files : "";
    for (std::size_t start = 0; start < list.size();) {
      const std::size_t end = std::min(list.find(':', start), list.size());
      const std::string text = vilma::fuzz::ReadText(list.substr(start, end - start));
      seeds.push_back(text);
      try {
        seeds.push_back(vilma::SensorRigToYaml(vilma::ParseSensorRig(text, "seed")));
      } catch (const std::exception&) {
      }
      start = end + 1;
    }
    return seeds;
  });
  return 0;
}

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, std::size_t size) {
  const std::string text(reinterpret_cast<const char*>(data), size);
  try {
    const vilma::SensorRig rig = vilma::ParseSensorRig(text, "fuzz-rig.yaml");
    // A rig that loads must also write and read back.
    vilma::ParseSensorRig(vilma::SensorRigToYaml(rig), "fuzz-rig-roundtrip.yaml");
  } catch (const std::exception&) {
  }
  return 0;
}
