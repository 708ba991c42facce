// systemd service notification (sd_notify(3), libsystemd): READY=1, WATCHDOG=1, STOPPING=1,
// STATUS=... When the process does not run under systemd (no $NOTIFY_SOCKET) every call is a
// cheap no-op.
#pragma once

#include <cstdint>
#include <string>

namespace vilma::daemon {

class SystemdNotifier {
 public:
  SystemdNotifier();
  bool enabled() const { return enabled_; }
  // Watchdog period from $WATCHDOG_USEC (0 if the watchdog is off) [us].
  uint64_t watchdog_usec() const { return watchdog_usec_; }

  void Ready() const;
  void Stopping() const;
  void Status(const std::string& text) const;
  // Pets the watchdog, at most every watchdog_usec / 4 (rate limited by the caller's clock
  // `now_ns` [steady ns]); call it as often as convenient from the loop that must make progress.
  void PetWatchdog(int64_t now_ns);

 private:
  bool enabled_ = false;
  uint64_t watchdog_usec_ = 0;
  int64_t last_pet_ns_ = 0;
};

}  // namespace vilma::daemon
