// The console's ProgressObserver: a bar with percentage and ETA redrawn in place on a terminal
// (at most 10 times a second), else one line per 10 % once the stage has run for a second;
// cancellation from the Ctrl-C flag.
#pragma once

#include <atomic>
#include <chrono>
#include <ostream>
#include <string>

#include "vilma/core/progress.h"

namespace vilma::console {

class ConsoleProgress : public ProgressObserver {
 public:
  ConsoleProgress(std::ostream& out, bool terminal, const std::atomic<bool>* cancel_flag)
      : out_(out), terminal_(terminal), cancel_flag_(cancel_flag) {}

  void Begin(const std::string& stage, std::size_t total) override;
  void Advance(std::size_t done) override;
  bool CancelRequested() const override {
    return cancel_flag_ != nullptr && cancel_flag_->load();
  }
  // Ends a bar left open on a terminal.
  void Finish();

 private:
  std::ostream& out_;
  bool terminal_;
  const std::atomic<bool>* cancel_flag_;
  std::string stage_;
  std::size_t total_ = 0;
  int last_decile_ = -1;
  bool bar_open_ = false;
  std::chrono::steady_clock::time_point start_;
  std::chrono::steady_clock::time_point last_draw_;
};

}  // namespace vilma::console
