// The map-building stage (docs/daemon.md "Map building"): a thread that feeds the MapBuilder
// in the filter's order (IMU samples and the states and images of the frames it wants),
// streams the mission's deltas to vilma-mapstored, starts a new mission when the filter's M
// frame starts anew, and at the end finishes the missions, ends the streams and saves the map.
// MapFeeder is its producer side, run by the filter thread: the frame thinning (the builder's
// own vertex-rate rule, mapping::VertexIntervalReached), the mission breaks, backpressure.
#pragma once

#include <atomic>
#include <cstdint>
#include <deque>
#include <functional>
#include <memory>
#include <string>
#include <utility>
#include <vector>

#include "pipeline.h"
#include "vilma/core/rig.h"
#include "vilma/daemon/daemon_options.h"
#include "vilma/mapping/map_builder.h"
#include "vilma/mapstore/map_io.h"
#include "vilma/mapstore/stream/mission_stream_sender.h"

namespace vilma::daemon {

// The daemon options the map stage uses, with what it needs to know of the run.
struct MapStageOptions {
  MappingOptions mapping;
  int num_cameras = 0;    // subscribed cameras (their images come with each frame)
  std::string input_log;  // --input-log: the mission seed comes from its content
};

class MapStage {
 public:
  using TransportFactory = std::function<std::unique_ptr<MissionStreamTransport>()>;
  // Checks the options against the rig (cameras, save folder: absent or empty, created now),
  // starts mission 0 and opens the stream (open_transport, with mapping.stream.enabled).
  // Throws InputError.
  MapStage(const MapStageOptions& options, const SensorRig& rig, Pipeline* pipeline,
           const TransportFactory& open_transport);
  ~MapStage();

  Spsc<MapItem>& queue() { return *queue_; }
  // Frames (with images) queued for the builder or being added (mapping.max_frames_in_flight).
  std::atomic<int>& frames_in_flight() { return frames_in_flight_; }
  // The thread loop: until the filter is done and the queue is empty; then the end of the run
  // (Finish, the streams' ends, the save). Sets map_done.
  void Run();

  // After Run (the thread joined).
  bool map_saved() const { return map_saved_; }
  bool stream_finished() const { return stream_finished_; }
  const std::string& map_error() const { return map_error_; }
  const std::string& report() const { return report_; }

 private:
  // A mission that ended while streaming: its last delta and END go out while the next
  // mission streams (the map thread never waits for mapstored in the middle of a run).
  // A part of a delta waiting for window space: the builder's delta index and whether it is
  // the delta's last part (its chunk's acknowledgement acknowledges the whole delta).
  struct Part {
    mapstore::MissionDelta delta;
    int64_t delta_index = 0;
    bool last = false;
  };
  struct EndingStream {
    std::unique_ptr<mapstore::LcmMissionStreamSender> sender;
    std::deque<Part> backlog;
    int64_t deadline_ns = 0;  // steady clock: stream.end_timeout_s after the mission ended
    int64_t durable_ns = -1;  // steady clock: when mapstored acknowledged the END as journaled
  };
  uint64_t MissionSeed(int k) const;
  std::string MissionName(int k) const;
  void CopyCounters();
  void TakeDelta(bool always);
  // Sends what fits the window; records the chunk of each delta's last part.
  void SendBacklog();
  // Releases in the builder what mapstored acknowledged (MapBuilderMemory::kReleaseAcknowledged).
  void ReleaseAcknowledged();
  void ServiceStream(int timeout_ms);
  void EndMission(bool end_of_run);
  void StartMission();
  void EndOfRun();

  const MapStageOptions options_;
  const SensorRig& rig_;
  Pipeline& p_;
  mapping::MapBuilderOptions builder_options_;  // cameras resolved
  // Streaming without --save-map: the builder drops what mapstored acknowledged
  // (docs/daemon.md "Memory in long missions"); otherwise it keeps the whole mission.
  mapping::MapBuilderMemory builder_memory_ = mapping::MapBuilderMemory::kWholeMission;
  uint64_t mission_seed_base_ = 0;
  // Declared before the senders that use it: destroyed after them.
  std::unique_ptr<MissionStreamTransport> transport_;
  std::unique_ptr<mapping::MapBuilder> builder_;
  std::unique_ptr<mapstore::LcmMissionStreamSender> stream_;
  std::unique_ptr<Spsc<MapItem>> queue_;
  std::atomic<int> frames_in_flight_{0};
  // Missions (docs/daemon.md "Missions and filter resets"): one per continuous odometry
  // segment. Mission k has the seed MissionSeed(k) and the name MissionName(k).
  int mission_index_ = 0;
  std::vector<mapstore::VIMap> finished_maps_;  // kept missions, for --save-map
  int missions_kept_ = 0;
  bool run_ended_ = false;                  // the last mission ended (its stats are in stats_done_)
  mapping::MapBuilderStats stats_done_;      // of the kept missions that ended
  mapstore::MissionStreamSenderCounters stream_counters_done_;  // of the senders that ended
  std::vector<EndingStream> ending_streams_;
  // Ended streams: COMPLETE (map folder written), END durable only (folder still being
  // written when the daemon stopped waiting), neither within end_timeout_s.
  int streams_finished_ = 0, streams_durable_ = 0, streams_unfinished_ = 0;
  std::deque<Part> backlog_;  // delta parts waiting for window space, in order
  // Deltas of the current mission sent whole: (delta index, seq of its last chunk), in order.
  std::deque<std::pair<int64_t, int64_t>> sent_deltas_;
  int64_t last_held_update_ns_ = 0;
  int64_t vertices_at_last_delta_ = 0;
  int64_t last_delta_ns_ = 0;
  double finish_ms_ = 0.0;  // Finish() of every mission
  bool map_saved_ = false;
  bool stream_finished_ = false;
  std::string map_error_;
  std::string report_;
};

// The filter thread's side of the map stage: what goes into its queue, in the filter's order.
class MapFeeder {
 public:
  MapFeeder(const MappingOptions& options, Pipeline* pipeline, MapStage* stage);

  // Every IMU sample the filter gets.
  void PushImu(const ImuSample& sample);
  // The filter's M frame starts anew (reset, restart): the current mission ends (nothing to
  // end before it got a frame). Live, a full queue defers the break to the next frame.
  void EndMission();
  // A tracked frame (pose valid, no reset) with every subscribed camera's image: handed to the
  // builder when its vertex rate wants it; live, dropped when the builder is behind;
  // --input-log, waits for it.
  void OfferFrame(const mapping::FrameState& state, std::array<cv::Mat, kMaxMapCameras>* images);

 private:
  bool PushBreak();

  const MappingOptions& options_;
  Pipeline& p_;
  Spsc<MapItem>& queue_;
  std::atomic<int>& frames_in_flight_;
  bool has_vertex_ = false;  // a frame went to the current mission
  int64_t last_vertex_ns_ = 0;
  // Live: a break that found the queue full, pushed before the next frame (which is dropped
  // while it cannot be).
  bool break_pending_ = false;
  MapItem item_;
};

}  // namespace vilma::daemon
