#include "vilma/daemon/systemd_notify.h"

#include <sys/socket.h>
#include <sys/un.h>
#include <unistd.h>

#include <catch2/catch.hpp>
#include <cstdlib>
#include <string>
#include <vector>

namespace vilma::daemon {
namespace {

std::vector<std::string> Drain(int fd) {
  std::vector<std::string> messages;
  char buffer[512];
  ssize_t n;
  while ((n = ::recv(fd, buffer, sizeof(buffer), MSG_DONTWAIT)) > 0) {
    messages.emplace_back(buffer, static_cast<std::size_t>(n));
  }
  return messages;
}

TEST_CASE("systemd notifier: no-op without NOTIFY_SOCKET, protocol messages with it") {
  ::unsetenv("NOTIFY_SOCKET");
  ::unsetenv("WATCHDOG_USEC");
  {
    SystemdNotifier off;
    CHECK(!off.enabled());
    off.Ready();
    off.PetWatchdog(1);
  }
  const std::string path = "/tmp/vilma_notify_test_" + std::to_string(::getpid()) + ".sock";
  ::unlink(path.c_str());
  const int fd = ::socket(AF_UNIX, SOCK_DGRAM, 0);
  REQUIRE(fd >= 0);
  sockaddr_un addr{};
  addr.sun_family = AF_UNIX;
  std::snprintf(addr.sun_path, sizeof(addr.sun_path), "%s", path.c_str());
  REQUIRE(::bind(fd, reinterpret_cast<sockaddr*>(&addr), sizeof(addr)) == 0);
  ::setenv("NOTIFY_SOCKET", path.c_str(), 1);
  ::setenv("WATCHDOG_USEC", "400000", 1);
  SystemdNotifier on;
  CHECK(on.enabled());
  CHECK(on.watchdog_usec() == 400000);
  on.Ready();
  // Pets are rate limited to a quarter of the period (100 ms).
  on.PetWatchdog(1000000000);
  on.PetWatchdog(1050000000);
  on.PetWatchdog(1100000001);
  on.Stopping();
  const std::vector<std::string> m = Drain(fd);
  REQUIRE(m.size() == 4);
  CHECK(m[0] == "READY=1");
  CHECK(m[1] == "WATCHDOG=1");
  CHECK(m[2] == "WATCHDOG=1");
  CHECK(m[3] == "STOPPING=1");
  ::unsetenv("NOTIFY_SOCKET");
  ::unsetenv("WATCHDOG_USEC");
  ::close(fd);
  ::unlink(path.c_str());
}

}  // namespace
}  // namespace vilma::daemon
