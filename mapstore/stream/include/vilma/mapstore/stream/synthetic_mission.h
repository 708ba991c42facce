// A deterministic synthetic mission cut into deltas, as a map builder would stream it: for the
// mission stream tests, vilma-mission-sender and the throughput benchmark. Not a simulation
// (see drivers/sim for that): seeded random poses, keypoints, descriptors and IMU samples.
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include "vilma/mapstore/map_io.h"

namespace vilma {
namespace mapstore {

struct SyntheticMissionOptions {
  std::string name = "synthetic";
  uint64_t seed = 1;               // also gives the mission id
  int vertices = 50;
  int vertices_per_delta = 1;      // each delta: these vertices, their IMU edges, landmarks
  int keypoints_per_frame = 100;   // one camera; 64-byte descriptors
  int landmarks_per_vertex = 10;   // stored at the vertex, observed by it (keypoints 0..n-1)
  int imu_samples_per_edge = 20;
  std::string Validate() const;    // "" or "field: expectation"
};

// Deltas in stream order; every delta carries the mission header with complete=false.
std::vector<MissionDelta> MakeSyntheticMissionDeltas(const SyntheticMissionOptions& options);
// The map the deltas build (ApplyMissionDelta in order).
VIMap ApplyDeltas(const std::vector<MissionDelta>& deltas);

}  // namespace mapstore
}  // namespace vilma
