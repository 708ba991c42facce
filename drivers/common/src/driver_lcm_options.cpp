#include "vilma/drivers/driver_lcm_options.h"

#include <algorithm>
#include <cmath>
#include <sstream>

#include "vilma/core/options_fields.h"
#include "vilma/core/validate.h"
#include "vilma/drivers/driver_status.h"
#include "vilma/drivers/lcm_url.h"

namespace vilma {
std::string DriverLcmOptions::DataChannel() const { return ChannelName(channel, channel_suffix); }

std::string DriverLcmOptions::StatusChannel() const {
  return ChannelName(status_channel.empty() ? DefaultStatusChannel(channel) : status_channel,
                     channel_suffix);
}

std::string DriverLcmOptions::ValidateLcm() const {
  const std::string channel_error = ValidateChannelName(DataChannel());
  if (!channel_error.empty()) return "channel: " + channel_error;
  const std::string status_error = ValidateChannelName(StatusChannel());
  if (!status_error.empty()) return "status_channel: " + status_error;
  if (StatusChannel() == DataChannel()) {
    return "status_channel: expected another channel than channel";
  }
  // Below 0.05 s the status traffic competes with the data; above a minute a monitor
  // (lcm-spy, the daemon's watchdog) cannot tell a stalled driver from a slow one.
  if (!(std::isfinite(status_period_s) && status_period_s >= 0.05 && status_period_s <= 60.0)) {
    return "status_period_s: expected 0.05 .. 60 [s]";
  }
  if (!(std::isfinite(seconds) && seconds >= 0.0)) return "seconds: expected >= 0 (0 = no limit)";
  return "";
}

std::string DriverLcmOptionsYaml(const DriverLcmOptions& o) {
  return OptionFieldsToYaml(o, [](auto& options, auto&& v) { VisitDriverLcmFields(options, v); });
}

bool ParseDriverLcmFlag(ArgCursor& arg, DriverLcmOptions* o) {
  const std::string& name = arg.name();
  if (name == "--lcm-url") {
    o->lcm_url = arg.Value();
  } else if (name == "--channel") {
    o->channel = arg.Value();
  } else if (name == "--channel-suffix") {
    o->channel_suffix = arg.Value();
  } else if (name == "--status-channel") {
    o->status_channel = arg.Value();
  } else if (name == "--status-period-s") {
    o->status_period_s = arg.DoubleValue();
  } else if (name == "--seconds") {
    o->seconds = arg.DoubleValue();
  } else {
    return false;
  }
  return true;
}

std::string DriverLcmUsage(const DriverLcmOptions& d, int column) {
  std::ostringstream out;
  auto line = [&](const std::string& flag, const std::string& text) {
    std::string head = "  " + flag;
    head.resize(std::max<std::size_t>(head.size() + 1, static_cast<std::size_t>(column)), ' ');
    out << head << text << "\n";
  };
  std::ostringstream period, seconds;
  period << d.status_period_s;
  seconds << d.seconds;
  line("--lcm-url URL", std::string("LCM provider [$LCM_DEFAULT_URL or ") + kDefaultLcmUrl + "]");
  line("--channel NAME", "data channel [" + d.channel + "]");
  line("--channel-suffix S", "appended to every channel name, e.g. _R2 [" + d.channel_suffix + "]");
  line("--status-channel NAME", "status_t channel [VILMA_STATUS_<channel>]");
  line("--status-period-s S", "status report period, 0.05 .. 60 [" + period.str() + "]");
  line("--seconds S", "stop after S seconds; 0 = until SIGINT/SIGTERM [" + seconds.str() + "]");
  return out.str();
}

}  // namespace vilma
