#include "vilma/drivers/replay_faults.h"

#include <cmath>
#include <cstdlib>
#include <sstream>

#include "vilma/core/time.h"

namespace vilma {
namespace {

struct KindName {
  ReplayFaultKind kind;
  const char* name;
  int numbers;  // after the name: START:DURATION[:OFFSET]
};

constexpr KindName kKinds[] = {{ReplayFaultKind::kCameraDrop, "camera-drop", 2},
                               {ReplayFaultKind::kImuGap, "imu-gap", 2},
                               {ReplayFaultKind::kTimeJump, "time-jump", 3},
                               {ReplayFaultKind::kDuplicate, "duplicate", 2},
                               {ReplayFaultKind::kCameraHalfRate, "camera-half-rate", 2}};

// Longest fault window: a day, far below what turns into int64 ns overflow.
constexpr double kMaxWindowS = 86400.0;

const char kForms[] =
    "camera-drop:START:DURATION, imu-gap:START:DURATION, time-jump:START:DURATION:OFFSET, "
    "duplicate:START:DURATION or camera-half-rate:START:DURATION (seconds)";

}  // namespace

std::string ReplayFault::Validate() const {
  if (!(std::isfinite(start_s) && start_s >= 0.0 && start_s <= kMaxWindowS)) {
    return "START must be in [0, 86400] s";
  }
  if (!(std::isfinite(duration_s) && duration_s > 0.0 && duration_s <= kMaxWindowS)) {
    return "DURATION must be in (0, 86400] s";
  }
  if (kind == ReplayFaultKind::kTimeJump &&
      !(std::isfinite(offset_s) && offset_s != 0.0 && std::abs(offset_s) <= kMaxTimeJumpS)) {
    return "OFFSET must be non-zero with |OFFSET| <= 1e6 s";
  }
  return "";
}

std::string ReplayFault::ToString() const {
  std::ostringstream out;
  for (const KindName& k : kKinds) {
    if (k.kind == kind) out << k.name;
  }
  out << ":" << start_s << ":" << duration_s;
  if (kind == ReplayFaultKind::kTimeJump) out << ":" << offset_s;
  return out.str();
}

std::string ParseReplayFault(const std::string& text, ReplayFault* fault) {
  std::vector<std::string> parts;
  std::stringstream ss(text);
  std::string part;
  while (std::getline(ss, part, ':')) parts.push_back(part);
  const KindName* kind = nullptr;
  for (const KindName& k : kKinds) {
    if (!parts.empty() && parts[0] == k.name) kind = &k;
  }
  if (kind == nullptr || static_cast<int>(parts.size()) != 1 + kind->numbers) {
    return "--fault '" + text + "': expected " + kForms;
  }
  double values[3] = {0.0, 0.0, 0.0};
  for (int i = 0; i < kind->numbers; ++i) {
    const std::string& t = parts[static_cast<size_t>(i) + 1];
    char* end = nullptr;
    values[i] = std::strtod(t.c_str(), &end);
    if (t.empty() || end == nullptr || *end != '\0' || !std::isfinite(values[i])) {
      return "--fault '" + text + "': '" + t + "' is not a number (expected " + kForms + ")";
    }
  }
  ReplayFault f;
  f.kind = kind->kind;
  f.start_s = values[0];
  f.duration_s = values[1];
  f.offset_s = values[2];
  const std::string error = f.Validate();
  if (!error.empty()) return "--fault '" + text + "': " + error;
  *fault = f;
  return "";
}

ReplayFaultAction ReplayFaultActionFor(const std::vector<ReplayFault>& faults, int64_t t_first_ns,
                                       int stream, int64_t t_ns, int64_t frame_index) {
  ReplayFaultAction action;
  bool dropped = false;
  for (const ReplayFault& f : faults) {
    const int64_t begin = t_first_ns + SecondsToNs(f.start_s);
    const int64_t end = begin + SecondsToNs(f.duration_s);
    if (t_ns < begin || t_ns >= end) continue;
    switch (f.kind) {
      case ReplayFaultKind::kCameraDrop:
        dropped |= stream >= 0;
        break;
      case ReplayFaultKind::kImuGap:
        dropped |= stream < 0;
        break;
      case ReplayFaultKind::kTimeJump:
        action.stamp_offset_ns += SecondsToNs(f.offset_s);
        break;
      case ReplayFaultKind::kDuplicate:
        action.copies *= 2;
        break;
      case ReplayFaultKind::kCameraHalfRate:
        dropped |= stream >= 0 && frame_index % 2 == 1;
        break;
    }
  }
  if (dropped) action.copies = 0;
  return action;
}

}  // namespace vilma
