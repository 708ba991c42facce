#include "vilma/mapping/loop_closure/loop_closure.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <map>
#include <memory>
#include <sstream>
#include <stdexcept>
#include <unordered_map>

#include "vilma/mapping/locmap/localization_map_builder.h"
#include "vilma/localizer/pose_ransac.h"

namespace vilma::mapping {

using mapstore::LandmarkId;
using mapstore::LandmarkObservation;
using mapstore::MissionId;
using mapstore::VertexId;
using mapstore::VIMap;

std::string LoopClosureOptions::Validate() const {
  const std::string problem = localizer.Validate();
  if (!problem.empty()) return "localizer." + problem;
  if (lc_min_inliers < 4) return "lc_min_inliers: expected >= 4";
  if (!(lc_min_time_gap_s >= 0)) return "lc_min_time_gap_s: expected >= 0";
  if (!(lc_max_correction_m > 0)) return "lc_max_correction_m: expected > 0";
  if (!(lc_max_correction_deg > 0)) return "lc_max_correction_deg: expected > 0";
  if (lc_every_nth_vertex < 1) return "lc_every_nth_vertex: expected >= 1";
  if (!(std::isfinite(lc_merged_keypoint_sigma_px) && lc_merged_keypoint_sigma_px >= 0)) {
    return "lc_merged_keypoint_sigma_px: expected >= 0 (0: keep each keypoint's)";
  }
  return "";
}

std::string LoopClosureSummary::BriefReport() const {
  std::ostringstream out;
  out << "lc: " << queries << " frames queried, " << verified << " loops verified; rejected: "
      << rejected[0] << " no pose, " << rejected[1] << " too few inliers, " << rejected[2]
      << " too large a correction; " << landmarks_merged << " landmarks merged, "
      << observations_added << " observations added, " << edges_added
      << " loop-closure edges; " << seconds << " s (" << ms_per_query() << " ms per frame)";
  return out.str();
}

std::string LoopClosureSummary::FullReport() const { return BriefReport() + "\n"; }

namespace {

// Landmarks merged away point to the one that absorbed them.
LandmarkId Resolve(const std::unordered_map<LandmarkId, LandmarkId, mapstore::IdHash>& merged,
                   LandmarkId id) {
  for (auto it = merged.find(id); it != merged.end(); it = merged.find(id)) id = it->second;
  return id;
}

bool FrameSees(const VIMap& map, const LandmarkId& landmark, const VertexId& vertex,
               uint32_t camera) {
  for (const LandmarkObservation& o : map.landmark(landmark).observations) {
    if (o.vertex_id == vertex && o.camera == camera) return true;
  }
  return false;
}

// A keypoint joins a landmark of another track: its noise at least `sigma_px` (its position
// agrees with its own track's reference, with the landmark's only up to the detector's noise).
void RaiseKeypointSigma(VIMap* map, const LandmarkObservation& o, double sigma_px) {
  mapstore::Keypoint& k = map->vertex(o.vertex_id).frames[o.camera].keypoints[o.keypoint];
  k.sigma_px = std::max(k.sigma_px, sigma_px);
}

mapstore::IdGenerator EdgeIds(const VIMap& map, const MissionId& mission) {
  uint64_t h = 1469598103934665603ULL;
  for (uint64_t word : {mission.hi, mission.lo, static_cast<uint64_t>(map.edge_ids(mission).size()),
                        uint64_t{0x6c63}}) {
    for (int b = 0; b < 8; ++b) {
      h ^= (word >> (8 * b)) & 0xffu;
      h *= 1099511628211ULL;
    }
  }
  return mapstore::IdGenerator(h);
}

}  // namespace

LoopClosureSummary CloseLoops(const LoopClosureOptions& options, VIMap* map,
                              const std::vector<MissionId>& missions,
                              ProgressObserver* progress) {
  const auto start = std::chrono::steady_clock::now();
  const std::string problem = options.Validate();
  if (!problem.empty()) throw std::invalid_argument("loop closure options: " + problem);
  const std::vector<MissionId> selected = missions.empty() ? map->mission_ids() : missions;
  std::vector<MissionId> known;
  for (const MissionId& m : map->mission_ids()) {
    if (map->mission(m).baseframe_known) known.push_back(m);
  }
  // One database per frame group, built before anything is merged.
  std::map<std::vector<MissionId>, std::shared_ptr<const localizer::Localizer>> databases;
  auto database_of = [&](const MissionId& m) {
    std::vector<MissionId> group = map->mission(m).baseframe_known ? known : std::vector{m};
    auto it = databases.find(group);
    if (it == databases.end()) {
      auto db = std::make_shared<localizer::LocalizationMap>(
          BuildLocalizationMapOfMissions(*map, group, options.localizer.map));
      if (db->num_landmarks() == 0) {
        throw std::invalid_argument("mission " + m.Hex() +
                                    ": no good landmarks to close loops with (run elq?)");
      }
      // Covisibility is filtered after the query's own recent track is dropped (below): before,
      // the largest covisible component would often be that track.
      localizer::LocalizerOptions without_covisibility = options.localizer;
      without_covisibility.matching.covisibility_filter = false;
      it = databases
               .emplace(group, std::make_shared<localizer::Localizer>(db, without_covisibility))
               .first;
    }
    return it->second;
  };
  for (const MissionId& m : selected) database_of(m);

  LoopClosureSummary s;
  std::unordered_map<LandmarkId, LandmarkId, mapstore::IdHash> merged;
  std::size_t total = 0;
  for (const MissionId& m : selected) total += map->vertex_ids(m).size();
  BeginProgress(progress, "lc", total);
  std::size_t done = 0;
  const int64_t gap_ns = static_cast<int64_t>(options.lc_min_time_gap_s * 1e9);
  for (const MissionId& m : selected) {
    const auto db = database_of(m);
    const localizer::LocalizationMap& lmap = db->map();
    const SensorRig& rig = map->mission(m).rig;
    mapstore::IdGenerator edge_ids = EdgeIds(*map, m);
    const std::vector<VertexId> chain = map->VertexChain(m);
    for (std::size_t vi = 0; vi < chain.size(); ++vi) {
      ReportProgress(progress, ++done);
      if (vi % static_cast<std::size_t>(options.lc_every_nth_vertex) != 0) continue;
      const VertexId v = chain[vi];
      const int64_t t_v = map->vertex(v).t_ns;
      for (uint32_t c = 0; c < map->vertex(v).frames.size() && c < rig.cameras.size(); ++c) {
        const mapstore::VisualFrame& frame = map->vertex(v).frames[c];
        if (frame.keypoints.empty() || frame.descriptor_size_bytes != lmap.descriptor_bytes) {
          continue;
        }
        ++s.queries;
        std::vector<Eigen::Vector2d> keypoints;
        keypoints.reserve(frame.keypoints.size());
        for (const mapstore::Keypoint& k : frame.keypoints) keypoints.push_back(k.uv);
        int raw = 0;
        std::vector<localizer::Match2D3D> matches =
            db->Match(keypoints, frame.descriptors.data(), &raw);
        // Not a loop: landmarks whose every observer is this mission within the time gap.
        std::vector<localizer::Match2D3D> kept;
        for (const localizer::Match2D3D& match : matches) {
          bool old = false;
          for (uint32_t i = lmap.observer_begin[match.landmark];
               i < lmap.observer_begin[match.landmark + 1] && !old; ++i) {
            const mapstore::Vertex& w = map->vertex(ToVIMapId(lmap.observers[lmap.observer_index[i]]));
            old = w.mission_id != m || std::llabs(w.t_ns - t_v) > gap_ns;
          }
          if (old) kept.push_back(match);
        }
        if (options.localizer.matching.covisibility_filter && !kept.empty()) {
          std::vector<localizer::Match2D3D> covisible;
          for (int k : localizer::LargestCovisibleComponent(lmap, kept)) {
            covisible.push_back(kept[static_cast<std::size_t>(k)]);
          }
          kept.swap(covisible);
        }
        if (static_cast<int>(kept.size()) < options.lc_min_inliers) {
          ++s.rejected[static_cast<int>(LoopRejection::kNoMatches)];
          continue;
        }
        std::vector<Eigen::Vector2d> uv;
        std::vector<Eigen::Vector3d> p_G;
        for (const localizer::Match2D3D& match : kept) {
          uv.push_back(keypoints[match.keypoint]);
          p_G.push_back(lmap.p_G[match.landmark]);
        }
        const CameraConfig& camera = rig.cameras[c];
        const localizer::PoseResult pose =
            localizer::EstimateCameraPose(camera.camera, uv, p_G, options.localizer.ransac);
        if (pose.status != localizer::PoseStatus::kOk ||
            static_cast<int>(pose.inliers.size()) < options.lc_min_inliers) {
          ++s.rejected[static_cast<int>(pose.status == localizer::PoseStatus::kTooFewInliers ||
                                                pose.status == localizer::PoseStatus::kOk
                                            ? LoopRejection::kTooFewInliers
                                            : LoopRejection::kNoMatches)];
          continue;
        }
        const Transformation T_G_I_loop = pose.T_G_C * camera.T_I_C.inverse();
        const Transformation T_G_I_now = map->T_G_I(v);
        const double correction_m = (T_G_I_loop.translation() - T_G_I_now.translation()).norm();
        const double correction_deg =
            AngleBetween(T_G_I_loop.rotation(), T_G_I_now.rotation()) * 180.0 / M_PI;
        if (correction_m > options.lc_max_correction_m ||
            correction_deg > options.lc_max_correction_deg) {
          ++s.rejected[static_cast<int>(LoopRejection::kTooLargeCorrection)];
          continue;
        }
        ++s.verified;

        // Tie the inlier keypoints to the matched landmarks; count the database observers.
        std::map<VertexId, int> observer_votes;
        for (int inlier : pose.inliers) {
          const localizer::Match2D3D& match = kept[static_cast<std::size_t>(inlier)];
          for (uint32_t i = lmap.observer_begin[match.landmark];
               i < lmap.observer_begin[match.landmark + 1]; ++i) {
            const VertexId w = ToVIMapId(lmap.observers[lmap.observer_index[i]]);
            const mapstore::Vertex& wv = map->vertex(w);
            if (wv.mission_id != m || std::llabs(wv.t_ns - t_v) > gap_ns) ++observer_votes[w];
          }
          const LandmarkId L = Resolve(merged, ToVIMapId(lmap.landmark_ids[match.landmark]));
          if (!map->HasLandmark(L)) continue;
          const LandmarkId Q =
              map->vertex(v).frames[c].landmark_ids[static_cast<std::size_t>(match.keypoint)];
          if (Q == L) continue;
          if (Q.IsValid()) {
            const std::vector<LandmarkObservation> moving = map->landmark(Q).observations;
            for (const LandmarkObservation& o : moving) {
              map->RemoveObservation(Q, o);
              if (!FrameSees(*map, L, o.vertex_id, o.camera)) {
                map->AddObservation(L, o);
                RaiseKeypointSigma(map, o, options.lc_merged_keypoint_sigma_px);
              }
            }
            map->RemoveLandmark(Q);
            merged[Q] = L;
            ++s.landmarks_merged;
          } else if (!FrameSees(*map, L, v, c)) {
            const LandmarkObservation o{v, c, static_cast<uint32_t>(match.keypoint)};
            map->AddObservation(L, o);
            RaiseKeypointSigma(map, o, options.lc_merged_keypoint_sigma_px);
            ++s.observations_added;
          }
        }
        if (!options.lc_add_edges || observer_votes.empty()) continue;
        VertexId best;
        int votes = 0;
        for (const auto& [w, n] : observer_votes) {
          if (n > votes) {
            best = w;
            votes = n;
          }
        }
        mapstore::Edge edge;
        do {
          edge.id = edge_ids.Next();
        } while (map->HasEdge(edge.id) || map->HasVertex(edge.id) || map->HasLandmark(edge.id));
        edge.type = mapstore::EdgeType::kLoopClosure;
        edge.from = v;
        edge.to = best;
        edge.T_A_B = T_G_I_loop.inverse() * map->T_G_I(best);
        // The RANSAC covariance is of the camera pose; moved to the IMU frame (adjoint).
        const Matrix6d Ad = camera.T_I_C.Adjoint();
        edge.covariance = Ad * pose.covariance_C * Ad.transpose();
        map->AddEdge(edge);
        ++s.edges_added;
      }
    }
  }
  s.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  return s;
}

}  // namespace vilma::mapping
