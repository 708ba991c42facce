#include "vilma/drivers/pose_log.h"

#include <cmath>
#include <exception>
#include <vilma/localization_t.hpp>
#include <vilma/pose_t.hpp>

#include "vilma/core/time.h"
#include "vilma/drivers/lcm_log.h"

namespace vilma {
namespace {

// The pose of a message (pose_t or localization_t fields); false when it is not finite or the
// quaternion is not a unit one (a malformed message).
bool PoseOf(const double position[3], const double orientation_wxyz[4], Transformation* T) {
  const Eigen::Vector3d p(position[0], position[1], position[2]);
  const Eigen::Quaterniond q(orientation_wxyz[0], orientation_wxyz[1], orientation_wxyz[2],
                             orientation_wxyz[3]);
  if (!p.allFinite() || !q.coeffs().allFinite() || std::abs(q.norm() - 1.0) > 1e-3) return false;
  *T = Transformation(q, p);
  return true;
}

// lcm-gen's decoders check a string's length against the buffer but throw std::length_error
// for a length <= 0 (they assign length - 1 bytes): a corrupted event is then malformed, not
// the end of the tool.
template <typename Msg>
bool Decodes(Msg* msg, const LcmLogEvent& event) {
  try {
    return msg->decode(event.data.data(), 0, static_cast<int>(event.data.size())) >= 0;
  } catch (const std::exception&) {
    return false;
  }
}

// Calls on_message(msg) for every message on `channel` that decodes as Msg, in log order;
// counts the channel's events and the ones that do not decode.
template <typename Msg, typename Fn>
void ForEachMessage(const std::string& path, const std::string& channel,
                    int64_t* events_on_channel, int64_t* malformed, Fn on_message) {
  LcmLogReader reader(path);
  LcmLogEvent event;
  while (reader.Next(&event)) {
    if (event.channel != channel) continue;
    ++*events_on_channel;
    Msg msg;
    if (!Decodes(&msg, event)) {
      ++*malformed;
      continue;
    }
    on_message(msg);
  }
}

}  // namespace

Trajectory ReadPoseLog(const std::string& path, const std::string& channel,
                       bool include_not_valid, PoseLogStats* stats) {
  PoseLogStats local;
  PoseLogStats& s = stats != nullptr ? *stats : local;
  s = PoseLogStats();
  Trajectory trajectory;
  ForEachMessage<pose_t>(path, channel, &s.events_on_channel, &s.malformed, [&](const pose_t& msg) {
    Transformation T;
    if (!PoseOf(msg.position, msg.orientation, &T)) {
      ++s.malformed;
    } else if (!include_not_valid &&
               (msg.status == pose_t::INVALID || msg.status == pose_t::INITIALIZING)) {
      ++s.not_valid;
    } else {
      trajectory.Add(UtimeToNs(msg.utime), T);
    }
  });
  return trajectory;
}

PoseLogType DetectPoseLogType(const std::string& path, const std::string& channel) {
  LcmLogReader reader(path);
  LcmLogEvent event;
  bool seen = false;
  while (reader.Next(&event)) {
    if (event.channel != channel) continue;
    seen = true;
    // decode() checks the fingerprint (the type's hash in the first 8 bytes) first.
    pose_t pose;
    if (Decodes(&pose, event)) return PoseLogType::kPose;
    localization_t loc;
    if (Decodes(&loc, event)) return PoseLogType::kLocalization;
  }
  return seen ? PoseLogType::kOther : PoseLogType::kEmpty;
}

Trajectory ReadLocalizationLog(const std::string& path, const std::string& channel,
                               LocalizationLogStats* stats) {
  LocalizationLogStats local;
  LocalizationLogStats& s = stats != nullptr ? *stats : local;
  s = LocalizationLogStats();
  Trajectory trajectory;
  ForEachMessage<localization_t>(
      path, channel, &s.events_on_channel, &s.malformed, [&](const localization_t& msg) {
        ++s.attempts;
        if (msg.decision == "accepted") ++s.accepted;
        if (msg.status != "ok") return;
        Transformation T;
        if (!PoseOf(msg.position, msg.orientation, &T)) {
          ++s.malformed;
          return;
        }
        ++s.with_pose;
        trajectory.Add(UtimeToNs(msg.utime), T);
      });
  return trajectory;
}

std::string PoseLogStats::BriefReport() const {
  return std::to_string(events_on_channel) + " messages, " + std::to_string(malformed) +
         " malformed, " + std::to_string(not_valid) + " not valid";
}

std::string LocalizationLogStats::BriefReport() const {
  return "attempts " + std::to_string(attempts) + ", with pose " + std::to_string(with_pose) +
         ", accepted " + std::to_string(accepted);
}

std::string LocalizationLogStats::FullReport() const {
  return BriefReport() + "\n" + std::to_string(events_on_channel) + " messages on the channel, " +
         std::to_string(malformed) + " malformed skipped\n";
}

}  // namespace vilma
