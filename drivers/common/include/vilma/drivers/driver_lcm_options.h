// What every driver shares: where it publishes (LCM URL, data and status channels, the
// robot's channel suffix), how often it reports its health and how long it runs. The three
// drivers' options structs (vilma-aravis, vilma-v4l2, vilma-usb-imu) extend this struct, so
// these keys are read, validated, written back (--print-config), parsed from flags and
// documented in --help by the functions below, once.
//
// YAML keys (flat, at the top level of each driver's file):
//   lcm_url, channel, channel_suffix, status_channel, status_period_s, seconds
// Flags: --lcm-url, --channel, --channel-suffix, --status-channel, --status-period-s, --seconds
#pragma once

#include <string>

#include "vilma/core/arg_cursor.h"
#include "vilma/core/yaml_io.h"

namespace vilma {

struct DriverLcmOptions {
  std::string lcm_url;         // "" = $LCM_DEFAULT_URL or LCM's default (ttl=0)
  std::string channel;         // data channel before the suffix (each driver sets its default)
  std::string channel_suffix;  // appended to every channel name (several robots, one network)
  std::string status_channel;  // status_t channel before the suffix; "" = VILMA_STATUS_<channel>
  double status_period_s = 1.0;  // status_t period [s]
  double seconds = 0.0;          // stop after this long [s]; 0 = until SIGINT/SIGTERM

  // The data channel with the suffix applied.
  std::string DataChannel() const;
  // (status_channel or VILMA_STATUS_<channel>) with the suffix applied.
  std::string StatusChannel() const;
  // "" or "field: expectation" for the fields above. (Named apart from the drivers'
  // Validate(), which call it.)
  std::string ValidateLcm() const;
};

// The field list of the keys above (core/options_fields.h), at the top level of a driver's
// file: each driver's own field list visits it (Options = a struct derived from
// DriverLcmOptions, const or not).
template <typename Options, typename Visitor>
void VisitDriverLcmFields(Options& o, Visitor&& v) {
  v("", "lcm_url", o.lcm_url);
  v("", "channel", o.channel);
  v("", "channel_suffix", o.channel_suffix);
  v("", "status_channel", o.status_channel);
  v("", "status_period_s", o.status_period_s);
  v("", "seconds", o.seconds);
}

// The keys above as block YAML lines ("key: value\n"), strings quoted, readable back by
// ReadOptionFields with the field list (OptionFieldsToYaml of the field list).
std::string DriverLcmOptionsYaml(const DriverLcmOptions& options);

// If the cursor's option is one of the flags above, consumes its value into *options and
// returns true; false for any other option. Throws UsageError for a bad value.
bool ParseDriverLcmFlag(ArgCursor& arg, DriverLcmOptions* options);

// The --help lines of the flags above, defaults from `defaults`; descriptions start at
// `column` (to line up with the driver's own flags).
std::string DriverLcmUsage(const DriverLcmOptions& defaults, int column = 28);

}  // namespace vilma
