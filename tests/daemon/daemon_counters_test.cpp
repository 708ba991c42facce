#include "vilma/daemon/daemon_counters.h"

#include <catch2/catch.hpp>
#include <map>
#include <set>
#include <string>

namespace vilma::daemon {
namespace {

// The published name as the enum value spells it: kSyncImagesLate -> "sync_images_late".
std::string SnakeCase(const std::string& id) {
  std::string out;
  for (std::size_t i = 1; i < id.size(); ++i) {  // skip the 'k'
    const char c = id[i];
    if (c >= 'A' && c <= 'Z') {
      if (i > 1) out += '_';
      out += static_cast<char>(c - 'A' + 'a');
    } else {
      out += c;
    }
  }
  return out;
}

TEST_CASE("daemon counters: every counter has its own name, spelled as its enum value") {
  std::set<std::string> names;
  int index = 0;
#define CHECK_COUNTER(id, name)                         \
  CHECK(static_cast<int>(id) == index);                 \
  CHECK(std::string(CounterName(id)) == name);          \
  CHECK(SnakeCase(#id) == name);                        \
  names.insert(name);                                   \
  ++index;
  VILMA_DAEMON_COUNTERS(CHECK_COUNTER)
#undef CHECK_COUNTER
  CHECK(index == kNumCounters);
  CHECK(static_cast<int>(names.size()) == kNumCounters);  // no name twice
  CHECK(std::string(CounterName(kSyncFramesDroppedOverflow)) == "sync_frames_dropped_overflow");
  CHECK(std::string(CounterName(kLocMessagesDropped)) == "loc_messages_dropped");
}

TEST_CASE("daemon counters: the synchronizer's counters are copied field by field, by name") {
  // Every field gets a distinct value, assigned by its name (not through the table).
  SensorSyncCounters s;
  s.imu_received = 101;
  s.imu_duplicates = 102;
  s.imu_out_of_order = 103;
  s.imu_gaps = 104;
  s.imu_time_jumps = 105;
  s.imu_invalid = 106;
  s.imu_stale = 107;
  s.imu_discarded = 108;
  s.images_received = 109;
  s.images_duplicate = 110;
  s.images_out_of_order = 111;
  s.images_late = 112;
  s.image_time_jumps = 113;
  s.images_invalid = 114;
  s.images_stale = 115;
  s.frames_released = 116;
  s.frames_incomplete = 117;
  s.frames_dropped_no_imu = 118;
  s.frames_dropped_overflow = 119;
  s.frames_dropped_time_jump = 120;
  const std::map<std::string, int64_t> expected = {
      {"sync_imu_received", 101},        {"sync_imu_duplicates", 102},
      {"sync_imu_out_of_order", 103},    {"sync_imu_gaps", 104},
      {"sync_imu_time_jumps", 105},      {"sync_imu_invalid", 106},
      {"sync_imu_stale", 107},           {"sync_imu_discarded", 108},
      {"sync_images_received", 109},     {"sync_images_duplicate", 110},
      {"sync_images_out_of_order", 111}, {"sync_images_late", 112},
      {"sync_image_time_jumps", 113},    {"sync_images_invalid", 114},
      {"sync_images_stale", 115},        {"sync_frames_released", 116},
      {"sync_frames_incomplete", 117},   {"sync_frames_dropped_no_imu", 118},
      {"sync_frames_dropped_overflow", 119}, {"sync_frames_dropped_time_jump", 120}};

  // What the daemon's sync stage does: copy through kSyncCounterFields into its counters.
  std::array<int64_t, kNumCounters> counters{};
  for (const SyncCounterField& f : kSyncCounterFields) counters[f.id] = s.*f.field;

  std::map<std::string, int64_t> published;
  for (const CounterInfo& c : kCounters) {
    if (std::string(c.name).rfind("sync_", 0) == 0) published[c.name] = counters[c.id];
  }
  CHECK(published == expected);
}

TEST_CASE("daemon counters: each localizer status counts into its own counter") {
  using localizer::LocalizationStatus;
  CHECK(LocStatusCounter(LocalizationStatus::kOk) == kLocOk);
  CHECK(LocStatusCounter(LocalizationStatus::kNoKeypoints) == kLocNoKeypoints);
  CHECK(LocStatusCounter(LocalizationStatus::kNoDescriptorMatches) == kLocNoDescriptorMatches);
  CHECK(LocStatusCounter(LocalizationStatus::kTooFewMatches) == kLocTooFewMatches);
  CHECK(LocStatusCounter(LocalizationStatus::kRansacFailed) == kLocRansacFailed);
  CHECK(LocStatusCounter(LocalizationStatus::kTooFewInliers) == kLocTooFewInliers);
  CHECK(LocStatusCounter(LocalizationStatus::kLowInlierRatio) == kLocLowInlierRatio);
  CHECK(LocStatusCounter(LocalizationStatus::kHighReprojectionError) == kLocHighReprojectionError);
  CHECK(LocStatusCounter(LocalizationStatus::kClusteredInliers) == kLocClusteredInliers);
  CHECK(LocStatusCounter(LocalizationStatus::kUncertainPose) == kLocUncertainPose);
  CHECK(LocStatusCounter(LocalizationStatus::kAmbiguousPose) == kLocAmbiguousPose);
  // The counter's name carries the status's name (LocalizationStatusName: e.g. "ransac_failed").
  for (int i = 0; i < static_cast<int>(LocalizationStatus::kNumStatuses); ++i) {
    const auto status = static_cast<LocalizationStatus>(i);
    CHECK(std::string(CounterName(LocStatusCounter(status))) ==
          std::string("loc_") + LocalizationStatusName(status));
  }
}

}  // namespace
}  // namespace vilma::daemon
