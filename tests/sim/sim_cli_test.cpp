// vilma-sim's IMU draws from the command line (--imu-draw, --images-from; docs/simulator.md
// "IMU draws"): the imu0 CSV of draw k is byte for byte the copy that the hidden diagnostic
// "IMU variants of a simulated set" (tests/estimator/vio_tracking_truth_sim_test.cpp) wrote
// at ba5e95c with its own code (restated here as the reference: the IMU simulated from the
// random stream DeriveSeed(DeriveSeed(seed, 2000 + session), k) and written by
// AslDatasetWriter), on a short simulated set.
#include <catch2/catch.hpp>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>
#include <unistd.h>

#include "test_skip.h"
#include "vilma/core/asl_dataset.h"
#include "vilma/sim/imu_sim.h"
#include "vilma/sim/random.h"
#include "vilma/sim/sim_yaml.h"
#include "vilma/sim/simulator.h"

namespace fs = std::filesystem;

namespace {

std::string ReadBytes(const fs::path& path) {
  std::ifstream in(path, std::ios::binary);
  REQUIRE(in.good());
  std::ostringstream s;
  s << in.rdbuf();
  return s.str();
}

// Runs vilma-sim with `args`; returns its exit status, stderr in `err`.
int RunSim(const std::string& args, const fs::path& err_file, std::string* err) {
  const std::string sim = std::string(VILMA_BINARY_DIR) + "/bin/vilma-sim";
  const std::string command = sim + " " + args + " > /dev/null 2> " + err_file.string();
  const int status = std::system(command.c_str());
  *err = ReadBytes(err_file);
  return WIFEXITED(status) ? WEXITSTATUS(status) : -1;
}

// The diagnostic's copy (ba5e95c's WriteImuVariant for a numeric variant): imu0 and ground truth.
void WriteReferenceDraw(const vilma::sim::SimOptions& options, int draw, const fs::path& out) {
  vilma::sim::SimOptions own = options;
  own.imu_draw = 0;
  vilma::sim::Simulator simulator(own);
  uint64_t seed = vilma::sim::DeriveSeed(own.seed, 2000 + static_cast<uint64_t>(own.session));
  if (draw > 0) seed = vilma::sim::DeriveSeed(seed, static_cast<uint64_t>(draw));
  vilma::sim::Rng rng(seed);
  const vilma::sim::ImuSimResult imu = vilma::sim::SimulateImu(
      simulator.trajectory(), simulator.start_time_ns(), own.seconds, own.imu, &rng);
  fs::remove_all(out);
  vilma::AslDatasetWriter writer(out.string(), 0);
  for (const vilma::ImuSample& s : imu.samples) writer.AddImu(s);
  for (const vilma::GroundTruthState& g : imu.ground_truth) writer.AddGroundTruth(g);
  writer.Finish();
}

}  // namespace

TEST_CASE("vilma-sim --imu-draw: the diagnostic's IMU copies byte for byte, images linked",
          "[sim][cli]") {
  const std::string sim = std::string(VILMA_BINARY_DIR) + "/bin/vilma-sim";
  if (!fs::exists(sim)) VILMA_SKIP(sim << " is not built");
  const fs::path root =
      fs::temp_directory_path() / ("vilma_sim_cli_test_" + std::to_string(::getpid()));
  fs::remove_all(root);
  fs::create_directories(root);
  const fs::path err_file = root / "stderr.txt";
  std::string err;
  const std::string base = "room --stereo --seconds 2 --seed 7 --session 1";
  REQUIRE(RunSim(base + " --out " + (root / "own").string(), err_file, &err) == 0);
  vilma::sim::SimOptions options = vilma::sim::ReadSimYaml((root / "own/sim.yaml").string());
  CHECK(options.world == "room");
  CHECK(options.seed == 7);
  CHECK(options.session == 1);
  CHECK(options.stereo);
  CHECK(options.imu_draw == 0);
  const std::string imu_csv = "mav0/imu0/data.csv";
  const std::string gt_csv = "mav0/state_groundtruth_estimate0/data.csv";

  for (const int k : {0, 1, 3}) {
    const fs::path out = root / ("draw" + std::to_string(k));
    REQUIRE(RunSim(base + " --imu-draw " + std::to_string(k) + " --images-from " +
                       (root / "own").string() + " --out " + out.string(),
                   err_file, &err) == 0);
    WriteReferenceDraw(options, k, root / "reference");
    const std::string bytes = ReadBytes(out / imu_csv);
    CHECK(bytes == ReadBytes(root / "reference" / imu_csv));
    CHECK(ReadBytes(out / gt_csv) == ReadBytes(root / "reference" / gt_csv));
    // Draw 0 is the set's own IMU; others differ from it.
    CHECK((bytes == ReadBytes(root / "own" / imu_csv)) == (k == 0));
    // The images are the rendering's (links), the rig and sensor files as a rendering writes.
    for (const char* cam : {"cam0", "cam1"}) {
      CHECK(fs::is_symlink(out / "mav0" / cam));
      CHECK(fs::equivalent(out / "mav0" / cam, root / "own/mav0" / cam));
    }
    CHECK(ReadBytes(out / "rig.yaml") == ReadBytes(root / "own/rig.yaml"));
    CHECK(ReadBytes(out / "mav0/imu0/sensor.yaml") == ReadBytes(root / "own/mav0/imu0/sensor.yaml"));
    const vilma::AslDataset d = vilma::AslDataset::Open(out.string());
    CHECK(d.cameras().size() == 2);
    CHECK(d.cameras()[1].frames.size() == 41);
    CHECK(vilma::sim::ReadSimYaml((out / "sim.yaml").string()).imu_draw == k);
    CHECK_THAT(ReadBytes(out / "sim.yaml"), Catch::Contains("images_from: "));
  }
  // A draw rendered in full has the same IMU as the linked one (the images do not depend on it).
  REQUIRE(RunSim(base + " --imu-draw 3 --out " + (root / "full3").string(), err_file, &err) == 0);
  CHECK(ReadBytes(root / "full3" / imu_csv) == ReadBytes(root / "draw3" / imu_csv));
  CHECK(!fs::is_symlink(root / "full3/mav0/cam0"));
  // A draw of a draw links to the rendering itself.
  REQUIRE(RunSim(base + " --imu-draw 2 --images-from " + (root / "draw3").string() + " --out " +
                     (root / "draw2").string(),
                 err_file, &err) == 0);
  CHECK(fs::read_symlink(root / "draw2/mav0/cam0") == fs::canonical(root / "own/mav0/cam0"));

  SECTION("another rendering is refused, naming the file and field") {
    const std::string own = (root / "own").string();
    const std::string sim_yaml = (root / "own" / "sim.yaml").string();
    const std::string out = " --out " + (root / "bad").string();
    CHECK(RunSim("room --stereo --seconds 3 --seed 7 --session 1 --images-from " + own + out,
                 err_file, &err) == 1);
    CHECK_THAT(err, Catch::Contains(sim_yaml + ": seconds: expected 3"));
    CHECK(RunSim("room --stereo --seconds 2 --seed 8 --session 1 --images-from " + own + out,
                 err_file, &err) == 1);
    CHECK_THAT(err, Catch::Contains(sim_yaml + ": seed: expected 8"));
    CHECK(RunSim("hall --stereo --seconds 2 --seed 7 --session 1 --images-from " + own + out,
                 err_file, &err) == 1);
    CHECK_THAT(err, Catch::Contains(sim_yaml + ": world: expected hall"));
    CHECK(RunSim("room --seconds 2 --seed 7 --session 1 --images-from " + own + out, err_file,
                 &err) == 1);
    CHECK_THAT(err, Catch::Contains(sim_yaml + ": stereo: expected false"));
    CHECK(RunSim("room --stereo --seconds 2 --seed 7 --session 0 --images-from " + own + out,
                 err_file, &err) == 1);
    CHECK_THAT(err, Catch::Contains(sim_yaml + ": session: expected 0"));
    CHECK(RunSim(base + " --images-from " + (root / "nothing").string() + out, err_file, &err) ==
          1);
    CHECK_THAT(err, Catch::Contains((root / "nothing" / "sim.yaml").string()));
    CHECK(!fs::exists(root / "bad"));
    // Bad command lines.
    CHECK(RunSim(base + " --imu-draw -1" + out, err_file, &err) == 2);
    CHECK(RunSim(base + " --live --images-from " + own, err_file, &err) == 2);
  }
  fs::remove_all(root);
}
