#include "publish_stage.h"

#include <sys/resource.h>

#include <algorithm>
#include <sstream>

#include <vilma/localization_t.hpp>
#include <vilma/pose_t.hpp>
#include <vilma/status_t.hpp>

#include "vilma/core/heap.h"
#include "vilma/core/time.h"
#include "vilma/drivers/lcm_url.h"

namespace vilma::daemon {

// PoseStatus (pipeline.h) keeps the filter stage free of LCM types.
constexpr bool SameStatus(PoseStatus a, int32_t b) { return static_cast<int32_t>(a) == b; }
static_assert(SameStatus(kPoseInvalid, pose_t::INVALID) &&
                  SameStatus(kPoseInitializing, pose_t::INITIALIZING) &&
                  SameStatus(kPoseTracking, pose_t::TRACKING) &&
                  SameStatus(kPoseLocalized, pose_t::LOCALIZED) && SameStatus(kPoseLost, pose_t::LOST),
              "PoseStatus (pipeline.h) must equal pose_t's constants");

PublishStageOptions MakePublishStageOptions(const DaemonOptions& o) {
  PublishStageOptions p;
  p.odometry_channel = ChannelName(o.channels.odometry, o.channel_suffix);
  p.pose_channel = ChannelName(o.channels.pose, o.channel_suffix);
  p.localization_channel = ChannelName(o.channels.localization, o.channel_suffix);
  p.status_channel = ChannelName(o.channels.status, o.channel_suffix);
  p.status_period_s = o.status_period_s;
  p.queue_capacity = o.queues.output_capacity;
  p.wait_for_map = o.mapping.enabled;
  return p;
}

PublishStage::PublishStage(const PublishStageOptions& options, Pipeline* pipeline,
                           const ImagePool* pool)
    : options_(options),
      p_(*pipeline),
      pool_(*pool),
      queue_(static_cast<std::size_t>(options.queue_capacity)) {}

void PublishStage::PublishStatus(MessageSink& sink, int state, int64_t now_ns) {
  // CPU load of the whole process over the last period [fraction of one core].
  rusage usage;
  getrusage(RUSAGE_SELF, &usage);
  const int64_t cpu_us = (usage.ru_utime.tv_sec + usage.ru_stime.tv_sec) * 1000000LL +
                         usage.ru_utime.tv_usec + usage.ru_stime.tv_usec;
  if (last_cpu_us_ >= 0 && now_ns > last_cpu_wall_ns_) {
    cpu_load_ = static_cast<double>(cpu_us - last_cpu_us_) * 1000.0 /
                static_cast<double>(now_ns - last_cpu_wall_ns_);
  }
  last_cpu_us_ = cpu_us;
  last_cpu_wall_ns_ = now_ns;

  const Counters& counters = p_.counters;
  status_t msg;
  msg.utime = WallClockUtime();
  msg.node = "vilma-estimatord";
  msg.state = state;
  const int fstate = p_.filter_state.load();
  const char* fname = fstate == pose_t::TRACKING ? "TRACKING"
                      : fstate == pose_t::LOST   ? "LOST"
                                                 : "INITIALIZING";
  std::ostringstream text;
  text << fname << ", " << p_.features.load() << " features";
  if (p_.filter_stalled.load()) text << ", FILTER STALLED (fault injection)";
  if (counters.Get(kImuDroppedInputQueue) + counters.Get(kImuDroppedFilterQueue) > 0) {
    text << ", IMU DROPPED";
  }
  msg.message = text.str();
  if (state == status_t::OK && (fstate != pose_t::TRACKING || p_.filter_stalled.load())) {
    msg.state = status_t::DEGRADED;
  }
  for (const CounterInfo& c : kCounters) {
    msg.counter_names.push_back(c.name);
    msg.counter_values.push_back(counters.Get(c.id));
  }
  auto add_counter = [&](const char* name, int64_t value) {
    msg.counter_names.push_back(name);
    msg.counter_values.push_back(value);
  };
  add_counter("malformed_messages", counters.Malformed());
  add_counter("drops", counters.Drops());
  add_counter("filter_state", fstate);
  add_counter("tracked_features", p_.features.load());
  add_counter("queue_input_depth_max", p_.input_depth_max.exchange(0));
  add_counter("queue_filter_depth_max", p_.filter_depth_max.exchange(0));
  add_counter("queue_output_depth_max", p_.output_depth_max.exchange(0));
  add_counter("image_pool_free", pool_.num_free());
  msg.num_counters = static_cast<int32_t>(msg.counter_names.size());
  auto add_metric = [&](const std::string& name, double value) {
    msg.metric_names.push_back(name);
    msg.metric_values.push_back(value);
  };
  add_metric("cpu_load", cpu_load_);
  const std::pair<const char*, const LatencyWindow*> stages[] = {
      {"latency_receive", &lat_receive_},          // utime -> received (wall clock; sensor clock!)
      {"latency_sync", &lat_sync_},                // received -> synced
      {"latency_filter_wait", &lat_filter_wait_},  // synced -> filter starts
      {"latency_filter", &lat_filter_},            // filter update
      {"latency_publish", &lat_publish_},          // filtered -> published
      {"latency_total", &lat_total_}};             // received -> published
  for (const auto& [name, window] : stages) {
    add_metric(std::string(name) + "_p50_ms", window->Percentile(0.5));
    add_metric(std::string(name) + "_p99_ms", window->Percentile(0.99));
  }
  // The heap over every malloc arena (vilma/core/heap.h): a growing RSS with a flat
  // heap_in_use_mb is the allocator keeping free pages, not state the daemon holds.
  const HeapUsage heap = ReadHeapUsage();
  add_metric("heap_in_use_mb", heap.in_use_mb);
  add_metric("heap_free_mb", heap.free_mb);
  add_metric("heap_mmapped_mb", heap.mmapped_mb);
  msg.num_metrics = static_cast<int32_t>(msg.metric_names.size());
  ++status_seq_;
  PublishMessage(sink, options_.status_channel, msg, &buffer_);
}

void PublishStage::Run(MessageSink* sink_in) {
  MessageSink& sink = *sink_in;
  pose_t msg;  // VILMA_ODOM
  msg.parent_frame = "M";
  msg.child_frame = "I";
  int64_t seq = 0;
  pose_t gmsg;  // VILMA_POSE (LOC mode)
  gmsg.parent_frame = "G";
  gmsg.child_frame = "I";
  int64_t gseq = 0;
  localization_t lmsg;  // VILMA_LOC (LOC mode)
  int64_t lseq = 0;
  const int64_t period_ns = SecondsToNs(options_.status_period_s);
  int64_t next_status_ns = SteadyNs();
  OutputItem out;
  while (true) {
    bool any = false;
    const int depth = static_cast<int>(queue_.read_available());
    if (depth > p_.output_depth_max.load()) p_.output_depth_max.store(depth);
    while (queue_.pop(out)) {
      any = true;
      if (out.kind == OutputItem::Kind::kLoc) {
        const LocRecord& rec = out.loc;
        lmsg.utime = NsToUtime(rec.t_ns);
        lmsg.seq = lseq++;
        lmsg.status = localizer::LocalizationStatusName(rec.status);
        lmsg.decision = LocDecisionName(rec.decision);
        lmsg.num_keypoints = rec.num_keypoints;
        lmsg.num_matches = rec.num_matches;
        lmsg.num_inliers = rec.num_inliers;
        std::copy(rec.position, rec.position + 3, lmsg.position);
        std::copy(rec.orientation, rec.orientation + 4, lmsg.orientation);
        std::copy(rec.covariance, rec.covariance + 36, lmsg.covariance);
        lmsg.stage_ms = rec.stage_ms;
        PublishMessage(sink, options_.localization_channel, lmsg, &buffer_);
        p_.counters.Add(kLocMessagesPublished);
        continue;
      }
      msg.utime = NsToUtime(out.t_ns);
      msg.seq = seq++;
      std::copy(out.position, out.position + 3, msg.position);
      std::copy(out.orientation, out.orientation + 4, msg.orientation);
      std::copy(out.velocity, out.velocity + 3, msg.velocity);
      std::copy(out.angular_velocity, out.angular_velocity + 3, msg.angular_velocity);
      std::copy(out.covariance, out.covariance + 36, msg.covariance);
      msg.status = out.status;
      PublishMessage(sink, options_.odometry_channel, msg, &buffer_);
      if (out.global) {
        gmsg.utime = msg.utime;
        gmsg.seq = gseq++;
        std::copy(out.g_position, out.g_position + 3, gmsg.position);
        std::copy(out.g_orientation, out.g_orientation + 4, gmsg.orientation);
        std::copy(out.g_velocity, out.g_velocity + 3, gmsg.velocity);
        std::copy(out.angular_velocity, out.angular_velocity + 3, gmsg.angular_velocity);
        std::copy(out.g_covariance, out.g_covariance + 36, gmsg.covariance);
        gmsg.status = pose_t::LOCALIZED;
        PublishMessage(sink, options_.pose_channel, gmsg, &buffer_);
        p_.counters.Add(kLocPosesPublished);
      }
      const int64_t published = SteadyNs();
      p_.counters.Add(kPosesPublished);
      lat_receive_.Add(static_cast<double>(out.recv_latency_us) * 1e-3);
      lat_sync_.Add(static_cast<double>(out.synced_steady_ns - out.recv_steady_ns) * 1e-6);
      lat_filter_wait_.Add(static_cast<double>(out.filter_start_ns - out.synced_steady_ns) * 1e-6);
      lat_filter_.Add(static_cast<double>(out.filtered_steady_ns - out.filter_start_ns) * 1e-6);
      lat_publish_.Add(static_cast<double>(published - out.filtered_steady_ns) * 1e-6);
      lat_total_.Add(static_cast<double>(published - out.recv_steady_ns) * 1e-6);
    }
    const int64_t now = SteadyNs();
    if (now >= next_status_ns) {
      const int32_t state = status_seq_ == 0 ? static_cast<int32_t>(status_t::STARTING)
                                             : static_cast<int32_t>(status_t::OK);
      PublishStatus(sink, state, now);
      next_status_ns = std::max(next_status_ns + period_ns, now + period_ns / 2);
    }
    if (!any) {
      if (p_.filter_done.load() && queue_.read_available() == 0 &&
          (!options_.wait_for_map || p_.map_done.load())) {
        break;
      }
      p_.output_wake.Wait(std::min<int64_t>(50 * kMs, std::max<int64_t>(kMs, next_status_ns - now)));
    }
  }
  PublishStatus(sink, status_t::STOPPING, SteadyNs());
}

}  // namespace vilma::daemon
