// ASL/EuRoC dataset folders (core/asl_dataset.h): the CSV files and a camera's sensor.yaml.
// A minimal valid dataset is written once; each input replaces one of its files (the first
// byte picks which).
#include <cstddef>
#include <cstdint>
#include <exception>
#include <filesystem>
#include <string>

#include "fuzz_util.h"
#include "vilma/core/asl_dataset.h"
#include <vector>

namespace fs = std::filesystem;

namespace {

struct SeedFile {
  const char* path;
  const char* content;
};

// A two-frame, four-sample dataset (the images are never decoded by Open()).
const SeedFile kSeedFiles[] = {
    {"mav0/cam0/data.csv",
     "#timestamp [ns],filename\n1403715273262142976,1403715273262142976.png\n"
     "1403715273312142976,1403715273312142976.png\n"},
    {"mav0/cam0/sensor.yaml",
     "sensor_type: camera\nrate_hz: 20\nresolution: [752, 480]\ncamera_model: pinhole\n"
     "intrinsics: [458.654, 457.296, 367.215, 248.375]\ndistortion_model: radial-tangential\n"
     "distortion_coefficients: [-0.28340811, 0.07395907, 0.00019359, 1.76187114e-05]\n"
     "T_BS:\n  cols: 4\n  rows: 4\n  data: [1.0, 0.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0,\n"
     "         0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 0.0, 1.0]\n"},
    {"mav0/imu0/data.csv",
     "#timestamp [ns],w_RS_S_x [rad s^-1],w_RS_S_y [rad s^-1],w_RS_S_z [rad s^-1],"
     "a_RS_S_x [m s^-2],a_RS_S_y [m s^-2],a_RS_S_z [m s^-2]\n"
     "1403715273257142784,-0.0991,0.1402,0.0286,9.0824,0.0817,-3.3587\n"
     "1403715273262142976,-0.0977,0.1388,0.0293,9.0578,0.0654,-3.3669\n"
     "1403715273267142912,-0.0970,0.1374,0.0300,9.0905,0.0736,-3.3506\n"
     "1403715273272143104,-0.0963,0.1367,0.0307,9.0987,0.0654,-3.3669\n"},
    {"mav0/state_groundtruth_estimate0/data.csv",
     "#timestamp,p_RS_R_x [m],p_RS_R_y [m],p_RS_R_z [m],q_RS_w [],q_RS_x [],q_RS_y [],"
     "q_RS_z [],v_RS_R_x [m s^-1],v_RS_R_y [m s^-1],v_RS_R_z [m s^-1],b_w_RS_S_x [rad s^-1],"
     "b_w_RS_S_y [rad s^-1],b_w_RS_S_z [rad s^-1],b_a_RS_S_x [m s^-2],b_a_RS_S_y [m s^-2],"
     "b_a_RS_S_z [m s^-2]\n"
     "1403715273262142976,0.878,2.142,0.947,0.061,-0.828,-0.058,-0.554,0.0,0.0,0.0,-0.002,"
     "0.021,0.076,-0.012,0.1,0.09\n"},
};
constexpr std::size_t kNumSeedFiles = sizeof(kSeedFiles) / sizeof(kSeedFiles[0]);

const fs::path& SeedRoot() {
  static const fs::path root = [] {
    const fs::path r = vilma::fuzz::ScratchDir("asl") / "dataset";
    for (const SeedFile& f : kSeedFiles) {
      fs::create_directories((r / f.path).parent_path());
      const std::string text = f.content;
      vilma::fuzz::WriteBytes(r / f.path, reinterpret_cast<const uint8_t*>(text.data()),
                              text.size());
    }
    return r;
  }();
  return root;
}

}  // namespace

extern "C" int LLVMFuzzerInitialize(int*, char***) {
  vilma::fuzz::WriteSeedsIfAsked([] {
    std::vector<std::string> seeds;
    for (std::size_t i = 0; i < kNumSeedFiles; ++i) {
      seeds.push_back(vilma::fuzz::WithPrefix(static_cast<uint8_t>(i), kSeedFiles[i].content));
    }
    return seeds;
  });
  return 0;
}

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, std::size_t size) {
  if (size < 1) return 0;
  const fs::path& root = SeedRoot();
  const SeedFile& seed = kSeedFiles[data[0] % kNumSeedFiles];
  vilma::fuzz::WriteBytes(root / seed.path, data + 1, size - 1);
  try {
    vilma::AslDataset::Open(root.string());
  } catch (const std::exception&) {
  }
  const std::string original = seed.content;
  vilma::fuzz::WriteBytes(root / seed.path, reinterpret_cast<const uint8_t*>(original.data()),
                          original.size());
  return 0;
}
