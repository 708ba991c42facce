#include "vilma/mapping/locmap/localization_map_builder.h"

#include <algorithm>
#include <unordered_map>

#include "vilma/core/error.h"
#include "vilma/mapping/locmap/landmark_covariance.h"

namespace vilma::mapping {

using localizer::LocalizationMap;
using localizer::LocalizationMapOptions;

std::vector<mapstore::MissionId> MissionsInCommonFrame(const mapstore::VIMap& map) {
  std::vector<mapstore::MissionId> anchored;
  for (const mapstore::MissionId& id : map.mission_ids()) {
    if (map.mission(id).baseframe_known) anchored.push_back(id);
  }
  if (!anchored.empty()) return anchored;
  if (map.mission_ids().empty()) return {};
  return {map.mission_ids().front()};
}

LocalizationMap BuildLocalizationMap(const mapstore::VIMap& map,
                                     const LocalizationMapOptions& options,
                                     LocalizationMapReport* report) {
  const std::vector<mapstore::MissionId> missions = MissionsInCommonFrame(map);
  if (report != nullptr) {
    report->missions_used = static_cast<int>(missions.size());
    report->missions_skipped = static_cast<int>(map.mission_ids().size() - missions.size());
  }
  return BuildLocalizationMapOfMissions(map, missions, options,
                                        report != nullptr ? &report->keypoint_noise : nullptr);
}

LocalizationMap BuildLocalizationMapOfMissions(const mapstore::VIMap& map,
                                               const std::vector<mapstore::MissionId>& missions,
                                               const LocalizationMapOptions& options,
                                               KeypointNoiseEstimate* keypoint_noise) {
  const std::string error = options.Validate();
  if (!error.empty()) throw InputError(FormatInputError("LocalizationMapOptions", "", error));
  LocalizationMap out;
  out.observer_begin.push_back(0);
  std::unordered_map<mapstore::VertexId, uint32_t, mapstore::IdHash> observer_of;
  bool bytes_known = false;
  bool any_covariance = false;
  // Per kept landmark: its valid observations, for the calibration after the loop.
  std::vector<std::vector<const mapstore::LandmarkObservation*>> kept_observations;
  for (const mapstore::MissionId& mission_id : missions) {
    for (const mapstore::LandmarkId& landmark_id : map.landmark_ids(mission_id)) {
      const mapstore::Landmark& landmark = map.landmark(landmark_id);
      if (landmark.quality != mapstore::LandmarkQuality::kGood) continue;
      // Observations whose vertex, frame and keypoint exist (after loop closure some may
      // point into missions that are not loaded).
      std::vector<const mapstore::LandmarkObservation*> valid;
      for (const mapstore::LandmarkObservation& obs : landmark.observations) {
        if (!map.HasVertex(obs.vertex_id)) continue;
        const mapstore::Vertex& v = map.vertex(obs.vertex_id);
        if (obs.camera >= v.frames.size() || obs.keypoint >= v.frames[obs.camera].size()) continue;
        const mapstore::VisualFrame& frame = v.frames[obs.camera];
        if (frame.descriptors.size() < (obs.keypoint + 1) * std::size_t{frame.descriptor_size_bytes}) {
          continue;
        }
        if (!bytes_known) {
          out.descriptor_bytes = frame.descriptor_size_bytes;
          bytes_known = true;
        }
        if (frame.descriptor_size_bytes != out.descriptor_bytes) continue;
        valid.push_back(&obs);
      }
      if (static_cast<int>(valid.size()) < options.min_observations || valid.empty()) continue;
      const uint32_t l = static_cast<uint32_t>(out.p_G.size());
      out.landmark_ids.push_back(ToMapObjectId(landmark_id));
      out.p_G.push_back(map.LandmarkPosition_G(landmark_id));
      // The landmark's covariance (of p_I in its store vertex's IMU frame, from its
      // triangulation) in G: Sigma_G = R_G_I Sigma_I R_G_I^T, symmetrized against rounding.
      const Eigen::Matrix3d R_G_I =
          map.T_G_I(landmark.store_vertex_id).rotation().toRotationMatrix();
      const Eigen::Matrix3d covariance_G = R_G_I * landmark.covariance * R_G_I.transpose();
      Eigen::Matrix3f c = (0.5 * (covariance_G + covariance_G.transpose())).cast<float>();
      // A degenerate triangulation (covariance not finite as floats, or negative variances
      // from rounding) carries no usable uncertainty: stored as unknown (zero).
      if (!c.allFinite() || c.diagonal().minCoeff() < 0.0f) c.setZero();
      out.p_G_covariance.push_back(c);
      any_covariance |= !c.isZero(0.0f);
      kept_observations.push_back(valid);
      const std::size_t first_observer = out.observer_index.size();
      for (const mapstore::LandmarkObservation* obs : valid) {
        auto [it, inserted] =
            observer_of.emplace(obs->vertex_id, static_cast<uint32_t>(out.observers.size()));
        if (inserted) out.observers.push_back(ToMapObjectId(obs->vertex_id));
        bool seen = false;
        for (std::size_t i = first_observer; i < out.observer_index.size(); ++i) {
          seen |= out.observer_index[i] == it->second;
        }
        if (!seen) out.observer_index.push_back(it->second);
      }
      out.observer_begin.push_back(static_cast<uint32_t>(out.observer_index.size()));
      // Evenly spread subset: indices round(i * (n - 1) / (m - 1)).
      const std::size_t n = valid.size();
      const std::size_t m =
          std::min(n, static_cast<std::size_t>(options.max_descriptors_per_landmark));
      for (std::size_t i = 0; i < m; ++i) {
        const std::size_t k = m == 1 ? 0 : (i * (n - 1) + (m - 1) / 2) / (m - 1);
        const mapstore::LandmarkObservation& obs = *valid[k];
        const uint8_t* d = map.vertex(obs.vertex_id).frames[obs.camera].descriptor(obs.keypoint);
        out.descriptors.insert(out.descriptors.end(), d, d + out.descriptor_bytes);
        out.descriptor_landmark.push_back(l);
      }
    }
  }
  // No landmark with a covariance (e.g. a map whose landmarks were set, not triangulated):
  // none stored, the localizer takes them as exact.
  if (!any_covariance) {
    out.p_G_covariance.clear();
    return out;
  }
  if (options.calibrate_landmark_covariances) {
    // The triangulated landmarks (those with a stored covariance) measure the keypoint noise;
    // their covariances are recomputed with it (landmark_covariance.h).
    std::vector<std::vector<const mapstore::LandmarkObservation*>> triangulated;
    std::vector<Eigen::Vector3d> triangulated_p_G;
    for (std::size_t l = 0; l < out.p_G.size(); ++l) {
      if (out.p_G_covariance[l].isZero(0.0f)) continue;
      triangulated.push_back(kept_observations[l]);
      triangulated_p_G.push_back(out.p_G[l]);
    }
    const KeypointNoiseEstimate noise = EstimateKeypointNoise(map, triangulated, triangulated_p_G);
    if (keypoint_noise != nullptr) *keypoint_noise = noise;
    if (noise.sigma_px > 0.0) {
      for (std::size_t l = 0; l < out.p_G.size(); ++l) {
        if (out.p_G_covariance[l].isZero(0.0f)) continue;
        Eigen::Matrix3d covariance_G;
        // A landmark whose geometry gives no covariance (its observations do not project
        // any more) keeps the stored one.
        if (TriangulationCovariance_G(map, kept_observations[l], out.p_G[l], noise.sigma_px,
                                      &covariance_G)) {
          out.p_G_covariance[l] = covariance_G.cast<float>();
        }
      }
    }
  }
  return out;
}

}  // namespace vilma::mapping
