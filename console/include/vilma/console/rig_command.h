// `vilma rig`: sensor-rig files.
//
//   vilma rig import DATASET [--out RIG.yaml]   EuRoC/Kalibr sensor.yaml files -> vilma rig YAML
//   vilma rig check RIG.yaml                    validate and print the effective rig
#pragma once

#include <ostream>
#include <string>
#include <vector>

#include "vilma/console/command.h"

namespace vilma::console {

void PrintRigHelp(std::ostream& out);

// The whole command; returns kExitOk, kExitInputError or kExitUsage.
int RunRigCommand(const std::vector<std::string>& args, std::ostream& out, std::ostream& err);

}  // namespace vilma::console
