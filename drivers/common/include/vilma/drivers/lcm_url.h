// LCM provider URLs and channel names (architecture.md section 2).
//
// The default transport is UDP multicast confined to the host (ttl=0). Image messages
// (752x480 GRAY8 = 361 KB) are far larger than one UDP datagram: LCM fragments them into
// ~64 KB datagrams, and the kernel's receive buffer must hold a whole burst of them, or the
// receiver silently loses fragments and therefore whole messages. Receivers of images add
// `recv_buf_size` to their URL (see docs/lcm.md for the sysctl that allows large values).
#pragma once

#include <cstdint>
#include <string>

#include "vilma/core/validate.h"

namespace vilma {

// LCM's own default, confined to this host.
constexpr const char kDefaultLcmUrl[] = "udpm://239.255.76.67:7667?ttl=0";
// Receive buffer that holds ~20 full-size 752x480 images [bytes]; see docs/lcm.md.
constexpr int64_t kRecommendedRecvBufSize = 8388608;

// $LCM_DEFAULT_URL if set and not empty, else kDefaultLcmUrl.
std::string DefaultLcmUrl();

// `url` if not empty, else DefaultLcmUrl(): what a `--lcm-url` option resolves to.
std::string ResolveLcmUrl(const std::string& url);

// The value of query parameter `key` of `url` ("" if absent).
std::string LcmUrlParameter(const std::string& url, const std::string& key);

// `url` with query parameter key=value set (replaced if present, appended otherwise).
std::string WithLcmUrlParameter(const std::string& url, const std::string& key,
                                const std::string& value);

// For udpm:// URLs without a recv_buf_size parameter: adds recv_buf_size=bytes. Other URLs
// (memq://, file://, or an explicit recv_buf_size chosen by the user) are returned unchanged.
std::string WithDefaultRecvBufSize(const std::string& url,
                                   int64_t bytes = kRecommendedRecvBufSize);

// ValidateChannelName (core/validate.h): channel names are matched as regular expressions by
// LCM subscribers, so only [A-Z0-9_] is accepted.

// `base` + `suffix` (e.g. "CAM0" + "_R2" -> "CAM0_R2"): several robots or a replay can share
// one network by giving each a suffix.
std::string ChannelName(const std::string& base, const std::string& suffix);

}  // namespace vilma
