#include "vilma/console/rig_command.h"

#include <cmath>
#include <iomanip>

#include "vilma/core/error.h"
#include "vilma/core/rig.h"

namespace vilma::console {
namespace {

// A human summary of what the rig implies (what people check by hand after a calibration).
void PrintRigSummary(const SensorRig& rig, std::ostream& out) {
  out << std::setprecision(4);
  out << "# imu " << rig.imu.name << ": " << rig.imu.rate_hz << " Hz, gravity "
      << rig.imu.gravity_magnitude << " m/s^2\n";
  for (const CameraConfig& c : rig.cameras) {
    const double hfov_deg =
        2.0 * std::atan2(0.5 * c.camera.width(), c.camera.fx()) * 180.0 / M_PI;
    out << "# camera " << c.name << ": " << c.camera.width() << "x" << c.camera.height() << " @ "
        << c.rate_hz << " Hz, " << ToString(c.camera.distortion_model())
        << ", horizontal FOV ~" << std::lround(hfov_deg) << " deg, |p_I_C| = "
        << c.T_I_C.translation().norm() << " m, time offset "
        << c.time_offset_ns << " ns\n";
  }
  for (std::size_t i = 1; i < rig.cameras.size(); ++i) {
    const Transformation T_C0_Ci = rig.cameras[0].T_I_C.inverse() * rig.cameras[i].T_I_C;
    out << "# baseline " << rig.cameras[0].name << "-" << rig.cameras[i].name << ": "
        << T_C0_Ci.translation().norm() << " m, relative rotation "
        << LogSO3(T_C0_Ci.rotation()).norm() * 180.0 / M_PI
        << " deg\n";
  }
}

}  // namespace

void PrintRigHelp(std::ostream& out) {
  out << "usage: vilma rig import DATASET [--out RIG.yaml]\n"
         "       vilma rig check RIG.yaml\n"
         "\n"
         "import  reads the EuRoC/Kalibr sensor.yaml files of an ASL dataset (DATASET/mav0/\n"
         "        cam*/sensor.yaml, imu0/sensor.yaml) and writes a vilma rig YAML\n"
         "        (docs/formats.md) to RIG.yaml, or to stdout without --out\n"
         "check   validates a vilma rig YAML and prints it as vilma reads it, with a summary\n"
         "        (field of view, lever arms, stereo baselines)\n"
         "\n"
         "exit codes: 0 ok, 1 input error, 2 usage error\n";
}

int RunRigCommand(const std::vector<std::string>& args, std::ostream& out, std::ostream& err) {
  try {
    if (args.empty()) throw UsageError("missing action: import or check");
    const std::string action = args[0];
    if (action == "--help" || action == "-h") {
      PrintRigHelp(out);
      return kExitOk;
    }
    std::string input, out_path;
    const std::vector<std::string> rest(args.begin() + 1, args.end());
    for (ArgCursor arg(rest); arg.Next();) {
      const std::string& a = arg.name();
      if (a == "--help" || a == "-h") {
        arg.Flag();  // "--help=x" is a usage error
        PrintRigHelp(out);
        return kExitOk;
      } else if (a == "--out" && action == "import") {
        out_path = arg.Value();
      } else if (arg.is_option()) {
        throw UsageError("unknown option " + arg.word());
      } else if (input.empty()) {
        input = a;
      } else {
        throw UsageError("unexpected argument " + a);
      }
    }
    if (input.empty()) throw UsageError(action == "import" ? "missing DATASET" : "missing RIG.yaml");

    if (action == "import") {
      const SensorRig rig = ImportEurocRig(input);
      if (out_path.empty()) {
        out << SensorRigToYaml(rig);
      } else {
        SaveSensorRig(rig, out_path);
        out << "wrote " << out_path << " (" << rig.cameras.size() << " cameras)\n";
      }
      PrintRigSummary(rig, out_path.empty() ? err : out);
      return kExitOk;
    }
    if (action == "check") {
      const SensorRig rig = LoadSensorRig(input);
      const std::string problem = rig.Validate();
      if (!problem.empty()) throw InputError(FormatInputError(input, "", problem));
      out << SensorRigToYaml(rig);
      PrintRigSummary(rig, out);
      out << "# " << input << ": ok\n";
      return kExitOk;
    }
    throw UsageError("unknown action '" + action + "' (import or check)");
  } catch (const UsageError& e) {
    err << "vilma rig: " << e.what() << "\n\n";
    PrintRigHelp(err);
    return kExitUsage;
  } catch (const std::exception& e) {
    err << "vilma rig: error: " << e.what() << "\n";
    return kExitInputError;
  }
}

}  // namespace vilma::console
