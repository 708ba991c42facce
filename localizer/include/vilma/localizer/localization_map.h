// Localization map (maplab's localization summary map): the good landmarks of a VI-map with
// their positions in the global frame G, a representative subset of their observations'
// binary descriptors, and their observer vertices (for covisibility filtering). It is all the
// localizer needs, saved as its own compact versioned binary file (docs/localizer.md,
// "Localization").
#pragma once

#include <Eigen/Core>
#include <cstdint>
#include <string>
#include <vector>

#include "vilma/mapstore/vi_map.h"

namespace vilma::localizer {

struct LocalizationMapOptions {
  // Descriptors kept per landmark: all its observations' descriptors when it has at most this
  // many, else this many spread evenly along the observation list (the track order, so the
  // subset spans the viewpoints the landmark was seen from). Bounds map size and query time.
  int max_descriptors_per_landmark = 8;
  // Landmarks with fewer observations are dropped (a landmark seen once is unreliable).
  int min_observations = 2;
  std::string Validate() const;
};

struct LocalizationMap {
  static constexpr uint32_t kFormatVersion = 1;

  uint32_t descriptor_bytes = 64;  // 512-bit BRISK
  // Per landmark (index l).
  std::vector<mapstore::LandmarkId> landmark_ids;
  std::vector<Eigen::Vector3d> p_G;  // [m]
  // Observer vertices of landmark l: observer_index[observer_begin[l] .. observer_begin[l+1])
  // into `observers` (deduplicated vertex ids, the nodes of the covisibility graph).
  std::vector<uint32_t> observer_begin;  // size landmarks + 1
  std::vector<uint32_t> observer_index;
  std::vector<mapstore::VertexId> observers;
  // Descriptors: descriptor d belongs to landmark descriptor_landmark[d]; its bytes are
  // descriptors[d * descriptor_bytes ...].
  std::vector<uint32_t> descriptor_landmark;
  std::vector<uint8_t> descriptors;
  // Learned descriptor projection (rows = projected dimensions, cols = descriptor bits), as
  // trained by TrainProjectionMatrix; empty: the localizer learns one when it loads the map.
  Eigen::MatrixXf projection;

  std::size_t num_landmarks() const { return p_G.size(); }
  std::size_t num_descriptors() const { return descriptor_landmark.size(); }
  const uint8_t* descriptor(std::size_t d) const {
    return descriptors.data() + d * descriptor_bytes;
  }
  // Empty if the arrays agree with each other, else what does not.
  std::string Validate() const;
};

// Which missions of a VI-map share the frame G, so that their landmarks can be summarized
// together: the anchored missions (baseframe known: T_G_M is meaningful) when there is one;
// else the FIRST mission alone, whose odometry frame M then is G (T_G_M = identity). An
// unanchored mission after the first one (e.g. the daemon's new mission after a filter reset,
// docs/daemon.md) has its own unknown frame: mixing its landmarks in would place them wrongly.
std::vector<mapstore::MissionId> MissionsInCommonFrame(const mapstore::VIMap& map);

struct LocalizationMapReport {
  int missions_used = 0;
  int missions_skipped = 0;  // not in the common frame (see MissionsInCommonFrame)
};

// From the missions of MissionsInCommonFrame(map): landmarks of quality good (unknown and bad
// are skipped), positioned with their mission's T_G_M. `report` (optional) says which were used.
LocalizationMap BuildLocalizationMap(const mapstore::VIMap& map,
                                     const LocalizationMapOptions& options = {},
                                     LocalizationMapReport* report = nullptr);

// The same from the given missions (the caller vouches that they share the frame G), in their
// order: loop closure queries a mission against itself and the missions anchored with it.
LocalizationMap BuildLocalizationMapOfMissions(const mapstore::VIMap& map,
                                               const std::vector<mapstore::MissionId>& missions,
                                               const LocalizationMapOptions& options = {});

// Binary little-endian file: magic "VLOCMAP1", format version, counts, arrays, then the CRC-32
// of everything before it. Written atomically (temporary file, fsync, rename). Load throws
// InputError naming the file and the field that is wrong.
void SaveLocalizationMap(const LocalizationMap& map, const std::string& path);
LocalizationMap LoadLocalizationMap(const std::string& path);

}  // namespace vilma::localizer
