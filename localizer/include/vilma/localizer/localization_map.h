// Localization map (maplab's localization summary map): the good landmarks of a VI-map with
// their positions in the global frame G, a representative subset of their observations'
// binary descriptors, and their observer vertices (for covisibility filtering). It is all the
// localizer needs, saved as its own compact versioned binary file (docs/localizer.md,
// "Localization"). Built from a VI-map by the map code (mapping/locmap): the localizer knows
// no VI-map.
#pragma once

#include <Eigen/Core>
#include <cstddef>
#include <cstdint>
#include <string>
#include <vector>

namespace vilma::localizer {

// The 128-bit id of the map object (landmark, observer vertex) an entry came from: opaque to
// the localizer, which only stores and compares it; the map code converts it to and from the
// VI-map's ids (mapping/locmap). 16 bytes, hi then lo, as stored in the file.
struct MapObjectId {
  uint64_t hi = 0;
  uint64_t lo = 0;
  bool operator==(const MapObjectId& o) const { return hi == o.hi && lo == o.lo; }
  bool operator!=(const MapObjectId& o) const { return !(*this == o); }
};
static_assert(sizeof(MapObjectId) == 16, "MapObjectId is stored as 16 bytes");

struct LocalizationMapOptions {
  // Descriptors kept per landmark: all its observations' descriptors when it has at most this
  // many, else this many spread evenly along the observation list (the track order, so the
  // subset spans the viewpoints the landmark was seen from). Bounds map size and query time.
  int max_descriptors_per_landmark = 8;
  // Landmarks with fewer observations are dropped (a landmark seen once is unreliable).
  int min_observations = 2;
  // Landmark covariances calibrated to the map's own keypoint noise (measured from the
  // residuals of its observations, mapping/locmap/landmark_covariance.h) instead of the
  // triangulation's assumed pixel sigma (1 px, 3-4x too large in variance; docs/localizer.md,
  // "Calibrated landmark covariances"). False: the stored covariances as they are.
  bool calibrate_landmark_covariances = true;
  std::string Validate() const;
};

struct LocalizationMap {
  // 2: per-landmark covariance after p_G. Version 1 files (without it) still load.
  static constexpr uint32_t kFormatVersion = 2;

  uint32_t descriptor_bytes = 64;  // 512-bit BRISK
  // Per landmark (index l).
  std::vector<MapObjectId> landmark_ids;  // the VI-map landmark of each
  std::vector<Eigen::Vector3d> p_G;  // [m]
  // Covariance of p_G [m^2] per landmark (from its triangulation: the observation geometry
  // under keypoint noise, e.g. stereo depth sigma_Z = Z^2 sigma_d / (f b)), or empty: unknown,
  // the landmarks are then taken as exact. The localizer propagates it into the reprojection
  // residual's covariance (pose_acceptance.h): a far stereo point constrains the pose little.
  // Floats: 36 bytes per landmark, sigmas of micrometres to metres.
  std::vector<Eigen::Matrix3f> p_G_covariance;
  // Observer vertices of landmark l: observer_index[observer_begin[l] .. observer_begin[l+1])
  // into `observers` (deduplicated vertex ids, the nodes of the covisibility graph).
  std::vector<uint32_t> observer_begin;  // size landmarks + 1
  std::vector<uint32_t> observer_index;
  std::vector<MapObjectId> observers;
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

// Binary little-endian file: magic "VLOCMAP1", format version, counts, arrays (version 2: the
// landmark covariances after p_G, 0 or one per landmark), then the CRC-32 of everything
// before it. Written atomically (temporary file, fsync, rename). Load throws
// InputError naming the file and the field that is wrong.
void SaveLocalizationMap(const LocalizationMap& map, const std::string& path);
LocalizationMap LoadLocalizationMap(const std::string& path);

}  // namespace vilma::localizer
