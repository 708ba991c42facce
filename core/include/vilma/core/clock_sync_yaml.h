// ClockSyncOptions in the drivers' YAML option files (the `clock_sync:` section of
// config/aravis.yaml, config/usb_imu.yaml): one reader and one writer for every driver.
#pragma once

#include <yaml-cpp/yaml.h>

#include "vilma/core/clock_sync.h"
#include "vilma/core/yaml_io.h"

namespace vilma {

// Strict: an unknown key is an error naming it; a missing key keeps `base`'s value; the result
// is validated (InputError "file: key_path.field: expectation").
ClockSyncOptions ReadClockSyncOptions(const YamlNode& node, ClockSyncOptions base = {});
// The options as a YAML map under `key` (the keys ReadClockSyncOptions reads), into a map that
// `out` is writing.
void EmitClockSyncOptions(YAML::Emitter& out, const char* key, const ClockSyncOptions& options);

}  // namespace vilma
