#include "vilma/drivers/lcm_rates.h"

#include <algorithm>
#include <cstdio>
#include <cstring>
#include <sstream>

#include <vilma/image_t.hpp>
#include <vilma/imu_t.hpp>

#include "vilma/drivers/lcm_convert.h"

namespace vilma {

namespace {

// True if the message starts with the type hash of image_t or imu_t (big endian).
bool IsSequencedType(const void* data, int size) {
  if (size < 8) return false;
  const auto* p = static_cast<const uint8_t*>(data);
  uint64_t hash = 0;
  for (int i = 0; i < 8; ++i) hash = (hash << 8) | p[i];
  return hash == static_cast<uint64_t>(image_t::getHash()) ||
         hash == static_cast<uint64_t>(imu_t::getHash());
}

}  // namespace

void LcmRateMonitor::OnMessage(const std::string& channel, const void* data, int size,
                               double t_s) {
  ChannelStats& s = channels_[channel];
  if (s.messages == 0) s.first_s = t_s;
  s.last_s = t_s;
  ++s.messages;
  s.bytes += size;
  ++s.window_messages;
  s.window_bytes += size;
  int64_t utime = 0, seq = 0;
  if (IsSequencedType(data, size) && PeekUtimeAndSeq(data, size, &utime, &seq)) {
    s.sequenced = true;
    if (s.last_seq >= 0) {
      if (seq > s.last_seq + 1) {
        s.lost += seq - s.last_seq - 1;
      } else if (seq <= s.last_seq) {
        ++s.out_of_order;
      }
    }
    s.last_seq = std::max(s.last_seq, seq);
  }
}

std::string LcmRateMonitor::PeriodicReport(double window_s) {
  std::ostringstream out;
  char line[256];
  for (auto& [name, s] : channels_) {
    std::snprintf(line, sizeof(line), "  %-20s %8.1f msg/s %8.2f MB/s  total %8lld  lost %lld\n",
                  name.c_str(), s.window_messages / window_s, s.window_bytes * 1e-6 / window_s,
                  static_cast<long long>(s.messages), static_cast<long long>(s.lost));
    out << line;
    s.window_messages = 0;
    s.window_bytes = 0;
  }
  return out.str();
}

std::string LcmRateMonitor::BriefReport() const {
  int64_t out_of_order = 0;
  for (const auto& entry : channels_) out_of_order += entry.second.out_of_order;
  char line[160];
  std::snprintf(line, sizeof(line), "%zu channels, %lld messages, %.2f MB, %lld lost, %lld out of order",
                channels_.size(), static_cast<long long>(total_messages()), total_bytes() * 1e-6,
                static_cast<long long>(total_lost()), static_cast<long long>(out_of_order));
  return line;
}

std::string LcmRateMonitor::FullReport() const {
  std::ostringstream out;
  char line[256];
  std::snprintf(line, sizeof(line), "%-20s %10s %10s %10s %10s %8s %8s\n", "channel", "messages",
                "MB", "msg/s", "MB/s", "lost", "ooo");
  out << line;
  double first = 0.0, last = 0.0;
  bool any = false;
  int64_t out_of_order = 0;
  for (const auto& [name, s] : channels_) {
    // Rate over the channel's active span; (n - 1) intervals between n messages.
    const double span = s.last_s - s.first_s;
    const double rate = (s.messages > 1 && span > 0) ? (s.messages - 1) / span : 0.0;
    const double mb_rate = (s.messages > 1 && span > 0) ? s.bytes * 1e-6 / span : 0.0;
    std::snprintf(line, sizeof(line), "%-20s %10lld %10.2f %10.1f %10.2f %8s %8lld\n",
                  name.c_str(), static_cast<long long>(s.messages), s.bytes * 1e-6, rate, mb_rate,
                  s.sequenced ? std::to_string(s.lost).c_str() : "-",
                  static_cast<long long>(s.out_of_order));
    out << line;
    first = any ? std::min(first, s.first_s) : s.first_s;
    last = any ? std::max(last, s.last_s) : s.last_s;
    any = true;
    out_of_order += s.out_of_order;
  }
  const double span = last - first;
  std::snprintf(line, sizeof(line), "%-20s %10lld %10.2f %10.1f %10.2f %8lld %8lld\n", "total",
                static_cast<long long>(total_messages()), total_bytes() * 1e-6,
                span > 0 ? total_messages() / span : 0.0, span > 0 ? total_bytes() * 1e-6 / span : 0.0,
                static_cast<long long>(total_lost()), static_cast<long long>(out_of_order));
  out << line;
  std::snprintf(line, sizeof(line), "TOTAL messages=%lld bytes=%lld lost=%lld out_of_order=%lld "
                "duration_s=%.3f\n",
                static_cast<long long>(total_messages()), static_cast<long long>(total_bytes()),
                static_cast<long long>(total_lost()), static_cast<long long>(out_of_order), span);
  out << line;
  return out.str();
}

int64_t LcmRateMonitor::total_messages() const {
  int64_t n = 0;
  for (const auto& entry : channels_) n += entry.second.messages;
  return n;
}

int64_t LcmRateMonitor::total_bytes() const {
  int64_t n = 0;
  for (const auto& entry : channels_) n += entry.second.bytes;
  return n;
}

int64_t LcmRateMonitor::total_lost() const {
  int64_t n = 0;
  for (const auto& entry : channels_) n += entry.second.lost;
  return n;
}

}  // namespace vilma
