#include "vilma/drivers/lcm_url.h"

#include <catch2/catch.hpp>
#include <cstdlib>

namespace vilma {
namespace {

TEST_CASE("DefaultLcmUrl honours LCM_DEFAULT_URL", "[lcm]") {
  const char* old = std::getenv("LCM_DEFAULT_URL");
  const std::string saved = old ? old : "";
  ::unsetenv("LCM_DEFAULT_URL");
  CHECK(DefaultLcmUrl() == "udpm://239.255.76.67:7667?ttl=0");
  CHECK(ResolveLcmUrl("") == "udpm://239.255.76.67:7667?ttl=0");
  CHECK(ResolveLcmUrl("memq://") == "memq://");
  ::setenv("LCM_DEFAULT_URL", "udpm://239.255.76.67:7000?ttl=1", 1);
  CHECK(DefaultLcmUrl() == "udpm://239.255.76.67:7000?ttl=1");
  ::setenv("LCM_DEFAULT_URL", "", 1);
  CHECK(DefaultLcmUrl() == kDefaultLcmUrl);
  if (old) {
    ::setenv("LCM_DEFAULT_URL", saved.c_str(), 1);
  } else {
    ::unsetenv("LCM_DEFAULT_URL");
  }
}

TEST_CASE("URL parameters are read, replaced and appended", "[lcm]") {
  const std::string url = "udpm://239.255.76.67:7667?ttl=0";
  CHECK(LcmUrlParameter(url, "ttl") == "0");
  CHECK(LcmUrlParameter(url, "tt").empty());
  CHECK(LcmUrlParameter("udpm://239.255.76.67:7667", "ttl").empty());
  CHECK(WithLcmUrlParameter(url, "recv_buf_size", "100") ==
        "udpm://239.255.76.67:7667?ttl=0&recv_buf_size=100");
  CHECK(WithLcmUrlParameter(url, "ttl", "1") == "udpm://239.255.76.67:7667?ttl=1");
  CHECK(WithLcmUrlParameter("udpm://239.255.76.67:7667", "ttl", "0") == url);
  CHECK(WithLcmUrlParameter("udpm://a:1?ttl=0&recv_buf_size=5", "recv_buf_size", "7") ==
        "udpm://a:1?ttl=0&recv_buf_size=7");
  CHECK(LcmUrlParameter("udpm://a:1?ttl=0&recv_buf_size=5", "recv_buf_size") == "5");
}

TEST_CASE("WithDefaultRecvBufSize only touches udpm URLs without one", "[lcm]") {
  CHECK(WithDefaultRecvBufSize("udpm://239.255.76.67:7667?ttl=0") ==
        "udpm://239.255.76.67:7667?ttl=0&recv_buf_size=8388608");
  CHECK(WithDefaultRecvBufSize("udpm://a:1?ttl=0&recv_buf_size=1000") ==
        "udpm://a:1?ttl=0&recv_buf_size=1000");
  CHECK(WithDefaultRecvBufSize("memq://") == "memq://");
  CHECK(WithDefaultRecvBufSize("file:///tmp/x.log?mode=r") == "file:///tmp/x.log?mode=r");
}

TEST_CASE("Channel names: upper case, digits, underscore, with a suffix", "[lcm]") {
  CHECK(ValidateChannelName("CAM0").empty());
  CHECK(ValidateChannelName("VILMA_ODOM_R2").empty());
  CHECK_FALSE(ValidateChannelName("").empty());
  CHECK_FALSE(ValidateChannelName("cam0").empty());
  CHECK_FALSE(ValidateChannelName("CAM.*").empty());
  CHECK_FALSE(ValidateChannelName(std::string(64, 'A')).empty());
  CHECK(ChannelName("CAM0", "") == "CAM0");
  CHECK(ChannelName("CAM0", "_R2") == "CAM0_R2");
}

}  // namespace
}  // namespace vilma
