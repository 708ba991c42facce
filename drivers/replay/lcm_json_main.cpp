// vilma-lcm-json: the vilma.status_t and vilma.pose_t messages of an LCM log as JSON lines
// (drivers/common/include/vilma/drivers/log_json.h), for scripts: scripts/soak.sh records
// VILMA_STATUS with lcm-logger and reads queue depths, drops and latencies from it;
// scripts/sensor-faults.sh reads the pose status of VILMA_ODOM around each fault.
#include <iostream>
#include <regex>
#include <string>

#include "vilma/drivers/log_json.h"

namespace {

const char kUsage[] = R"(Usage: vilma-lcm-json LOG [--channels REGEX]

Writes the vilma.status_t (VILMA_STATUS*) and vilma.pose_t (VILMA_ODOM, VILMA_POSE) messages
of an LCM log file as JSON, one object per line, in log order, to stdout:
  {"log_us":..,"channel":"VILMA_STATUS","type":"status","utime":..,"node":"vilma-estimatord",
   "state":1,"message":"..","counters":{"drops":0,..},"metrics":{"latency_total_p99_ms":2.1,..}}
  {"log_us":..,"channel":"VILMA_ODOM","type":"pose","utime":..,"seq":..,"status":2,
   "position":[x,y,z],"orientation":[w,x,y,z]}
log_us is the event time of the log [us] (lcm-logger: receive time); utime the message's own
time [us]. Events of other types (by their LCM fingerprint) are skipped and counted on stderr.

Options:
  --channels REGEX  channels to convert, the whole name (default VILMA_.*)
  --help            this text

Exit status: 0 on success, 1 on an unreadable log or when no event matched, 2 on bad options.
)";

}  // namespace

int main(int argc, char** argv) {
  std::string log_path, channels = "VILMA_.*";
  for (int i = 1; i < argc; ++i) {
    const std::string a = argv[i];
    if (a == "--help" || a == "-h") {
      std::cout << kUsage;
      return 0;
    } else if (a == "--channels" && i + 1 < argc) {
      channels = argv[++i];
    } else if (!a.empty() && a[0] != '-' && log_path.empty()) {
      log_path = a;
    } else {
      std::cerr << "vilma-lcm-json: unexpected argument '" << a << "'\n(see --help)\n";
      return 2;
    }
  }
  if (log_path.empty()) {
    std::cerr << "vilma-lcm-json: LOG is required\n(see --help)\n";
    return 2;
  }
  std::regex regex;
  try {
    regex = std::regex(channels);
  } catch (const std::regex_error& e) {
    std::cerr << "vilma-lcm-json: --channels: not a regular expression: '" << channels << "' ("
              << e.what() << ")\n";
    return 2;
  }
  try {
    const vilma::LogJsonStats stats = vilma::WriteLogJson(log_path, regex, std::cout);
    std::cerr << "vilma-lcm-json: " << stats.BriefReport() << "\n";
    if (stats.status + stats.poses == 0) {
      std::cerr << "vilma-lcm-json: " << log_path << ": no status_t or pose_t event on channels '"
                << channels << "'\n";
      return 1;
    }
    return 0;
  } catch (const std::exception& e) {
    std::cerr << "vilma-lcm-json: error: " << e.what() << "\n";
    return 1;
  }
}
