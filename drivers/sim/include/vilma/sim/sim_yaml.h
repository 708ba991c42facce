// A vilma-sim dataset's sim.yaml (the options it was made with; Simulator::WriteDataset writes
// it): read back, and compared with other options to reuse a rendering's images for another IMU
// draw (`vilma-sim --images-from`, docs/simulator.md "IMU draws").
#pragma once

#include <string>

#include "vilma/sim/simulator.h"

namespace vilma {
namespace sim {

// The options recorded in a sim.yaml: world, session, seconds, seed, revisit_seconds, stereo,
// and when present camera_time_offset_ns, motion_blur_samples, noise_sigma, imu_draw (older
// files lack some; they keep SimOptions' defaults). Options sim.yaml does not record keep their
// defaults. Throws InputError naming the file and key for an unreadable file or value.
SimOptions ReadSimYaml(const std::string& path);

// Whether the dataset folder `images_dir` holds the images that `options` render: its sim.yaml
// has the same world, seed, session, seconds, stereo, revisit_seconds, camera_time_offset_ns,
// motion_blur_samples and noise_sigma (all of them required in the file) and `frames` equal to
// `num_frames`; the IMU draw may differ. Returns "" or the InputError message "FILE: FIELD:
// expected ..." naming the first field that differs (or the missing file / folder).
std::string CheckSameImages(const std::string& images_dir, const SimOptions& options,
                            int num_frames);

}  // namespace sim
}  // namespace vilma
