// scripts/lcm-spy starts under Xvfb with the vilma types on Debian 12 (Java 17), and the
// type database it uses maps the fingerprint of a C++ vilma.imu_t to the Java class.
// Skips (VILMA_SKIP) without java, xvfb-run or the types jar.
#include <catch2/catch.hpp>
#include <filesystem>
#include <lcm/lcm-cpp.hpp>
#include <thread>

#include <vilma/imu_t.hpp>

#include "integration/process_util.h"
#include "test_skip.h"

namespace vilma {
namespace {

TEST_CASE("scripts/lcm-spy starts with the vilma types and decodes imu_t",
          "[integration][lcm]") {
  const std::string jar = std::string(VILMA_BINARY_DIR) + "/vilma_lcmtypes.jar";
  const std::string script = std::string(VILMA_SOURCE_DIR) + "/scripts/lcm-spy";
  for (const char* program : {"java", "xvfb-run"}) {
    if (!test::HaveProgram(program)) {
      VILMA_SKIP(program << " not found (Debian packages default-jdk-headless xvfb xauth)");
    }
  }
  if (!test::FileExists(jar) || !test::FileExists("/usr/share/java/jchart2d.jar")) {
    VILMA_SKIP(jar << " or /usr/share/java/jchart2d.jar missing");
  }
  int num_types = 0;
  for (const auto& entry :
       std::filesystem::directory_iterator(std::string(VILMA_SOURCE_DIR) + "/msgs/lcm/vilma")) {
    if (entry.path().extension() == ".lcm") ++num_types;
  }
  const std::string dir = test::ScratchDir();
  const std::string out = dir + "/lcm_spy.out";
  const std::string trigger = dir + "/lcm_spy.screenshot";
  const std::string png = std::string(VILMA_BINARY_DIR) + "/lcm-spy.png";
  std::filesystem::remove(trigger);
  const std::string url = test::UniqueLcmUrl(false);

  // lcm-spy in a virtual X server; when the test touches `trigger`, a screenshot of the root
  // window is taken (if ImageMagick's `import` is there) and lcm-spy is stopped.
  const std::string shell =
      "\"" + script + "\" --lcm-url \"" + url + "\" & spy=$!; "
      "while [ ! -f \"" + trigger + "\" ]; do sleep 0.1; done; "
      "if command -v import >/dev/null; then import -window root \"" + png + "\"; fi; "
      "kill $spy; wait $spy";
  test::ChildProcess spy({"xvfb-run", "-a", "-s", "-screen 0 1280x800x24", "sh", "-c", shell},
                         out, {"VILMA_BUILD_DIR=" VILMA_BINARY_DIR});
  const std::string found = "Found " + std::to_string(num_types) + " LCM types";
  const bool started = test::WaitForOutput(out, found, 30.0);
  INFO(test::ReadTextFile(out));
  REQUIRE(started);

  // Publish IMU samples for lcm-spy to show (and to fail on, would it choke).
  {
    lcm::LCM lcm(url);
    REQUIRE(lcm.good());
    imu_t msg{};
    for (int i = 0; i < 30; ++i) {
      msg.utime = 1403715273262143 + 5000 * i;
      msg.seq = i;
      msg.linear_acceleration[2] = 9.81;
      lcm.publish("IMU", &msg);
      std::this_thread::sleep_for(std::chrono::milliseconds(50));
    }
  }
  std::this_thread::sleep_for(std::chrono::milliseconds(700));  // a GUI refresh
  CHECK(spy.running());
  std::ofstream(trigger) << "now";
  spy.Wait(20.0);
  const std::string output = test::ReadTextFile(out);
  CHECK(output.find("Exception") == std::string::npos);
  CHECK(output.find("Unrecognized option") == std::string::npos);

  // The fingerprint lcm-spy reads from the first 8 bytes of our C++ message resolves to the
  // Java class vilma.imu_t in lcm-spy's own type database, on the script's class path.
  char hex[32];
  std::snprintf(hex, sizeof(hex), "%llx", static_cast<unsigned long long>(imu_t::getHash()));
  const std::string check_out = dir + "/lcm_spy_check.out";
  test::ChildProcess check({"java", "-cp",
                            "/usr/share/java/lcm.jar:/usr/share/java/jchart2d.jar:" + jar,
                            std::string(VILMA_SOURCE_DIR) + "/tests/integration/LcmSpyTypeCheck.java",
                            hex},
                           check_out);
  REQUIRE(check.Wait(60.0) == 0);
  const std::string check_output = test::ReadTextFile(check_out);
  INFO(check_output);
  CHECK(check_output.find("FINGERPRINT " + std::string(hex) + " -> vilma.imu_t") !=
        std::string::npos);
}

}  // namespace
}  // namespace vilma
