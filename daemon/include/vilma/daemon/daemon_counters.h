// The estimator daemon's VILMA_STATUS counters. One list defines each counter's enum value
// and its published name together (an X-macro), so that a name can neither be missing nor be
// shifted against its value; a second table copies the synchronizer's counters by field, not
// by position, and the static_asserts below fail the build when a field is added to
// SensorSyncCounters without a counter here.
#pragma once

#include <array>
#include <cstddef>
#include <cstdint>
#include <string_view>

#include "vilma/core/sensor_sync.h"
#include "vilma/localizer/localizer.h"

namespace vilma::daemon {

// X(enum value, name in VILMA_STATUS). Each counter is written by one thread (relaxed atomics)
// and read by the publisher. docs/daemon.md "VILMA_STATUS" describes them.
// clang-format off
#define VILMA_DAEMON_COUNTERS(X) \
  X(kImuReceived, "imu_received")                                                                                      \
  X(kImagesReceived, "images_received")                                                                                \
  X(kMalformedImu, "malformed_imu")                                                                                    \
  X(kMalformedImages, "malformed_images")                                                                              \
  X(kImagesWrongSize, "images_wrong_size")                                                                             \
  X(kImagesDroppedPool, "images_dropped_pool")                                                                         \
  X(kImagesDroppedInputQueue, "images_dropped_input_queue")                                                            \
  X(kImuDroppedInputQueue, "imu_dropped_input_queue") /* a bug: the input queue is sized for seconds of IMU */         \
  X(kImuDroppedFilterQueue, "imu_dropped_filter_queue") /* a bug as well */                                            \
  X(kFramesDroppedBusy, "frames_dropped_busy") /* thinned: the filter was behind (max_frames_in_flight) */             \
  X(kFramesDroppedFilterQueue, "frames_dropped_filter_queue")                                                          \
  X(kFramesWithoutVioCamera, "frames_without_vio_camera")                                                              \
  X(kFramesWithoutStereo, "frames_without_stereo") /* stereo: frame without the second image, updated mono */         \
  X(kCameraSilences, "camera_silences")                                                                                \
  X(kTimeJumpRestarts, "time_jump_restarts") /* timestamp jumps that started a new filter */                          \
  X(kTimeJumpResumes, "time_jump_resumes") /* jumps back onto the pre-jump timeline: that filter resumed */        \
  X(kTimeJumpImuRestamped, "time_jump_imu_restamped") /* jumped IMU samples re-stamped into a resume's gap */       \
  X(kFramesFiltered, "frames_filtered")                                                                                \
  X(kFilterResets, "filter_resets")                                                                                    \
  X(kPosesPublished, "poses_published")                                                                                \
  X(kPosesDroppedOutput, "poses_dropped_output")                                                                       \
  X(kLcmErrors, "lcm_errors")                                                                                          \
  /* SensorSyncCounters, copied by the sync thread. */                                                                 \
  X(kSyncImuReceived, "sync_imu_received")                                                                             \
  X(kSyncImuDuplicates, "sync_imu_duplicates")                                                                         \
  X(kSyncImuOutOfOrder, "sync_imu_out_of_order")                                                                       \
  X(kSyncImuGaps, "sync_imu_gaps")                                                                                     \
  X(kSyncImuTimeJumps, "sync_imu_time_jumps")                                                                          \
  X(kSyncImuInvalid, "sync_imu_invalid") /* non-finite values: dropped */                                              \
  X(kSyncImuStale, "sync_imu_stale") /* still on the time base before a jump: dropped */                               \
  X(kSyncImuDiscarded, "sync_imu_discarded") /* accepted but pruned unused (imu_history_ns) */                         \
  X(kSyncImagesReceived, "sync_images_received")                                                                       \
  X(kSyncImagesDuplicate, "sync_images_duplicate")                                                                     \
  X(kSyncImagesOutOfOrder, "sync_images_out_of_order")                                                                 \
  X(kSyncImagesLate, "sync_images_late")                                                                               \
  X(kSyncImageTimeJumps, "sync_image_time_jumps")                                                                      \
  X(kSyncImagesInvalid, "sync_images_invalid") /* bad camera index, empty image, stamp overflow */                     \
  X(kSyncImagesStale, "sync_images_stale") /* still on the time base before a jump: dropped */                         \
  X(kSyncFramesReleased, "sync_frames_released")                                                                       \
  X(kSyncFramesIncomplete, "sync_frames_incomplete")                                                                   \
  X(kSyncFramesDroppedNoImu, "sync_frames_dropped_no_imu")                                                             \
  X(kSyncFramesDroppedOverflow, "sync_frames_dropped_overflow")                                                        \
  X(kSyncFramesDroppedTimeJump, "sync_frames_dropped_time_jump") /* pending when a time jump cleared history */        \
  /* Map-builder stage (docs/daemon.md "Map building"). */                                                             \
  X(kMapFramesQueued, "map_frames_queued") /* frames (state + images) handed to the builder */                         \
  X(kMapFramesThinned, "map_frames_thinned") /* tracking frames the builder does not want (vertex rate) */             \
  X(kMapFramesDropped, "map_frames_dropped") /* live: the builder was behind (mapping.max_frames_in_flight / queue) */ \
  X(kMapImuDropped, "map_imu_dropped") /* a bug: the queue is sized for tens of seconds of IMU */                      \
  X(kMapVertices, "map_vertices")                                                                                      \
  X(kMapImuEdges, "map_imu_edges")                                                                                     \
  X(kMapKeypoints, "map_keypoints")                                                                                    \
  X(kMapLandmarks, "map_landmarks")                                                                                    \
  X(kMapLandmarksGood, "map_landmarks_good")                                                                           \
  X(kMapVertexUsMean, "map_vertex_us_mean") /* builder time per vertex [us], mean and max */                           \
  X(kMapVertexUsMax, "map_vertex_us_max")                                                                              \
  X(kMapDeltas, "map_deltas") /* deltas taken for the stream */                                                        \
  X(kMapMissions, "map_missions") /* missions started (a new one after each filter reset / restart) */                 \
  X(kMapMissionsDropped, "map_missions_dropped") /* ended with fewer than 2 vertices: neither saved nor streamed */    \
  X(kMapVerticesHeld, "map_vertices_held") /* gauge: vertices of the mission in memory (streaming: bounded) */         \
  X(kMapBytesHeld, "map_bytes_held") /* gauge: their estimated heap bytes, with edges, landmarks, tracks */            \
  X(kStreamSent, "stream_sent") /* chunks queued (each transmitted once, then resent until acked) */                   \
  X(kStreamAcked, "stream_acked")                                                                                      \
  X(kStreamRetransmitted, "stream_retransmitted")                                                                      \
  X(kStreamWindowFull, "stream_window_full") /* Send()/End() refused: the window was full (the delta waits) */         \
  X(kStreamDiskFullAcks, "stream_disk_full_acks")                                                                      \
  X(kStreamErrorAcks, "stream_error_acks")                                                                             \
  X(kStreamBacklog, "stream_backlog") /* deltas waiting for window space */                                            \
  /* Localization stage (docs/daemon.md "Localization"). */                                                            \
  X(kLocAttempts, "loc_attempts") /* frames handed to the localizer */                                                 \
  X(kLocThinned, "loc_thinned") /* tracking frames not wanted (max_rate_hz) */                                         \
  X(kLocBusy, "loc_busy") /* live: wanted, but the localizer was still busy (not a drop) */                            \
  X(kLocOk, "loc_ok") /* library statuses */                                                                           \
  X(kLocNoKeypoints, "loc_no_keypoints")                                                                               \
  X(kLocNoDescriptorMatches, "loc_no_descriptor_matches")                                                              \
  X(kLocTooFewMatches, "loc_too_few_matches")                                                                          \
  X(kLocRansacFailed, "loc_ransac_failed")                                                                             \
  X(kLocTooFewInliers, "loc_too_few_inliers")                                                                          \
  X(kLocLowInlierRatio, "loc_low_inlier_ratio") /* acceptance gates, docs/localizer.md */                              \
  X(kLocHighReprojectionError, "loc_high_reprojection_error")                                                          \
  X(kLocClusteredInliers, "loc_clustered_inliers")                                                                     \
  X(kLocUncertainPose, "loc_uncertain_pose")                                                                           \
  X(kLocAmbiguousPose, "loc_ambiguous_pose")                                                                           \
  X(kLocRejectedInliers, "loc_rejected_inliers") /* ok, but fewer than localization.min_inliers */                     \
  X(kLocRejectedGravity, "loc_rejected_gravity") /* T_G_M not a yaw rotation */                                        \
  X(kLocRejectedJump, "loc_rejected_jump") /* gated against the estimate */                                            \
  X(kLocRejectedStale, "loc_rejected_stale") /* result for a previous M frame (filter restart / reset meanwhile) */    \
  X(kLocTgmUpdates, "loc_tgm_updates") /* accepted into the T_G_M estimate */                                          \
  X(kLocTgmResets, "loc_tgm_resets") /* estimate dropped (filter restart/reset, or re-initialized) */                  \
  X(kLocInitialized, "loc_initialized") /* gauge: 1 when VILMA_POSE is published */                                    \
  X(kLocPosesPublished, "loc_poses_published")                                                                         \
  X(kLocStageUsP50, "loc_stage_us_p50") /* localizer stage time per query (extract + Localize) [us] */                 \
  X(kLocStageUsMax, "loc_stage_us_max")                                                                                \
  X(kLocMessagesPublished, "loc_messages_published") /* VILMA_LOC messages (one per attempt) */                        \
  X(kLocMessagesDropped, "loc_messages_dropped") /* live: the publisher queue was full */                              \
// clang-format on

enum Counter : int {
#define VILMA_DAEMON_COUNTER_ENUM(id, name) id,
  VILMA_DAEMON_COUNTERS(VILMA_DAEMON_COUNTER_ENUM)
#undef VILMA_DAEMON_COUNTER_ENUM
  kNumCounters
};

struct CounterInfo {
  Counter id;
  const char* name;  // snake_case, as published in status_t.counter_names
};

inline constexpr std::array<CounterInfo, kNumCounters> kCounters = {{
#define VILMA_DAEMON_COUNTER_INFO(id, name) {id, name},
    VILMA_DAEMON_COUNTERS(VILMA_DAEMON_COUNTER_INFO)
#undef VILMA_DAEMON_COUNTER_INFO
}};

namespace counters_detail {
constexpr bool EveryCounterNamedInOrder() {
  for (std::size_t i = 0; i < kCounters.size(); ++i) {
    if (kCounters[i].id != static_cast<Counter>(i)) return false;
    if (kCounters[i].name == nullptr || kCounters[i].name[0] == '\0') return false;
  }
  return true;
}
}  // namespace counters_detail
static_assert(counters_detail::EveryCounterNamedInOrder(),
              "kCounters: one entry per Counter, in enum order, each with a name");

inline const char* CounterName(Counter c) { return kCounters[static_cast<std::size_t>(c)].name; }

// The synchronizer's counters (SensorSyncCounters) as daemon counters, field by field.
struct SyncCounterField {
  Counter id;
  int64_t SensorSyncCounters::*field;
};

inline constexpr std::array<SyncCounterField, 20> kSyncCounterFields = {{
    {kSyncImuReceived, &SensorSyncCounters::imu_received},
    {kSyncImuDuplicates, &SensorSyncCounters::imu_duplicates},
    {kSyncImuOutOfOrder, &SensorSyncCounters::imu_out_of_order},
    {kSyncImuGaps, &SensorSyncCounters::imu_gaps},
    {kSyncImuTimeJumps, &SensorSyncCounters::imu_time_jumps},
    {kSyncImuInvalid, &SensorSyncCounters::imu_invalid},
    {kSyncImuStale, &SensorSyncCounters::imu_stale},
    {kSyncImuDiscarded, &SensorSyncCounters::imu_discarded},
    {kSyncImagesReceived, &SensorSyncCounters::images_received},
    {kSyncImagesDuplicate, &SensorSyncCounters::images_duplicate},
    {kSyncImagesOutOfOrder, &SensorSyncCounters::images_out_of_order},
    {kSyncImagesLate, &SensorSyncCounters::images_late},
    {kSyncImageTimeJumps, &SensorSyncCounters::image_time_jumps},
    {kSyncImagesInvalid, &SensorSyncCounters::images_invalid},
    {kSyncImagesStale, &SensorSyncCounters::images_stale},
    {kSyncFramesReleased, &SensorSyncCounters::frames_released},
    {kSyncFramesIncomplete, &SensorSyncCounters::frames_incomplete},
    {kSyncFramesDroppedNoImu, &SensorSyncCounters::frames_dropped_no_imu},
    {kSyncFramesDroppedOverflow, &SensorSyncCounters::frames_dropped_overflow},
    {kSyncFramesDroppedTimeJump, &SensorSyncCounters::frames_dropped_time_jump},
}};

// Every field of SensorSyncCounters is an int64_t; a new one makes the struct larger than the
// table and stops the build here until it has a counter (and a row above).
static_assert(sizeof(SensorSyncCounters) == kSyncCounterFields.size() * sizeof(int64_t),
              "SensorSyncCounters has a field without a row in kSyncCounterFields");

namespace counters_detail {
constexpr bool SyncCountersDistinct() {
  for (std::size_t i = 0; i < kSyncCounterFields.size(); ++i) {
    const std::string_view name = kCounters[kSyncCounterFields[i].id].name;
    if (name.substr(0, 5) != "sync_") return false;
    for (std::size_t j = 0; j < i; ++j) {
      if (kSyncCounterFields[j].id == kSyncCounterFields[i].id) return false;
    }
  }
  return true;
}
}  // namespace counters_detail
static_assert(counters_detail::SyncCountersDistinct(),
              "kSyncCounterFields: each row a distinct sync_* counter");

// The counter that counts a localizer result with this status (a switch, not an offset from
// kLocOk, so that a new status fails -Wswitch instead of counting as its neighbour).
inline Counter LocStatusCounter(localizer::LocalizationStatus status) {
  using localizer::LocalizationStatus;
  switch (status) {
    case LocalizationStatus::kOk: return kLocOk;
    case LocalizationStatus::kNoKeypoints: return kLocNoKeypoints;
    case LocalizationStatus::kNoDescriptorMatches: return kLocNoDescriptorMatches;
    case LocalizationStatus::kTooFewMatches: return kLocTooFewMatches;
    case LocalizationStatus::kRansacFailed: return kLocRansacFailed;
    case LocalizationStatus::kTooFewInliers: return kLocTooFewInliers;
    case LocalizationStatus::kLowInlierRatio: return kLocLowInlierRatio;
    case LocalizationStatus::kHighReprojectionError: return kLocHighReprojectionError;
    case LocalizationStatus::kClusteredInliers: return kLocClusteredInliers;
    case LocalizationStatus::kUncertainPose: return kLocUncertainPose;
    case LocalizationStatus::kAmbiguousPose: return kLocAmbiguousPose;
    case LocalizationStatus::kNumStatuses: break;
  }
  return kLocOk;  // unreachable for a valid status; the switch above is exhaustive
}

}  // namespace vilma::daemon
