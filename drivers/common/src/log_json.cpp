#include "vilma/drivers/log_json.h"

#include <cmath>
#include <exception>
#include <vilma/pose_t.hpp>
#include <vilma/status_t.hpp>

#include "vilma/core/json.h"
#include "vilma/drivers/lcm_log.h"
#include "vilma/drivers/lcm_safe_decode.h"

namespace vilma {
namespace {

void WriteNumber(std::ostream& out, double x) {
  if (std::isfinite(x)) {
    out << x;
  } else {
    out << "null";
  }
}

void WriteStatus(const status_t& msg, std::ostream& out) {
  out << ",\"type\":\"status\",\"utime\":" << msg.utime << ",\"node\":" << JsonString(msg.node)
      << ",\"state\":" << msg.state << ",\"message\":" << JsonString(msg.message)
      << ",\"counters\":{";
  // lcm-gen's decoder sizes the arrays by num_counters / num_metrics.
  for (std::size_t i = 0; i < msg.counter_names.size(); ++i) {
    out << (i ? "," : "") << JsonString(msg.counter_names[i]) << ":" << msg.counter_values[i];
  }
  out << "},\"metrics\":{";
  for (std::size_t i = 0; i < msg.metric_names.size(); ++i) {
    out << (i ? "," : "") << JsonString(msg.metric_names[i]) << ":";
    WriteNumber(out, msg.metric_values[i]);
  }
  out << "}}\n";
}

void WritePose(const pose_t& msg, std::ostream& out) {
  out << ",\"type\":\"pose\",\"utime\":" << msg.utime << ",\"seq\":" << msg.seq
      << ",\"status\":" << msg.status << ",\"position\":[";
  for (int i = 0; i < 3; ++i) {
    if (i) out << ",";
    WriteNumber(out, msg.position[i]);
  }
  out << "],\"orientation\":[";
  for (int i = 0; i < 4; ++i) {
    if (i) out << ",";
    WriteNumber(out, msg.orientation[i]);
  }
  out << "]}\n";
}

}  // namespace

LogJsonStats WriteLogJson(const std::string& path, const std::regex& channel_regex,
                          std::ostream& out) {
  LogJsonStats stats;
  LcmLogReader reader(path);
  LcmLogEvent event;
  status_t status;
  pose_t pose;
  const auto old_precision = out.precision(17);
  while (reader.Next(&event)) {
    if (!std::regex_match(event.channel, channel_regex)) continue;
    ++stats.events_matched;
    const int size = static_cast<int>(event.data.size());
    // decode() checks the type's fingerprint first, so each event decodes as one type at most.
    // lcm-gen's decoders throw std::length_error on a string length of 0 (a corrupted or
    // hostile event, docs/reliability.md): such an event is skipped like any undecodable one.
    // status_t goes through DecodeStatusMessage, which bounds its array counts before lcm-gen
    // allocates them (lcm_safe_decode.h); pose_t has fixed arrays and checked strings.
    int decoded_as = 0;
    try {
      if (DecodeStatusMessage(event.data.data(), size, &status).empty()) {
        decoded_as = 1;
      } else if (pose.decode(event.data.data(), 0, size) >= 0) {
        decoded_as = 2;
      }
    } catch (const std::exception&) {
      decoded_as = 0;
    }
    if (decoded_as == 1) {
      out << "{\"log_us\":" << event.timestamp_us << ",\"channel\":" << JsonString(event.channel);
      WriteStatus(status, out);
      ++stats.status;
    } else if (decoded_as == 2) {
      out << "{\"log_us\":" << event.timestamp_us << ",\"channel\":" << JsonString(event.channel);
      WritePose(pose, out);
      ++stats.poses;
    } else {
      ++stats.skipped;
    }
  }
  out.precision(old_precision);
  return stats;
}

std::string LogJsonStats::BriefReport() const {
  return std::to_string(status) + " status_t, " + std::to_string(poses) + " pose_t, " +
         std::to_string(skipped) + " other events skipped";
}

}  // namespace vilma
