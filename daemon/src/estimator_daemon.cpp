// vilma-estimatord's wiring: the stages are created and connected here, run on their threads
// and stopped in pipeline order (docs/daemon.md "Pipeline"). Each stage is a class in its own
// file: input_stage (LCM, decoding), sync_stage, filter_stage, loc_stage (localizer and its
// query scheduler), map_stage (map builder and mission stream), publish_stage (VILMA_ODOM,
// VILMA_POSE, VILMA_LOC, VILMA_STATUS); pipeline.h holds what they share.
#include "vilma/daemon/estimator_daemon.h"

#include <sstream>
#include <thread>

#include "filter_stage.h"
#include "input_stage.h"
#include "loc_stage.h"
#include "map_stage.h"
#include "pipeline.h"
#include "publish_stage.h"
#include "sync_stage.h"
#include "vilma/core/error.h"
#include "vilma/daemon/image_pool.h"

namespace vilma::daemon {

struct EstimatorDaemon::Impl {
  Impl(const DaemonOptions& o, const SensorRig& r);

  DaemonOptions options;
  SensorRig rig;
  int num_cameras = 0;
  Pipeline pipeline;
  // Declared before the stages, whose queues and synchronizer hold its images: destroyed last.
  std::unique_ptr<ImagePool> pool;
  std::unique_ptr<PublishStage> publish;
  std::unique_ptr<FilterStage> filter;
  std::unique_ptr<SyncStage> sync;
  std::unique_ptr<InputStage> input;
  std::unique_ptr<MapStage> map;  // mapping.enabled
  std::unique_ptr<LocStage> loc;  // localization.enabled
};

EstimatorDaemon::Impl::Impl(const DaemonOptions& o, const SensorRig& r)
    : options(o), rig(r), pipeline(!o.input_log.empty()) {
  const std::string error = options.Validate();
  if (!error.empty()) throw InputError("daemon options: " + error);
  num_cameras = std::min(static_cast<int>(rig.cameras.size()),
                         static_cast<int>(options.channels.cameras.size()));
  if (options.vio_camera >= num_cameras) {
    throw InputError(FormatInputError("rig", "cameras[" + std::to_string(options.vio_camera) + "]",
                                      "the camera given by vio_camera (the rig has " +
                                          std::to_string(rig.cameras.size()) + ")"));
  }
  const estimator::FilterOptions estimator_options = options.EffectiveEstimatorOptions();
  if (estimator_options.stereo.enabled && estimator_options.stereo.camera >= num_cameras) {
    throw InputError(FormatInputError(
        "rig", "cameras[" + std::to_string(estimator_options.stereo.camera) + "]",
        "the stereo camera (estimator stereo.camera; the rig has " +
            std::to_string(rig.cameras.size()) + ")"));
  }
  std::size_t slot_bytes = 0;
  std::vector<int64_t> camera_offsets_ns;
  for (int i = 0; i < num_cameras; ++i) {
    const CameraConfig& c = rig.cameras[static_cast<std::size_t>(i)];
    slot_bytes = std::max(slot_bytes, static_cast<std::size_t>(c.camera.width()) *
                                          static_cast<std::size_t>(c.camera.height()));
    camera_offsets_ns.push_back(c.time_offset_ns);
  }
  // Every slot the stages can hold at once (RequiredImagePoolSlots): with fewer, the log mode's
  // blocking input could wait for a slot that only newer input would free.
  if (options.queues.image_pool_slots < RequiredImagePoolSlots(options, num_cameras)) {
    throw InputError(FormatInputError("daemon options", "queues.image_pool_slots",
                                      ImagePoolRuleText(options, num_cameras)));
  }
  pool = std::make_unique<ImagePool>(options.queues.image_pool_slots, slot_bytes);

  publish = std::make_unique<PublishStage>(MakePublishStageOptions(options), &pipeline, pool.get());
  FilterStageOptions fo;
  fo.estimator = estimator_options;
  fo.vio_camera = options.vio_camera;
  fo.queue_capacity = options.queues.filter_capacity;
  fo.fault_stall_after = options.fault_stall_filter_after;
  fo.fault_reset_at = options.fault_reset_filter_at;
  fo.time_jump.resume_max_gap_s = options.time_jump_resume_max_gap_s;
  filter = std::make_unique<FilterStage>(fo, rig, &pipeline, &publish->queue());
  SyncStageOptions so;
  so.sync = options.sync;
  so.camera_offsets_ns = camera_offsets_ns;
  so.vio_camera = options.vio_camera;
  so.stereo_camera = estimator_options.stereo.enabled ? estimator_options.stereo.camera : -1;
  so.camera_silence_s = options.camera_silence_s;
  so.input_capacity = options.queues.input_capacity;
  so.max_frames_in_flight = options.queues.max_frames_in_flight;
  so.with_all_images = options.mapping.enabled;
  sync = std::make_unique<SyncStage>(so, &pipeline, &filter->queue(), &filter->frames_in_flight());
  input = std::make_unique<InputStage>(options, rig, num_cameras, &pipeline, pool.get(), &sync->queue());
  if (options.mapping.enabled) {
    MapStageOptions mo;
    mo.mapping = options.mapping;
    mo.num_cameras = num_cameras;
    mo.input_log = options.input_log;
    map = std::make_unique<MapStage>(mo, rig, &pipeline,
                                     [this] { return OpenMissionStreamTransport(options); });
    filter->ConnectMap(options.mapping, map.get());
  }
  if (options.localization.enabled) {
    loc = std::make_unique<LocStage>(options.localization,
                                     rig.cameras[static_cast<std::size_t>(options.vio_camera)],
                                     &pipeline);
    filter->ConnectLoc(options.localization, loc.get());
  }
}

EstimatorDaemon::EstimatorDaemon(const DaemonOptions& options, const SensorRig& rig)
    : impl_(std::make_unique<Impl>(options, rig)) {}

EstimatorDaemon::~EstimatorDaemon() = default;

void EstimatorDaemon::RequestStop() { impl_->pipeline.stop.store(true); }

DaemonSummary EstimatorDaemon::Run() {
  Impl& d = *impl_;
  Pipeline& p = d.pipeline;
  // Downstream first, so that every consumer waits before its producer starts.
  std::thread publisher([&] { d.publish->Run(&d.input->sink()); });
  std::thread filter([&] { d.filter->Run(); });
  std::thread sync([&] { d.sync->Run(); });
  std::thread map_thread;
  if (d.map) map_thread = std::thread([&] { d.map->Run(); });
  std::thread loc_thread;
  if (d.loc) loc_thread = std::thread([&] { d.loc->Run(); });
  // Subscribed (constructor) and every stage is up.
  p.notifier.Ready();
  p.notifier.Status(p.log_mode ? "reading " + d.options.input_log : "running");
  std::thread input([&] { d.input->Run(); });
  // Each stage ends when its producer is done and its queue is empty (the end of the log or a
  // stop request ends the input): the pipeline flushes in order.
  input.join();
  if (p.stop.load()) p.notifier.Stopping();
  sync.join();
  filter.join();
  if (map_thread.joinable()) map_thread.join();
  if (loc_thread.joinable()) loc_thread.join();
  publisher.join();
  if (!p.stop.load()) p.notifier.Stopping();
  // Close LCM: a file:// provider flushes its file here (the output of an --input-log run).
  d.input->Close();

  const Counters& c = p.counters;
  DaemonSummary summary;
  summary.frames_filtered = c.Get(kFramesFiltered);
  summary.poses_published = c.Get(kPosesPublished);
  summary.malformed_messages = c.Malformed();
  summary.drops = c.Drops();
  std::ostringstream report;
  for (const CounterInfo& info : kCounters) report << info.name << " " << c.Get(info.id) << "\n";
  summary.report = report.str();
  summary.mapping = d.map != nullptr;
  if (d.map) {
    summary.map_saved = d.map->map_saved();
    summary.map_error = d.map->map_error();
    summary.map_report = d.map->report();
    summary.stream_finished = d.map->stream_finished();
  }
  return summary;
}

std::string DaemonSummary::BriefReport() const {
  return std::to_string(frames_filtered) + " frames, " + std::to_string(poses_published) +
         " poses published, " + std::to_string(malformed_messages) + " malformed messages, " +
         std::to_string(drops) + " drops";
}

std::string DaemonSummary::FullReport(const std::string& program) const {
  std::string full = program + "stopped: " + BriefReport() + "\n" + report;
  if (mapping) full += program + map_report + "\n";
  return full;
}

}  // namespace vilma::daemon
