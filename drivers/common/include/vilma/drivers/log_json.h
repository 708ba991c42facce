// Health reports and poses out of LCM logs as JSON lines, for the reliability scripts
// (scripts/soak.sh, scripts/sensor-faults.sh) that follow queue depths, drops, latency
// percentiles and the pose status over time without an LCM binding of their own.
#pragma once

#include <cstdint>
#include <ostream>
#include <regex>
#include <string>

namespace vilma {

struct LogJsonStats {
  int64_t events_matched = 0;  // events on a matching channel
  int64_t status = 0;          // written as vilma.status_t
  int64_t poses = 0;           // written as vilma.pose_t
  int64_t skipped = 0;         // neither type (by the LCM fingerprint) or corrupted

  // "S status_t, P pose_t, K other events skipped" (core/report.h's shape).
  std::string BriefReport() const;
  std::string FullReport() const { return BriefReport() + "\n"; }
};

// One line per event whose channel matches `channel_regex` (the whole name) and that decodes
// as vilma.status_t or vilma.pose_t (told apart by the LCM fingerprint), in log order:
//   {"log_us":E,"channel":"C","type":"status","utime":U,"node":"N","state":S,"message":"M",
//    "counters":{"name":v,...},"metrics":{"name":x,...}}
//   {"log_us":E,"channel":"C","type":"pose","utime":U,"seq":Q,"status":S,
//    "position":[x,y,z],"orientation":[w,x,y,z]}
// log_us is the event time (lcm-logger: receive time; vilma's writers: the message's utime)
// [us]; utime the message's own time [us] (status: wall clock; pose: sensor clock).
// Non-finite numbers are written as null (JSON has no NaN). Throws InputError naming the file
// if it cannot be read.
LogJsonStats WriteLogJson(const std::string& path, const std::regex& channel_regex,
                          std::ostream& out);

}  // namespace vilma
