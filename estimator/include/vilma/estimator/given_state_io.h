// Reads a start state for VioFilter::StartFrom (docs/estimator.md, "Start from a given state")
// from a trajectory file: TUM or EuRoC CSV poses (read by core's trajectory reader, so the same
// files as `vilma eval`), or an ASL state_groundtruth_estimate0/data.csv with velocity and
// biases (17 columns). The poses must be T_W_I of the rig's IMU in a gravity-aligned frame
// (z up). Without velocity columns the velocity is the central difference of the interpolated
// positions over +-50 ms; without bias columns the biases are 0 with wider sigmas.
#pragma once

#include <cstdint>
#include <string>

#include "vilma/estimator/vio_filter.h"

namespace vilma::estimator {

struct GivenStateSource {
  bool velocity_from_file = false;  // else from position differences
  bool biases_from_file = false;    // else zero
};

// The state at t_ns (IMU clock, nanoseconds): poses interpolated between the two around it.
// Throws InputError naming the file when it cannot be read or does not cover t_ns (within
// 100 ms of a pose on each side).
GivenState LoadGivenState(const std::string& path, int64_t t_ns,
                          GivenStateSource* source = nullptr);

}  // namespace vilma::estimator
