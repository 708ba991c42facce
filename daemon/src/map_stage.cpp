#include "map_stage.h"

#include <chrono>
#include <cstdio>
#include <filesystem>
#include <random>
#include <sstream>

#include "vilma/core/error.h"
#include "vilma/core/time.h"
#include "vilma/mapstore/delta_split.h"

namespace vilma::daemon {
namespace {

void AddStreamCounters(const mapstore::MissionStreamSenderCounters& c,
                       mapstore::MissionStreamSenderCounters* sum) {
  sum->sent += c.sent;
  sum->retransmitted += c.retransmitted;
  sum->acked += c.acked;
  sum->window_full += c.window_full;
  sum->disk_full_acks += c.disk_full_acks;
  sum->error_acks += c.error_acks;
  sum->ignored_acks += c.ignored_acks;
  sum->bytes_sent += c.bytes_sent;
}

// Adds the counters of a mission that ended to the run's (what VILMA_STATUS reports).
void AddBuilderStats(const mapping::MapBuilderStats& b, mapping::MapBuilderStats* sum) {
  sum->vertices += b.vertices;
  sum->imu_edges += b.imu_edges;
  sum->keypoints += b.keypoints;
  sum->landmarks += b.landmarks;
  sum->landmarks_good += b.landmarks_good;
  sum->vertex_ms_total += b.vertex_ms_total;
  sum->vertex_ms_max = std::max(sum->vertex_ms_max, b.vertex_ms_max);
  sum->finish_ms += b.finish_ms;
}

// The whole of one mission of `map` as a delta (mission, vertices, edges, landmarks in their
// insertion order), to gather the missions of a run into one map.
mapstore::MissionDelta WholeMission(const mapstore::VIMap& map, const mapstore::MissionId& id) {
  mapstore::MissionDelta d;
  d.mission = map.mission(id);
  for (const mapstore::VertexId& v : map.vertex_ids(id)) d.vertices.push_back(map.vertex(v));
  for (const mapstore::EdgeId& e : map.edge_ids(id)) d.edges.push_back(map.edge(e));
  for (const mapstore::LandmarkId& l : map.landmark_ids(id)) d.landmarks.push_back(map.landmark(l));
  return d;
}

}  // namespace

MapStage::MapStage(const MapStageOptions& options, const SensorRig& rig, Pipeline* pipeline,
                   const TransportFactory& open_transport)
    : options_(options), rig_(rig), p_(*pipeline) {
  const MappingOptions& m = options_.mapping;
  const int num_cameras = options_.num_cameras;
  if (num_cameras > kMaxMapCameras) {
    throw InputError(FormatInputError("daemon options", "mapping.enabled",
                                      "at most " + std::to_string(kMaxMapCameras) +
                                          " cameras in channels.cameras with map building"));
  }
  builder_options_ = m.map_builder;
  if (builder_options_.cameras.empty()) {
    // Features in every camera the daemon subscribes to (not the rig's others: no images).
    for (int c = 0; c < num_cameras; ++c) builder_options_.cameras.push_back(c);
  }
  for (int c : builder_options_.cameras) {
    if (c < 0 || c >= num_cameras) {
      throw InputError(FormatInputError(
          "daemon options", "mapping.map_builder.cameras",
          "camera indices below " + std::to_string(num_cameras) + " (the subscribed cameras)"));
    }
  }
  if (!m.save_dir.empty()) {
    // Checked now rather than after an hour of mapping: the folder must not hold a map
    // (saving would replace it), and must be creatable.
    namespace fs = std::filesystem;
    std::error_code ec;
    if (fs::exists(m.save_dir, ec) &&
        (!fs::is_directory(m.save_dir, ec) || !fs::is_empty(m.save_dir, ec))) {
      throw InputError(FormatInputError(m.save_dir, "mapping.save_dir / --save-map",
                                        "a folder that does not exist yet or is empty"));
    }
    fs::create_directories(m.save_dir, ec);
    if (ec) {
      throw InputError(FormatInputError(m.save_dir, "mapping.save_dir / --save-map",
                                        "a folder that can be created (" + ec.message() + ")"));
    }
  }
  uint64_t seed = m.mission_seed;
  if (seed == 0) {
    if (!options_.input_log.empty()) {
      // From the log's content: the same log gives the same ids, two sessions' logs give
      // missions that can be merged (distinct ids).
      seed = mapstore::SeedFromFileContent(options_.input_log);
    } else {
      std::random_device device;
      seed = (static_cast<uint64_t>(device()) << 32) ^ device();
      if (seed == 0) seed = 1;
    }
  }
  mission_seed_base_ = seed;
  // Streaming without a local copy: mapstored's journal holds what it acknowledged, so the
  // builder keeps only what it still needs (a long mission's memory stays bounded). A local
  // copy (--save-map) needs the whole mission in memory, as before.
  if (m.stream.enabled && m.save_dir.empty()) {
    builder_memory_ = mapping::MapBuilderMemory::kReleaseAcknowledged;
    if (builder_options_.keep_images) {
      throw InputError(FormatInputError(
          "daemon options", "mapping.map_builder.keep_images",
          "false when streaming without mapping.save_dir / --save-map (the stream carries no "
          "images; keep them in a local copy)"));
    }
  }
  builder_ = std::make_unique<mapping::MapBuilder>(rig, builder_options_, MissionSeed(0),
                                                   MissionName(0), builder_memory_);
  p_.counters.Add(kMapMissions);
  queue_ = std::make_unique<Spsc<MapItem>>(static_cast<std::size_t>(m.queue_capacity));
  if (m.stream.enabled) {
    transport_ = open_transport();
    stream_ = transport_->MakeSender(builder_->mission_id(), MissionName(0));
  }
}

MapStage::~MapStage() = default;

// Mission 0 keeps the configured seed (the ids of a run without resets are unchanged); mission
// k > 0 gets a seed mixed from it and k (splitmix64's finalizer), so ids stay deterministic
// with --input-log and the missions of one run never share ids.
uint64_t MapStage::MissionSeed(int k) const {
  if (k == 0) return mission_seed_base_;
  uint64_t z = mission_seed_base_ + 0x9E3779B97F4A7C15ULL * static_cast<uint64_t>(k);
  z = (z ^ (z >> 30)) * 0xBF58476D1CE4E5B9ULL;
  z = (z ^ (z >> 27)) * 0x94D049BB133111EBULL;
  z ^= z >> 31;
  return z == 0 ? 1 : z;
}

// "<mission_name>-<k>" after a reset; "" stays "" (mapstored then names the folder by the id).
std::string MapStage::MissionName(int k) const {
  const std::string& name = options_.mapping.mission_name;
  if (k == 0 || name.empty()) return name;
  return name + "-" + std::to_string(k);
}

// VILMA_STATUS map counters: the missions that ended (kept ones) plus the current one.
void MapStage::CopyCounters() {
  mapping::MapBuilderStats b = stats_done_;
  if (!run_ended_) AddBuilderStats(builder_->stats(), &b);  // else in stats_done_
  Counters& c = p_.counters;
  c.Set(kMapVertices, b.vertices);
  c.Set(kMapImuEdges, b.imu_edges);
  c.Set(kMapKeypoints, b.keypoints);
  c.Set(kMapLandmarks, b.landmarks);
  c.Set(kMapLandmarksGood, b.landmarks_good);
  c.Set(kMapVertexUsMean, static_cast<int64_t>(b.vertex_ms_mean() * 1e3));
  c.Set(kMapVertexUsMax, static_cast<int64_t>(b.vertex_ms_max * 1e3));
  // What the current mission holds in memory (counted at most once a second: with the whole
  // mission in memory the count walks it).
  const int64_t now = SteadyNs();
  if (run_ended_ || now - last_held_update_ns_ >= 1000 * kMs) {
    last_held_update_ns_ = now;
    const mapping::MapBuilderHeld held = run_ended_ ? mapping::MapBuilderHeld() : builder_->Held();
    c.Set(kMapVerticesHeld, held.vertices);
    c.Set(kMapBytesHeld, held.bytes);
  }
  if (transport_) {
    mapstore::MissionStreamSenderCounters s = stream_counters_done_;
    for (const EndingStream& e : ending_streams_) AddStreamCounters(e.sender->sender().counters(), &s);
    if (stream_) AddStreamCounters(stream_->sender().counters(), &s);
    c.Set(kStreamSent, static_cast<int64_t>(s.sent));
    c.Set(kStreamAcked, static_cast<int64_t>(s.acked));
    c.Set(kStreamRetransmitted, static_cast<int64_t>(s.retransmitted));
    c.Set(kStreamWindowFull, static_cast<int64_t>(s.window_full));
    c.Set(kStreamDiskFullAcks, static_cast<int64_t>(s.disk_full_acks));
    c.Set(kStreamErrorAcks, static_cast<int64_t>(s.error_acks));
  }
}

// Deltas go out once the mission has 2 vertices: a mission dropped for having fewer never
// reaches mapstored.
void MapStage::TakeDelta(bool always) {
  mapstore::MissionDelta delta = builder_->TakeDelta();
  if (!always && delta.vertices.empty() && delta.edges.empty() && delta.landmarks.empty()) return;
  // A large delta (the last one of a mission kept whole re-sends it) goes out in parts that
  // each fit one LCM message.
  const int64_t index = builder_->delta_count() - 1;
  std::vector<mapstore::MissionDelta> parts = mapstore::SplitMissionDelta(
      delta, static_cast<std::size_t>(options_.mapping.stream.max_delta_bytes));
  for (std::size_t i = 0; i < parts.size(); ++i) {
    backlog_.push_back({std::move(parts[i]), index, i + 1 == parts.size()});
  }
  p_.counters.Add(kMapDeltas);
}

void MapStage::SendBacklog() {
  mapstore::MissionStreamSender& s = stream_->sender();
  while (!backlog_.empty() && s.Send(backlog_.front().delta)) {
    if (backlog_.front().last) sent_deltas_.emplace_back(backlog_.front().delta_index, s.next_seq() - 1);
    backlog_.pop_front();
  }
}

// Acknowledgements are cumulative: a delta whose last chunk is acknowledged is on mapstored's
// disk with every delta before it (deltas taken but empty were not sent: nothing to release).
void MapStage::ReleaseAcknowledged() {
  if (builder_memory_ != mapping::MapBuilderMemory::kReleaseAcknowledged || !stream_) return;
  const int64_t acked = stream_->sender().acked_seq();
  int64_t released = -1;
  while (!sent_deltas_.empty() && sent_deltas_.front().second <= acked) {
    released = sent_deltas_.front().first;
    sent_deltas_.pop_front();
  }
  if (released >= 0) builder_->ReleaseAcknowledged(released);
}

namespace {
// After mapstored acknowledged the END as durable, how long the ending stream still waits for
// COMPLETE (the map folder written) [ns]: a short mission's folder follows within
// milliseconds, an hour's takes minutes, which a stopping robot should not wait for.
constexpr int64_t kCompleteGraceNs = 1'000'000'000;
}  // namespace

// Acks (the senders' handlers run in this thread: each takes the acks of its mission),
// retransmissions, queued deltas.
void MapStage::ServiceStream(int timeout_ms) {
  if (transport_->Handle(timeout_ms) > 0) {
    while (transport_->Handle(0) > 0) {
    }
  }
  if (stream_) {
    SendBacklog();
    stream_->sender().Poll();
    ReleaseAcknowledged();
  }
  std::size_t waiting = backlog_.size();
  const int64_t now = SteadyNs();
  for (std::size_t i = 0; i < ending_streams_.size();) {
    EndingStream& e = ending_streams_[i];
    mapstore::MissionStreamSender& s = e.sender->sender();
    while (!e.backlog.empty() && s.Send(e.backlog.front().delta)) e.backlog.pop_front();
    if (e.backlog.empty()) s.End();  // queued once; retried while the window is full
    s.Poll();
    waiting += e.backlog.size();
    const bool timed_out = now >= e.deadline_ns;
    // The END journaled and fsynced is what the robot needs before it stops: the mission is
    // safe in mapstored, which writes the map folder next (minutes for an hour of mapping).
    // COMPLETE is awaited kCompleteGraceNs more (a short mission's folder is written at once).
    if (s.end_durable() && e.durable_ns < 0) e.durable_ns = now;
    const bool durable_done = e.durable_ns >= 0 && now - e.durable_ns >= kCompleteGraceNs;
    if (s.finished() || durable_done || timed_out) {
      if (s.finished()) {
        ++streams_finished_;
      } else if (s.end_durable()) {
        ++streams_durable_;
        p_.log(14, "map: mission %s journaled by mapstored (END acknowledged), map folder pending",
               s.mission_id().Hex().c_str());
      } else {
        ++streams_unfinished_;
        std::fprintf(stderr,
                     "vilma-estimatord: mapstored did not acknowledge mission %s within "
                     "mapping.stream.end_timeout_s (%.1f s): %s\n",
                     s.mission_id().Hex().c_str(), options_.mapping.stream.end_timeout_s,
                     s.last_message().c_str());
      }
      AddStreamCounters(s.counters(), &stream_counters_done_);
      ending_streams_.erase(ending_streams_.begin() + static_cast<std::ptrdiff_t>(i));
      continue;
    }
    ++i;
  }
  p_.counters.Set(kStreamBacklog, static_cast<int64_t>(waiting));
}

// Ends the current mission: landmarks (Finish), then either dropped (fewer than 2 vertices; at
// the end of a run without any other mission the last one is kept) or kept: the last delta and
// END go out without waiting, the map is kept for --save-map.
void MapStage::EndMission(bool end_of_run) {
  builder_->Finish();
  finish_ms_ += builder_->stats().finish_ms;
  const bool keep = builder_->stats().vertices >= 2 || (end_of_run && missions_kept_ == 0);
  run_ended_ = end_of_run;
  if (!keep) {
    p_.counters.Add(kMapMissionsDropped);
    // Nothing of it was streamed (TakeDelta waits for 2 vertices): the sender just goes.
    if (stream_) {
      AddStreamCounters(stream_->sender().counters(), &stream_counters_done_);
      stream_.reset();
    }
    backlog_.clear();
    p_.log(12, "map: mission %s dropped (%lld vertices)", builder_->mission_id().Hex().c_str(),
           static_cast<long long>(builder_->stats().vertices));
    return;
  }
  ++missions_kept_;
  AddBuilderStats(builder_->stats(), &stats_done_);
  if (stream_) {
    TakeDelta(true);  // landmarks, changed vertices, complete = true
    EndingStream e;
    e.sender = std::move(stream_);
    e.backlog = std::move(backlog_);
    backlog_.clear();
    e.deadline_ns = SteadyNs() + SecondsToNs(options_.mapping.stream.end_timeout_s);
    ending_streams_.push_back(std::move(e));
  }
  if (!options_.mapping.save_dir.empty()) finished_maps_.push_back(builder_->ReleaseMap());
}

void MapStage::StartMission() {
  ++mission_index_;
  builder_ = std::make_unique<mapping::MapBuilder>(rig_, builder_options_, MissionSeed(mission_index_),
                                                   MissionName(mission_index_), builder_memory_);
  sent_deltas_.clear();
  p_.counters.Add(kMapMissions);
  p_.log(13, "map: the filter's frame M starts anew (reset / restart): mission %d, %s",
         mission_index_, builder_->mission_id().Hex().c_str());
  if (transport_) stream_ = transport_->MakeSender(builder_->mission_id(), MissionName(mission_index_));
  vertices_at_last_delta_ = 0;
  last_delta_ns_ = SteadyNs();
}

// Live mode: never waited for by the filter (drops are counted there); --input-log: the filter
// waits for it, so the map is the same on every run.
void MapStage::Run() {
  const MapStreamOptions& so = options_.mapping.stream;
  std::vector<cv::Mat> images(rig_.cameras.size());
  last_delta_ns_ = SteadyNs();
  const int64_t delta_period_ns = SecondsToNs(so.delta_period_s);
  MapItem item;
  while (true) {
    bool any = false;
    while (queue_->pop(item)) {
      any = true;
      if (item.kind == MapItem::Kind::kImu) {
        builder_->AddImu(item.imu);
        continue;
      }
      if (item.kind == MapItem::Kind::kBreak) {
        // The filter's M frame starts anew: a mission is one frame M (docs/daemon.md).
        EndMission(false);
        StartMission();
        CopyCounters();
        continue;
      }
      for (std::size_t c = 0; c < images.size() && c < item.images.size(); ++c) {
        images[c] = item.images[c];
        item.images[c].release();
      }
      builder_->AddFrame(item.state, images);
      for (cv::Mat& m : images) m.release();  // back to the pool
      frames_in_flight_.fetch_sub(1);
      CopyCounters();
      if (stream_ && builder_->stats().vertices >= 2 &&
          builder_->stats().vertices - vertices_at_last_delta_ >= so.delta_vertices) {
        TakeDelta(false);
        vertices_at_last_delta_ = builder_->stats().vertices;
        last_delta_ns_ = SteadyNs();
      }
    }
    if (transport_) {
      const int64_t now = SteadyNs();
      if (stream_ && builder_->stats().vertices >= 2 &&
          builder_->stats().vertices > vertices_at_last_delta_ &&
          now - last_delta_ns_ >= delta_period_ns) {
        TakeDelta(false);
        vertices_at_last_delta_ = builder_->stats().vertices;
        last_delta_ns_ = now;
      }
      ServiceStream(0);
      CopyCounters();
    }
    if (!any) {
      if (p_.filter_done.load() && queue_->read_available() == 0) break;
      if (transport_) {
        ServiceStream(10);  // waits on the LCM socket (acks) for up to 10 ms
      } else {
        p_.map_wake.Wait(50 * kMs);
      }
    }
  }
  EndOfRun();
  p_.map_done.store(true);
  p_.output_wake.Notify();
}

// The last mission ends like the others; then every mission that is still ending gets until
// its own deadline (at most end_timeout_s from now) for mapstored's acks; the map is saved.
void MapStage::EndOfRun() {
  const auto t0 = std::chrono::steady_clock::now();
  EndMission(true);
  if (transport_) {
    while (!ending_streams_.empty()) ServiceStream(10);
  }
  CopyCounters();
  const int missions = mission_index_ + 1;
  const mapping::MapBuilderStats& st = stats_done_;
  std::ostringstream report;
  report << "map: ";
  if (missions > 1) {
    report << missions << " missions (" << (missions - missions_kept_)
           << " dropped: fewer than 2 vertices), ";
  }
  report << st.vertices << " vertices, " << st.landmarks << " landmarks (" << st.landmarks_good
         << " good), finish " << static_cast<int>(finish_ms_) << " ms";
  if (transport_) {
    stream_finished_ = streams_unfinished_ == 0 &&
                       streams_finished_ + streams_durable_ == missions_kept_;
    const mapstore::MissionStreamSenderCounters& c = stream_counters_done_;
    report << "; stream: " << c.sent << " chunks, " << c.acked << " acked, " << c.retransmitted
           << " retransmitted, ";
    if (missions_kept_ == 1) {
      report << (streams_finished_ == 1 ? "mission complete in mapstored"
                 : streams_durable_ == 1
                     ? "mission journaled by mapstored (END acknowledged; map folder still being written)"
                     : "NOT acknowledged by mapstored");
    } else {
      report << streams_finished_ << " of " << missions_kept_ << " missions complete in mapstored";
      if (streams_durable_ > 0) report << ", " << streams_durable_ << " journaled (map folder pending)";
    }
  }
  const std::string& save_dir = options_.mapping.save_dir;
  if (!save_dir.empty()) {
    try {
      mapstore::MapSaveSummary saved;
      if (finished_maps_.size() == 1) {
        saved = mapstore::SaveMap(finished_maps_[0], save_dir);
      } else {
        // The missions of the run in one map, in the order they were made.
        mapstore::VIMap all;
        for (const mapstore::VIMap& m : finished_maps_) {
          for (const mapstore::MissionId& id : m.mission_ids()) {
            mapstore::ApplyMissionDelta(WholeMission(m, id), &all);
          }
          // Deltas carry no resources: the images of map_builder.keep_images.
          all.resources().MergeFrom(m.resources());
        }
        saved = mapstore::SaveMap(all, save_dir);
      }
      map_saved_ = true;
      report << "; saved to " << save_dir << " (" << saved.bytes_written << " B)";
    } catch (const std::exception& e) {
      map_error_ = std::string("saving the map into ") + save_dir + " failed: " + e.what();
      std::fprintf(stderr, "vilma-estimatord: error: %s\n", map_error_.c_str());
    }
  }
  report << "; end of mission took "
         << static_cast<int>(
                std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count())
         << " ms";
  report_ = report.str();
}

// ---------------------------------------------------------------- MapFeeder (filter thread)

MapFeeder::MapFeeder(const MappingOptions& options, Pipeline* pipeline, MapStage* stage)
    : options_(options),
      p_(*pipeline),
      queue_(stage->queue()),
      frames_in_flight_(stage->frames_in_flight()) {}

void MapFeeder::PushImu(const ImuSample& sample) {
  item_.kind = MapItem::Kind::kImu;
  item_.imu = sample;
  if (!Push(p_, queue_, item_)) {
    p_.counters.Add(kMapImuDropped);
    // (With --input-log a push only fails when a stop request cut the wait short.)
    if (!p_.log_mode) {
      p_.log(11, "BUG: map builder queue full, IMU sample dropped (mapping.queue_capacity)");
    }
    return;
  }
  p_.map_wake.Notify();
}

bool MapFeeder::PushBreak() {
  MapItem brk;
  brk.kind = MapItem::Kind::kBreak;
  const bool pushed = Push(p_, queue_, brk);
  if (pushed) p_.map_wake.Notify();
  return pushed;
}

void MapFeeder::EndMission() {
  if (!has_vertex_) return;
  has_vertex_ = false;
  break_pending_ = !PushBreak();
}

void MapFeeder::OfferFrame(const mapping::FrameState& state,
                           std::array<cv::Mat, kMaxMapCameras>* images) {
  // The builder receives only the frames it wants (its own rule), so both agree.
  const bool wanted =
      !has_vertex_ ||
      mapping::VertexIntervalReached(state.t_ns - last_vertex_ns_, options_.map_builder.vertex_rate_hz);
  if (!wanted) {
    p_.counters.Add(kMapFramesThinned);
    return;
  }
  if (break_pending_) break_pending_ = !PushBreak();
  const int max_in_flight = options_.max_frames_in_flight;
  bool room = !break_pending_ && frames_in_flight_.load() < max_in_flight;
  if (!room && p_.log_mode) {
    // Deterministic: wait for the builder (it never waits for the filter).
    while (frames_in_flight_.load() >= max_in_flight && !p_.stop.load()) {
      p_.notifier.PetWatchdog(SteadyNs());
      std::this_thread::sleep_for(std::chrono::microseconds(200));
    }
    room = frames_in_flight_.load() < max_in_flight;
  }
  if (!room) {
    p_.counters.Add(kMapFramesDropped);
    return;
  }
  item_.kind = MapItem::Kind::kFrame;
  item_.state = state;
  item_.images = *images;
  frames_in_flight_.fetch_add(1);
  if (Push(p_, queue_, item_)) {
    has_vertex_ = true;
    last_vertex_ns_ = state.t_ns;
    p_.counters.Add(kMapFramesQueued);
    p_.map_wake.Notify();
  } else {
    frames_in_flight_.fetch_sub(1);
    p_.counters.Add(kMapFramesDropped);
  }
  for (cv::Mat& m : item_.images) m.release();
}

}  // namespace vilma::daemon
