// The map builder (docs/mapping.md), as maplab's ROVIOLI map builder: turns the estimator's
// states, the raw IMU stream and the camera images into a VI-map mission.
//
//   AddImu(sample)       every IMU sample, in time order (duplicates / out of order dropped).
//   AddFrame(state, images)
//                        a synchronized frame with the estimator's state at its time. At most
//                        at options.vertex_rate_hz it becomes a vertex: keyframe features are
//                        extracted per camera and tracked from the previous vertex with the
//                        gyroscope rotation integrated since then; the IMU edge from the
//                        previous vertex carries the raw samples between the two.
//   TakeDelta()          what changed since the last call (the live mission stream).
//   Finish()             triangulates a landmark per track with >= 2 observations, stores it
//                        in its first observing vertex, adds the observations, evaluates the
//                        landmark quality and marks the mission complete. A track longer than
//                        options.max_track_vertices (or max_track_duration_s) is cut into
//                        consecutive segments of that length, a landmark each.
//
// Streaming with bounded memory (MapBuilderMemory::kReleaseAcknowledged, the daemon streaming
// to vilma-mapstored without --save-map; docs/daemon.md "Memory in long missions"): a track
// can only continue from the previous keyframe of its camera, so a track that the newest
// vertex does not continue is closed for good, and a track segment that reaches the length
// limit is closed as well (so that a robot standing still, whose tracks never end, still
// releases its vertices; the track's next observation opens a new segment). Its landmark is triangulated right away, with
// exactly the inputs Finish() would use (its observers' T_M_I and keypoints). A vertex whose
// tracks are all closed is final: compacted as Finish() would, and sent once more in a delta
// with its landmark ids. A landmark goes out with every delta that makes one of its observers
// final, carrying the observations of final vertices only, so that every delta prefix is a
// consistent map on the receiver's side. ReleaseAcknowledged(k) then drops what the receiver
// holds durably (deltas 0..k): edges, landmarks whose observers are all final, and vertices
// whose landmarks are all released. The receiver's mission equals the batch one's but for the
// landmark ids (a generator of their own, so that vertex and edge ids stay the same) and the
// landmarks' order (in the order they were completed instead of by track id).
//
// IMU edges: the edge from vertex a (time t_a) to b (t_b) holds [s(t_a), every raw sample with
// t_a < t < t_b, s(t_b)], where s(t) is the raw sample at t if one has that stamp, else the
// linear interpolation of the two samples around t (core/imu.h InterpolateImu). So every raw
// sample strictly between the first and last vertex is in exactly one edge, and the edges
// cover their vertices' times exactly (CheckMapConsistency). An edge whose end sample has not
// arrived yet stays pending until it does (the IMU may lag the frames); Finish() completes a
// still pending edge by holding the last sample (zero-order hold), and counts it.
//
// Deterministic: the same inputs and mission seed give the same map, ids included.
// Not thread-safe: one thread calls everything (the daemon's map-builder thread).
#pragma once

#include <Eigen/Core>
#include <cstdint>
#include <deque>
#include <map>
#include <memory>
#include <opencv2/core.hpp>
#include <string>
#include <unordered_map>
#include <utility>
#include <vector>

#include "vilma/core/geometry.h"
#include "vilma/core/imu.h"
#include "vilma/core/rig.h"
#include "vilma/localizer/feature_tracker.h"
#include "vilma/mapping/map_builder_options.h"
#include "vilma/mapping/track_refinement.h"
#include "vilma/mapping/triangulation.h"
#include "vilma/mapstore/map_io.h"
#include "vilma/mapstore/vi_map.h"

namespace vilma::mapping {

// The estimator's state at a frame (IMU clock), plain so that this library needs no estimator.
struct FrameState {
  int64_t t_ns = 0;  // state time, IMU clock [ns]
  Transformation T_M_I;
  Eigen::Vector3d v_M = Eigen::Vector3d::Zero();         // [m/s]
  Eigen::Vector3d gyro_bias = Eigen::Vector3d::Zero();   // b_g [rad/s]
  Eigen::Vector3d accel_bias = Eigen::Vector3d::Zero();  // b_a [m/s^2]
};

struct MapBuilderStats {
  int64_t imu_samples = 0;          // accepted
  int64_t imu_dropped = 0;          // duplicate or out-of-order stamps
  int64_t frames = 0;               // AddFrame calls
  int64_t frames_skipped_rate = 0;  // not a vertex because of the vertex rate
  int64_t frames_rejected = 0;      // not increasing in time
  int64_t vertices = 0;
  int64_t imu_edges = 0;            // completed
  int64_t imu_edges_held = 0;       // completed by Finish() with a held last sample
  int64_t keypoints = 0;            // over all vertices and cameras
  int64_t tracked_keypoints = 0;    // keypoints that continue a track
  // options.track_refinement: observations moved to their track's aligned position,
  // alignments that failed and split their track ("split"), and failed ones kept in their track
  // with the detector's sigma ("keep", "reanchor"; track_refinement.h).
  int64_t refined_keypoints = 0;
  int64_t refinement_splits = 0;
  int64_t refinement_kept = 0;
  // The failed alignments (split or kept) per PatchAlignment::Status, and the sum of |aligned -
  // detected| over the aligned observations (how far the refinement moves the detector's
  // keypoints; its mean is in the report) [px].
  int64_t refinement_failed_by_status[PatchAlignment::kNumStatuses] = {};
  double refinement_shift_sum_px = 0.0;
  int64_t tracks = 0;               // tracks with >= 2 observations
  int64_t single_observations = 0;  // tracks seen once (no landmark)
  // Track segments closed at options.max_track_vertices / max_track_duration_s (the track's
  // next observation starts a new landmark).
  int64_t track_cuts = 0;
  int64_t short_tracks = 0;         // compact: tracks below min_observers (no landmark)
  int64_t bad_not_stored = 0;       // compact: bad landmarks not stored (in landmarks_bad)
  int64_t keypoints_dropped = 0;    // compact: keypoints without a landmark removed
  int64_t landmarks = 0;            // stored (good + bad; compact: good only)
  int64_t landmarks_good = 0;
  int64_t landmarks_bad = 0;
  int64_t verdicts[kNumLandmarkVerdicts] = {};  // per LandmarkVerdict (index = enum value)
  int64_t images_kept = 0;       // keep_images: image resources stored
  int64_t image_bytes = 0;       // keep_images: their PNG bytes
  double image_ms_total = 0.0;   // keep_images: time spent encoding them [ms]
  double vertex_ms_total = 0.0;  // time in AddFrame for frames that became vertices [ms]
  double vertex_ms_max = 0.0;
  double finish_ms = 0.0;  // time in Finish() [ms]

  double vertex_ms_mean() const { return vertices > 0 ? vertex_ms_total / vertices : 0.0; }
  // One line: vertices, IMU edges, keypoints, landmarks (good), time per vertex.
  std::string BriefReport() const;
  // Multi-line human-readable summary (each line indented by `indent`; core/report.h's shape).
  std::string FullReport(const std::string& indent = "  ") const;
};

// The vertex-rate rule, the one copy of it (MapBuilder::WantsFrame and the daemon's thinning
// of frames towards its map-builder thread): a frame `dt_ns` after the previous vertex becomes
// a vertex when dt >= 0.9 / vertex_rate_hz (10 % slack for stamp jitter), compared in double
// as dt [ns] >= 0.9e9 / rate; every frame when vertex_rate_hz <= 0.
bool VertexIntervalReached(int64_t dt_ns, double vertex_rate_hz);

// What the builder keeps of the mission (see the header comment).
enum class MapBuilderMemory {
  kWholeMission,         // everything until Finish(); map() is the whole mission
  kReleaseAcknowledged,  // incremental landmarks; acknowledged data is dropped
};

// What the builder holds in memory now (kReleaseAcknowledged: bounded in a long mission).
struct MapBuilderHeld {
  int64_t vertices = 0;
  int64_t edges = 0;
  int64_t landmarks = 0;
  int64_t open_tracks = 0;
  // Estimated heap bytes of those (keypoints, descriptors, ids, IMU samples, observations).
  int64_t bytes = 0;
};

class MapBuilder {
 public:
  // `mission_seed` fixes the mission id (and through IdGenerator::ForMission every object id).
  // Throws InputError for invalid options or a rig / camera list that does not fit.
  MapBuilder(const SensorRig& rig, const MapBuilderOptions& options, uint64_t mission_seed,
             const std::string& mission_name = "",
             MapBuilderMemory memory = MapBuilderMemory::kWholeMission);
  ~MapBuilder();

  void AddImu(const ImuSample& sample);

  // `images`: one per rig camera (an empty cv::Mat: no image of that camera in this frame;
  // cameras not in options.cameras get no features), 8-bit grey. With options.keep_images every
  // image of a frame that becomes a vertex is also stored as a PNG image resource. Returns true
  // when the frame became a vertex. Frames must come in increasing time; others are rejected
  // (counted).
  bool AddFrame(const FrameState& state, const std::vector<cv::Mat>& images);
  // True when a frame at t_ns would become a vertex (so a caller can skip loading or copying
  // images of frames that would be dropped by the vertex rate).
  bool WantsFrame(int64_t t_ns) const;

  // The mission header plus vertices and completed edges new since the last call; after
  // Finish() also the landmarks and the vertices whose landmark ids changed. Deltas carry no
  // resources, so their vertices carry no image ids (keep_images: only map() has the images).
  // kReleaseAcknowledged: also the vertices that became final and their landmarks, as the
  // header comment says; Finish() adds only what was not final yet.
  // Deltas are numbered from 0 in the order taken (delta_count() - 1 is the last one's).
  mapstore::MissionDelta TakeDelta();
  int64_t delta_count() const { return deltas_taken_; }
  // kReleaseAcknowledged: the receiver holds deltas 0..delta_index durably; drops what no
  // later delta and no open track needs. Does nothing in kWholeMission.
  void ReleaseAcknowledged(int64_t delta_index);
  MapBuilderHeld Held() const;
  MapBuilderMemory memory() const { return memory_; }

  // Triangulates and evaluates the landmarks, completes a pending IMU edge, marks the mission
  // complete. Call once; later AddImu/AddFrame calls are ignored.
  const mapstore::VIMap& Finish();

  const mapstore::VIMap& map() const { return map_; }
  // Moves the map out (after Finish()); the builder is then unusable. With
  // kReleaseAcknowledged map() holds only what was not released (not a whole mission).
  mapstore::VIMap ReleaseMap() { return std::move(map_); }
  const mapstore::MissionId& mission_id() const { return mission_id_; }
  const MapBuilderStats& stats() const { return stats_; }
  const MapBuilderOptions& options() const { return options_; }

 private:
  struct PendingEdge {
    mapstore::VertexId from, to;
    int64_t t_from = 0, t_to = 0;
  };
  // Rotation R_Ia_Ib of the IMU between t_a and t_b from the buffered gyroscope (bias removed);
  // the samples beyond the newest one are held.
  Eigen::Quaterniond IntegrateGyro(int64_t t_a, int64_t t_b, const Eigen::Vector3d& b_g) const;
  // Completes pending edges whose end sample has arrived (all of them when `hold_last`).
  void CompletePendingEdges(bool hold_last);
  ImuSample SampleAt(int64_t t_ns) const;
  void TrimImuBuffer();
  // Triangulates one track (observations in vertex order), evaluates it and stores its
  // landmark (ids from `landmark_ids`), as Finish() does for every track. The landmark's id or
  // an invalid id when none is stored.
  mapstore::LandmarkId FinishTrack(const std::vector<mapstore::LandmarkObservation>& observations,
                                   mapstore::IdGenerator* landmark_ids);
  // kReleaseAcknowledged: the tracks of the newest vertex (all when `all`), the tracks it did
  // not continue closed and triangulated, the vertices without an open track made final.
  void UpdateTracks(bool all);
  void MakeFinal(int64_t up_to_index);

  struct OpenTrack {
    int64_t first_index = 0;  // vertex index of the first observation
    int64_t first_t_ns = 0;   // its vertex's time [ns]
    std::vector<mapstore::LandmarkObservation> observations;
  };
  struct HeldVertex {
    mapstore::VertexId id;
    int64_t index = 0;
    bool final = false;
    int64_t final_delta = -1;  // the delta that carries its final form
    int open_landmarks = 0;    // landmarks it observes that are not released
  };
  struct HeldLandmark {
    int pending_observers = 0;   // observer vertices not final yet
    int64_t complete_delta = -1;  // the delta that carries it with every observation
  };
  HeldVertex& held_by_id(const mapstore::VertexId& id);
  bool IsFinal(const mapstore::VertexId& id) const;  // released vertices are final

  SensorRig rig_;
  MapBuilderOptions options_;
  std::vector<int> cameras_;  // rig camera indices with features
  mapstore::MissionId mission_id_;
  mapstore::IdGenerator ids_;
  mapstore::VIMap map_;
  std::vector<std::unique_ptr<localizer::FeatureTracker>> trackers_;  // per rig camera
  std::vector<std::unique_ptr<TrackRefiner>> refiners_;  // per rig camera, next to trackers_
  std::vector<RefinedKeypoint> refined_kinds_;  // Refine's output, reused across frames

  std::deque<ImuSample> imu_;  // from the last sample at or before the oldest needed time
  bool has_vertex_ = false;
  mapstore::VertexId last_vertex_id_;
  int64_t last_vertex_t_ns_ = 0;
  int64_t last_frame_t_ns_ = 0;
  bool has_frame_ = false;
  std::deque<PendingEdge> pending_edges_;
  bool finished_ = false;

  // Delta bookkeeping (ids in creation order).
  std::vector<mapstore::VertexId> delta_vertices_;
  std::vector<mapstore::EdgeId> delta_edges_;
  std::vector<mapstore::LandmarkId> delta_landmarks_;
  int64_t deltas_taken_ = 0;

  // kReleaseAcknowledged bookkeeping.
  MapBuilderMemory memory_ = MapBuilderMemory::kWholeMission;
  mapstore::IdGenerator landmark_ids_;
  std::map<int64_t, OpenTrack> open_tracks_;  // by track id
  int64_t next_vertex_index_ = 0;
  int64_t final_frontier_ = 0;      // vertices with a lower index are final
  std::deque<HeldVertex> held_;     // vertices in map_, in index order
  std::unordered_map<mapstore::Id, int64_t, mapstore::IdHash> held_index_;  // id -> index
  std::unordered_map<mapstore::Id, HeldLandmark, mapstore::IdHash> held_landmarks_;
  std::vector<mapstore::VertexId> delta_final_vertices_;  // made final since the last delta
  std::deque<std::pair<mapstore::EdgeId, int64_t>> sent_edges_;  // edge, its delta
  std::deque<std::pair<mapstore::LandmarkId, int64_t>> complete_landmarks_;  // id, its delta
  std::vector<mapstore::LandmarkId> completed_since_delta_;

  MapBuilderStats stats_;
};

}  // namespace vilma::mapping
