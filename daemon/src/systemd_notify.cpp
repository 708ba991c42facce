#include "vilma/daemon/systemd_notify.h"

#include <systemd/sd-daemon.h>

#include <cstdlib>

namespace vilma::daemon {

SystemdNotifier::SystemdNotifier() {
  const char* socket = std::getenv("NOTIFY_SOCKET");
  enabled_ = socket != nullptr && socket[0] != '\0';
  uint64_t usec = 0;
  // > 0: the watchdog is on for this process (checks $WATCHDOG_PID when set).
  if (sd_watchdog_enabled(0, &usec) > 0) watchdog_usec_ = usec;
}

void SystemdNotifier::Ready() const {
  if (enabled_) sd_notify(0, "READY=1");
}

void SystemdNotifier::Stopping() const {
  if (enabled_) sd_notify(0, "STOPPING=1");
}

void SystemdNotifier::Status(const std::string& text) const {
  if (enabled_) sd_notify(0, ("STATUS=" + text).c_str());
}

void SystemdNotifier::PetWatchdog(int64_t now_ns) {
  if (!enabled_ || watchdog_usec_ == 0) return;
  // systemd recommends petting at half the period; a quarter leaves room for a slow frame.
  const int64_t interval_ns = static_cast<int64_t>(watchdog_usec_) * 1000 / 4;
  if (last_pet_ns_ != 0 && now_ns - last_pet_ns_ < interval_ns) return;
  last_pet_ns_ = now_ns;
  sd_notify(0, "WATCHDOG=1");
}

}  // namespace vilma::daemon
