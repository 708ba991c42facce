#include "vilma/mapping/map_builder.h"

#include <algorithm>
#include <cctype>
#include <chrono>
#include <cstring>
#include <iomanip>
#include <map>
#include <sstream>
#include <stdexcept>

#include "vilma/core/error.h"
#include "vilma/core/timing.h"
#include "vilma/mapping/image_resources.h"
#include "vilma/mapstore/compaction.h"

namespace vilma::mapping {
namespace {

using mapstore::Id;
using mapstore::VertexId;

std::string Upper(std::string s) {
  for (char& c : s) c = static_cast<char>(std::toupper(static_cast<unsigned char>(c)));
  return s;
}

// Track ids of camera c start at c * 2^40, so the trackers of a rig never share an id; the
// ids of split tracks (track refinement) at c * 2^40 + 2^39.
constexpr int64_t kTrackIdsPerCamera = int64_t{1} << 40;
constexpr int64_t kSplitTrackIdOffset = int64_t{1} << 39;

}  // namespace

std::string MapBuilderStats::BriefReport() const {
  std::ostringstream s;
  s << std::fixed << std::setprecision(2) << vertices << " vertices, " << imu_edges
    << " IMU edges, " << keypoints << " keypoints, " << landmarks << " landmarks ("
    << landmarks_good << " good), " << vertex_ms_mean() << " ms per vertex";
  return s.str();
}

std::string MapBuilderStats::FullReport(const std::string& indent) const {
  std::ostringstream s;
  s << std::fixed << std::setprecision(2);
  s << indent << "frames           " << frames << " (" << frames_skipped_rate
    << " skipped by the vertex rate, " << frames_rejected << " out of order)\n"
    << indent << "vertices         " << vertices << "\n"
    << indent << "IMU edges        " << imu_edges << " (" << imu_samples << " samples, "
    << imu_dropped << " dropped, " << imu_edges_held << " edges ended by a held sample)\n"
    << indent << "keypoints        " << keypoints << " (" << tracked_keypoints
    << " continue a track)\n";
  if (refined_keypoints > 0 || refinement_splits > 0 || refinement_kept > 0) {
    s << indent << "track refinement " << refined_keypoints << " observations aligned to their "
      << "track's first, " << refinement_splits << " tracks split, " << refinement_kept
      << " failed alignments kept in their track\n";
    s << indent << "                 mean |aligned - detected| "
      << (refined_keypoints > 0
              ? refinement_shift_sum_px / static_cast<double>(refined_keypoints)
              : 0.0)
      << " px";
    const char* separator = "; failed: ";
    for (int k = 0; k < PatchAlignment::kNumStatuses; ++k) {
      if (refinement_failed_by_status[k] == 0) continue;
      s << separator << refinement_failed_by_status[k] << " "
        << PatchAlignmentStatusName(static_cast<PatchAlignment::Status>(k));
      separator = ", ";
    }
    s << "\n";
  }
  s
    << indent << "tracks           " << tracks << " with >= 2 observations, " << single_observations
    << " seen once";
  if (track_cuts > 0) s << ", " << track_cuts << " cut at the length limit";
  if (short_tracks > 0 || keypoints_dropped > 0) {
    s << "; compact: " << short_tracks << " shorter than min_observers and " << bad_not_stored
      << " bad without a landmark, " << keypoints_dropped << " keypoints without a landmark "
      << "dropped";
  }
  s << "\n"
    << indent << "landmarks        " << landmarks << ": " << landmarks_good << " good, "
    << landmarks_bad << " bad";
  bool first = true;
  for (int v = 1; v < kNumLandmarkVerdicts; ++v) {
    if (verdicts[v] == 0) continue;
    s << (first ? " (" : ", ") << LandmarkVerdictName(static_cast<LandmarkVerdict>(v)) << " "
      << verdicts[v];
    first = false;
  }
  if (!first) s << ")";
  s << "\n";
  if (images_kept > 0) {
    s << indent << "images kept      " << images_kept << " (" << image_bytes / 1e6 << " MB PNG, "
      << image_ms_total / static_cast<double>(images_kept) << " ms/image to encode)\n";
  }
  s
    << indent << "builder time     " << vertex_ms_mean() << " ms/vertex mean, " << vertex_ms_max
    << " max; finish " << finish_ms << " ms\n";
  return s.str();
}

MapBuilder::MapBuilder(const SensorRig& rig, const MapBuilderOptions& options,
                       uint64_t mission_seed, const std::string& mission_name,
                       MapBuilderMemory memory)
    : rig_(rig), options_(options), ids_(0), memory_(memory), landmark_ids_(0) {
  ThrowIfInvalid(options_.Validate(), "map builder options");
  if (memory_ == MapBuilderMemory::kReleaseAcknowledged && options_.keep_images) {
    // Images are resources, which deltas do not carry: released vertices would lose them.
    throw InputError(FormatInputError("map builder options", "keep_images",
                                      "false when acknowledged data is released (streaming "
                                      "without a local copy: the stream carries no images)"));
  }
  if (rig_.cameras.empty()) {
    throw InputError(FormatInputError("rig", "cameras", "at least one camera"));
  }
  if (options_.cameras.empty()) {
    for (std::size_t c = 0; c < rig_.cameras.size(); ++c) cameras_.push_back(static_cast<int>(c));
  } else {
    cameras_ = options_.cameras;
  }
  trackers_.resize(rig_.cameras.size());
  refiners_.resize(rig_.cameras.size());
  for (int c : cameras_) {
    if (c >= static_cast<int>(rig_.cameras.size())) {
      throw InputError(FormatInputError(
          "map builder options", "cameras",
          "indices of rig cameras (the rig has " + std::to_string(rig_.cameras.size()) + ")"));
    }
    trackers_[static_cast<std::size_t>(c)] = std::make_unique<localizer::FeatureTracker>(
        options_.features, static_cast<int64_t>(c) * kTrackIdsPerCamera);
    refiners_[static_cast<std::size_t>(c)] = std::make_unique<TrackRefiner>(
        options_.track_refinement, static_cast<int64_t>(c) * kTrackIdsPerCamera + kSplitTrackIdOffset);
  }
  mapstore::IdGenerator mission_ids(mission_seed);
  mission_id_ = mission_ids.Next();
  ids_ = mapstore::IdGenerator::ForMission(mission_id_);
  // Landmark ids of the incremental mode from a stream of their own, so that the vertex and
  // edge ids (drawn from ids_ as objects are made) stay those of the whole-mission mode.
  mapstore::IdGenerator mixer(mission_id_.lo ^ 0xBB67AE8584CAA73BULL);
  landmark_ids_ = mapstore::IdGenerator(mixer.Next().hi ^ mission_id_.hi);
  mapstore::Mission mission;
  mission.id = mission_id_;
  mission.name = mission_name;
  mission.rig = rig_;
  mission.complete = false;
  map_.AddMission(mission);
}

MapBuilder::~MapBuilder() = default;

void MapBuilder::AddImu(const ImuSample& sample) {
  if (finished_) return;
  if (!imu_.empty() && sample.t_ns <= imu_.back().t_ns) {
    ++stats_.imu_dropped;
    return;
  }
  imu_.push_back(sample);
  ++stats_.imu_samples;
  CompletePendingEdges(false);
  TrimImuBuffer();
}

void MapBuilder::TrimImuBuffer() {
  // Oldest time still needed: the start of the oldest pending edge, else the last vertex
  // (start of the next edge and of the next gyro integration), else the last frame (no vertex
  // can come earlier), else 2 s of history.
  int64_t t_keep;
  if (!pending_edges_.empty()) {
    t_keep = pending_edges_.front().t_from;
  } else if (has_vertex_) {
    t_keep = last_vertex_t_ns_;
  } else if (has_frame_) {
    t_keep = last_frame_t_ns_;
  } else {
    t_keep = imu_.empty() ? 0 : imu_.back().t_ns - 2'000'000'000;
  }
  // Keep the last sample at or before t_keep (for interpolation at t_keep).
  while (imu_.size() >= 2 && imu_[1].t_ns <= t_keep) imu_.pop_front();
}

ImuSample MapBuilder::SampleAt(int64_t t_ns) const {
  if (imu_.empty()) {
    ImuSample s;
    s.t_ns = t_ns;
    return s;
  }
  if (t_ns <= imu_.front().t_ns) {
    ImuSample s = imu_.front();
    s.t_ns = t_ns;  // equal stamps: the raw sample; earlier: held (no data before)
    return s;
  }
  if (t_ns >= imu_.back().t_ns) {
    ImuSample s = imu_.back();
    s.t_ns = t_ns;  // equal: the raw sample; later: zero-order hold (only with hold_last)
    return s;
  }
  const auto it = std::lower_bound(imu_.begin(), imu_.end(), t_ns,
                                   [](const ImuSample& s, int64_t t) { return s.t_ns < t; });
  if (it->t_ns == t_ns) return *it;
  return InterpolateImu(*(it - 1), *it, t_ns);
}

void MapBuilder::CompletePendingEdges(bool hold_last) {
  while (!pending_edges_.empty()) {
    const PendingEdge& p = pending_edges_.front();
    const bool end_arrived = !imu_.empty() && imu_.back().t_ns >= p.t_to;
    if (!end_arrived && !hold_last) break;
    mapstore::Edge edge;
    edge.id = ids_.Next();
    edge.type = mapstore::EdgeType::kImu;
    edge.from = p.from;
    edge.to = p.to;
    if (!imu_.empty()) {
      edge.imu_samples.push_back(SampleAt(p.t_from));
      for (const ImuSample& s : imu_) {
        if (s.t_ns > p.t_from && s.t_ns < p.t_to) edge.imu_samples.push_back(s);
      }
      edge.imu_samples.push_back(SampleAt(p.t_to));
    }
    if (!end_arrived) ++stats_.imu_edges_held;
    delta_edges_.push_back(edge.id);
    map_.AddEdge(std::move(edge));
    ++stats_.imu_edges;
    pending_edges_.pop_front();
  }
}

Eigen::Quaterniond MapBuilder::IntegrateGyro(int64_t t_a, int64_t t_b,
                                             const Eigen::Vector3d& b_g) const {
  // R_Ia_Ib = prod_k Exp((omega_mid,k - b_g) dt_k) over the sub-intervals cut at the sample
  // times, omega_mid the mean of the linearly interpolated rates at the sub-interval ends
  // (trapezoidal rule, second order like the midpoint of the piecewise-linear signal).
  Eigen::Quaterniond q = Eigen::Quaterniond::Identity();
  if (imu_.empty() || t_b <= t_a) return q;
  std::vector<int64_t> cuts;
  cuts.push_back(t_a);
  for (const ImuSample& s : imu_) {
    if (s.t_ns > t_a && s.t_ns < t_b) cuts.push_back(s.t_ns);
  }
  cuts.push_back(t_b);
  Eigen::Vector3d omega0 = SampleAt(cuts[0]).omega_I;
  for (std::size_t k = 1; k < cuts.size(); ++k) {
    const Eigen::Vector3d omega1 = SampleAt(cuts[k]).omega_I;
    const double dt = static_cast<double>(cuts[k] - cuts[k - 1]) * 1e-9;
    q = q * ExpSO3((0.5 * (omega0 + omega1) - b_g) * dt);
    omega0 = omega1;
  }
  return q.normalized();
}

bool VertexIntervalReached(int64_t dt_ns, double vertex_rate_hz) {
  if (vertex_rate_hz <= 0.0) return true;
  return static_cast<double>(dt_ns) >= 0.9e9 / vertex_rate_hz;
}

bool MapBuilder::WantsFrame(int64_t t_ns) const {
  if (finished_ || (has_frame_ && t_ns <= last_frame_t_ns_)) return false;
  return !has_vertex_ || VertexIntervalReached(t_ns - last_vertex_t_ns_, options_.vertex_rate_hz);
}

bool MapBuilder::AddFrame(const FrameState& state, const std::vector<cv::Mat>& images) {
  if (finished_) return false;
  ++stats_.frames;
  if (has_frame_ && state.t_ns <= last_frame_t_ns_) {
    ++stats_.frames_rejected;
    return false;
  }
  if (!WantsFrame(state.t_ns)) {
    ++stats_.frames_skipped_rate;
    has_frame_ = true;
    last_frame_t_ns_ = state.t_ns;
    TrimImuBuffer();
    return false;
  }
  has_frame_ = true;
  last_frame_t_ns_ = state.t_ns;
  const auto t0 = std::chrono::steady_clock::now();

  mapstore::Vertex vertex;
  vertex.id = ids_.Next();
  vertex.mission_id = mission_id_;
  vertex.t_ns = state.t_ns;
  vertex.T_M_I = state.T_M_I;
  vertex.v_M = state.v_M;
  vertex.accel_bias = state.accel_bias;
  vertex.gyro_bias = state.gyro_bias;
  vertex.frames.resize(rig_.cameras.size());

  // Gyroscope rotation since the previous vertex, for the trackers' search windows.
  const Eigen::Quaterniond q_Ia_Ib =
      has_vertex_ ? IntegrateGyro(last_vertex_t_ns_, state.t_ns, state.gyro_bias)
                  : Eigen::Quaterniond::Identity();
  for (int c : cameras_) {
    const std::size_t ci = static_cast<std::size_t>(c);
    localizer::FeatureTracker& tracker = *trackers_[ci];
    const cv::Mat* image = ci < images.size() && !images[ci].empty() ? &images[ci] : nullptr;
    if (image == nullptr) {
      // No image of this camera: its tracks end here (the next keyframe would be matched
      // against an older one with the wrong rotation).
      tracker.Reset();
      refiners_[ci]->Reset();
      continue;
    }
    const CameraConfig& cam = rig_.cameras[ci];
    // R_Ckm1_Ck = R_C_I R_Ikm1_Ik R_I_C; the tracker wants q_Ck_Ckm1.
    const Eigen::Quaterniond q_I_C = cam.T_I_C.rotation();
    const Eigen::Quaterniond q_Ck_Ckm1 = (q_I_C.conjugate() * q_Ia_Ib * q_I_C).conjugate();
    const localizer::TrackingResult r = tracker.Track(*image, cam.camera, q_Ck_Ckm1);

    mapstore::VisualFrame& frame = vertex.frames[ci];
    const std::size_t n = r.features.keypoints.size();
    frame.descriptor_type = Upper(r.features.descriptor_type);
    frame.descriptor_size_bytes = static_cast<uint32_t>(r.features.descriptors.cols);
    frame.keypoints.resize(n);
    frame.descriptors.resize(n * frame.descriptor_size_bytes);
    for (std::size_t k = 0; k < n; ++k) {
      const cv::KeyPoint& kp = r.features.keypoints[k];
      mapstore::Keypoint& out = frame.keypoints[k];
      out.uv = Eigen::Vector2d(kp.pt.x, kp.pt.y);
      out.scale = kp.size;
      out.orientation = kp.angle * M_PI / 180.0;
      out.score = kp.response;
      out.sigma_px = options_.triangulation.keypoint_sigma_px;
      std::memcpy(frame.descriptors.data() + k * frame.descriptor_size_bytes,
                  r.features.descriptors.ptr<uint8_t>(static_cast<int>(k)),
                  frame.descriptor_size_bytes);
    }
    if (options_.track_refinement.enabled()) {
      TrackRefiner& refiner = *refiners_[ci];
      std::vector<Eigen::Vector2d> uv(n);
      for (std::size_t k = 0; k < n; ++k) uv[k] = frame.keypoints[k].uv;
      const TrackRefinementStats before = refiner.stats();
      refiner.Refine(*image, r.track_ids, &uv, &frame.track_ids, &refined_kinds_);
      // Keypoints aligned to their track's template, and templates (a track's first): the
      // refinement's noise; kept in their track without alignment: the detector's.
      for (std::size_t k = 0; k < n; ++k) {
        frame.keypoints[k].uv = uv[k];
        frame.keypoints[k].sigma_px = refined_kinds_[k] == RefinedKeypoint::kUnaligned
                                          ? options_.triangulation.keypoint_sigma_px
                                          : options_.track_refinement.keypoint_sigma_px;
      }
      stats_.refined_keypoints += refiner.stats().refined - before.refined;
      stats_.refinement_splits += refiner.stats().splits - before.splits;
      stats_.refinement_kept += refiner.stats().kept - before.kept;
      stats_.refinement_shift_sum_px += refiner.stats().shift_sum_px - before.shift_sum_px;
      for (int k = 0; k < PatchAlignment::kNumStatuses; ++k) {
        stats_.refinement_failed_by_status[k] +=
            refiner.stats().failed_by_status[k] - before.failed_by_status[k];
      }
    } else {
      frame.track_ids = r.track_ids;
    }
    frame.landmark_ids.assign(n, mapstore::LandmarkId());
    stats_.keypoints += static_cast<int64_t>(n);
    stats_.tracked_keypoints += r.num_matched;
  }

  if (options_.keep_images) {
    // Every image of the vertex, also of cameras without features (dense reconstruction wants
    // the stereo partner). Encoding copies, so the caller may reuse its buffers.
    const auto ti = std::chrono::steady_clock::now();
    for (std::size_t ci = 0; ci < vertex.frames.size() && ci < images.size(); ++ci) {
      if (images[ci].empty()) continue;
      const mapstore::ResourceId rid = ImageResourceId(vertex.id, static_cast<uint32_t>(ci));
      std::string png = EncodeImagePng(images[ci]);
      stats_.image_bytes += static_cast<int64_t>(png.size());
      map_.resources().Add(mapstore::ResourceType::kImage, rid, "png", std::move(png));
      vertex.frames[ci].image_resource_id = rid;
      ++stats_.images_kept;
    }
    stats_.image_ms_total += MsSince(ti);
  }

  const VertexId id = vertex.id;
  map_.AddVertex(std::move(vertex));
  delta_vertices_.push_back(id);
  if (!has_vertex_) {
    map_.mission(mission_id_).root_vertex_id = id;
  } else {
    pending_edges_.push_back({last_vertex_id_, id, last_vertex_t_ns_, state.t_ns});
  }
  has_vertex_ = true;
  last_vertex_id_ = id;
  last_vertex_t_ns_ = state.t_ns;
  ++stats_.vertices;
  CompletePendingEdges(false);
  TrimImuBuffer();
  if (memory_ == MapBuilderMemory::kReleaseAcknowledged) {
    held_index_.emplace(id, next_vertex_index_);
    held_.push_back({id, next_vertex_index_++});
    UpdateTracks(false);
  }
  const double ms = MsSince(t0);
  stats_.vertex_ms_total += ms;
  stats_.vertex_ms_max = std::max(stats_.vertex_ms_max, ms);
  return true;
}

mapstore::LandmarkId MapBuilder::FinishTrack(
    const std::vector<mapstore::LandmarkObservation>& observations,
    mapstore::IdGenerator* landmark_ids) {
  if (observations.size() < 2) {
    ++stats_.single_observations;
    return {};
  }
  // Compact maps: such a track's landmark would be bad (too few observers) for good.
  if (!options_.StoresShortTracks() &&
      observations.size() < static_cast<std::size_t>(options_.landmark_quality.min_observers)) {
    ++stats_.short_tracks;
    return {};
  }
  ++stats_.tracks;
  std::vector<TriangulationObservation> obs;
  obs.reserve(observations.size());
  for (const mapstore::LandmarkObservation& o : observations) {
    const mapstore::Vertex& v = map_.vertex(o.vertex_id);
    const CameraConfig& cam = rig_.cameras[o.camera];
    TriangulationObservation t;
    t.T_M_C = v.T_M_I * cam.T_I_C;
    t.camera = &cam.camera;
    t.uv = v.frames[o.camera].keypoints[o.keypoint].uv;
    t.sigma_px = v.frames[o.camera].keypoints[o.keypoint].sigma_px;
    obs.push_back(t);
  }
  const TriangulationResult result = Triangulate(obs, options_.triangulation);
  const LandmarkVerdict verdict = EvaluateLandmarkQuality(obs, result, options_.landmark_quality);
  ++stats_.verdicts[static_cast<int>(verdict)];
  // Without a position there is nothing to store (the track's keypoints stay landmark-free).
  if (!result.ok()) return {};
  // Compact maps store the good landmarks only (what localization and optimization use).
  if (!options_.StoresBadLandmarks() && verdict != LandmarkVerdict::kGood) {
    ++stats_.landmarks_bad;
    ++stats_.bad_not_stored;
    return {};
  }

  mapstore::Landmark landmark;
  landmark.id = landmark_ids->Next();
  landmark.store_vertex_id = observations.front().vertex_id;
  const Transformation& T_M_I = map_.vertex(landmark.store_vertex_id).T_M_I;
  landmark.p_I = T_M_I.inverse() * result.p_M;
  const Eigen::Matrix3d R_I_M = T_M_I.rotation().toRotationMatrix().transpose();
  landmark.covariance = R_I_M * result.covariance_M * R_I_M.transpose();
  landmark.quality = verdict == LandmarkVerdict::kGood ? mapstore::LandmarkQuality::kGood
                                                       : mapstore::LandmarkQuality::kBad;
  const mapstore::LandmarkId lid = landmark.id;
  map_.AddLandmark(std::move(landmark));
  for (const mapstore::LandmarkObservation& o : observations) map_.AddObservation(lid, o);
  ++stats_.landmarks;
  if (verdict == LandmarkVerdict::kGood) {
    ++stats_.landmarks_good;
  } else {
    ++stats_.landmarks_bad;
  }
  return lid;
}

const mapstore::VIMap& MapBuilder::Finish() {
  if (finished_) return map_;
  const auto t0 = std::chrono::steady_clock::now();
  CompletePendingEdges(true);
  finished_ = true;

  if (memory_ == MapBuilderMemory::kReleaseAcknowledged) {
    // Every track ends here; the vertices not final yet become final (only they go out).
    UpdateTracks(true);
  } else {
    // Observations per track, ordered by track id (deterministic), each in vertex order.
    std::map<int64_t, std::vector<mapstore::LandmarkObservation>> tracks;
    for (const VertexId& vid : map_.vertex_ids(mission_id_)) {
      const mapstore::Vertex& v = map_.vertex(vid);
      for (std::size_t c = 0; c < v.frames.size(); ++c) {
        const mapstore::VisualFrame& f = v.frames[c];
        for (std::size_t k = 0; k < f.track_ids.size(); ++k) {
          if (f.track_ids[k] < 0) continue;
          tracks[f.track_ids[k]].push_back(
              {vid, static_cast<uint32_t>(c), static_cast<uint32_t>(k)});
        }
      }
    }
    // Each track cut into consecutive segments at the length limit, as the incremental mode
    // closes them while they grow (MapBuilderOptions::TrackSegmentFull).
    std::vector<mapstore::LandmarkObservation> segment;
    const auto finish_segment = [&] {
      const mapstore::LandmarkId lid = FinishTrack(segment, &ids_);
      if (lid.IsValid()) delta_landmarks_.push_back(lid);
      segment.clear();
    };
    for (const auto& [track_id, observations] : tracks) {
      (void)track_id;
      int64_t t_first_ns = 0;
      for (const mapstore::LandmarkObservation& o : observations) {
        const int64_t t_ns = map_.vertex(o.vertex_id).t_ns;
        if (segment.empty()) t_first_ns = t_ns;
        segment.push_back(o);
        if (options_.TrackSegmentFull(segment.size(), t_first_ns, t_ns)) {
          ++stats_.track_cuts;
          finish_segment();
        }
      }
      if (!segment.empty()) finish_segment();
    }
    if (options_.compact != "none") {
      const mapstore::KeypointCompactionStats compaction =
          mapstore::RemoveKeypointsWithoutLandmark(&map_, map_.vertex_ids(mission_id_));
      stats_.keypoints_dropped = static_cast<int64_t>(compaction.keypoints_before -
                                                      compaction.keypoints_after);
    }
    // Every vertex may have new landmark ids (and, compact, fewer keypoints): the next delta
    // re-sends them all.
    for (const VertexId& vid : map_.vertex_ids(mission_id_)) delta_vertices_.push_back(vid);
  }
  map_.mission(mission_id_).complete = true;
  imu_.clear();
  stats_.finish_ms = MsSince(t0);
  return map_;
}

void MapBuilder::UpdateTracks(bool all) {
  const VertexId newest = held_.empty() ? VertexId() : held_.back().id;
  if (!all && !held_.empty()) {
    const HeldVertex& hv = held_.back();
    const mapstore::Vertex& v = map_.vertex(hv.id);
    for (std::size_t c = 0; c < v.frames.size(); ++c) {
      const mapstore::VisualFrame& f = v.frames[c];
      for (std::size_t k = 0; k < f.track_ids.size(); ++k) {
        if (f.track_ids[k] < 0) continue;
        auto [it, inserted] = open_tracks_.try_emplace(f.track_ids[k]);
        if (inserted) {
          it->second.first_index = hv.index;
          it->second.first_t_ns = v.t_ns;
        }
        it->second.observations.push_back(
            {hv.id, static_cast<uint32_t>(c), static_cast<uint32_t>(k)});
      }
    }
  }
  // A track the newest vertex did not continue never continues (the trackers match against
  // the previous keyframe only, and ids are never reused): its landmark is made now, in
  // track-id order as Finish() would. A continued one whose segment reached the length limit
  // is closed too: the track's next observation opens a new segment (try_emplace above), as
  // Finish() of the whole mission cuts it.
  const int64_t newest_t_ns = held_.empty() ? 0 : map_.vertex(newest).t_ns;
  for (auto it = open_tracks_.begin(); it != open_tracks_.end();) {
    if (!all && it->second.observations.back().vertex_id == newest) {
      if (!options_.TrackSegmentFull(it->second.observations.size(), it->second.first_t_ns,
                                     newest_t_ns)) {
        ++it;
        continue;
      }
      ++stats_.track_cuts;
    }
    const mapstore::LandmarkId lid = FinishTrack(it->second.observations, &landmark_ids_);
    if (lid.IsValid()) {
      HeldLandmark& h = held_landmarks_[lid];
      h.pending_observers = static_cast<int>(it->second.observations.size());
      for (const mapstore::LandmarkObservation& o : it->second.observations) {
        ++held_by_id(o.vertex_id).open_landmarks;
      }
    }
    it = open_tracks_.erase(it);
  }
  // Tracks span consecutive vertices, so a vertex has an open track iff its index is at or
  // after the first vertex of the oldest open track.
  int64_t frontier = next_vertex_index_;
  for (const auto& [track_id, track] : open_tracks_) {
    (void)track_id;
    frontier = std::min(frontier, track.first_index);
  }
  MakeFinal(frontier);
}

}  // namespace vilma::mapping
