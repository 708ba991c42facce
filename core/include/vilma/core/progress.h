// Progress and cancellation of long library calls (console commands: architecture.md section
// 10). A library function that may run for seconds takes a `ProgressObserver*` (nullptr: no
// reporting) and calls ReportProgress at safe points: places where stopping leaves its result
// well defined. When the observer asks to cancel, ReportProgress throws `Cancelled`; the
// function's documentation says what its output holds then. The console runs map-modifying
// commands on a copy of the map, so a cancelled command never touches the loaded map.
#pragma once

#include <cstddef>
#include <stdexcept>
#include <string>

namespace vilma {

// Thrown by ReportProgress when the observer asks to cancel.
class Cancelled : public std::runtime_error {
 public:
  Cancelled() : std::runtime_error("cancelled") {}
};

class ProgressObserver {
 public:
  virtual ~ProgressObserver() = default;
  // A new stage of `total` steps (0: unknown total) named `stage` ("keyframing", ...).
  virtual void Begin(const std::string& stage, std::size_t total) = 0;
  // `done` of the stage's total steps are done.
  virtual void Advance(std::size_t done) = 0;
  // True once the user asked to stop (Ctrl-C in the console).
  virtual bool CancelRequested() const = 0;
};

// Calls observer->Begin (no-op for nullptr).
inline void BeginProgress(ProgressObserver* observer, const std::string& stage,
                          std::size_t total) {
  if (observer != nullptr) observer->Begin(stage, total);
}

// A safe point: reports `done` and throws Cancelled when a cancel was requested.
inline void ReportProgress(ProgressObserver* observer, std::size_t done) {
  if (observer == nullptr) return;
  observer->Advance(done);
  if (observer->CancelRequested()) throw Cancelled();
}

}  // namespace vilma
