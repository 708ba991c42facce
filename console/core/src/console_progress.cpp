#include "console_progress.h"

#include <cstdio>

namespace vilma::console {

void ConsoleProgress::Begin(const std::string& stage, std::size_t total) {
  Finish();
  stage_ = stage;
  total_ = total;
  last_decile_ = -1;
  start_ = std::chrono::steady_clock::now();
  last_draw_ = start_ - std::chrono::seconds(1);
}

void ConsoleProgress::Advance(std::size_t done) {
  if (total_ == 0) return;
  const auto now = std::chrono::steady_clock::now();
  const double fraction = std::min(1.0, static_cast<double>(done) / static_cast<double>(total_));
  const double elapsed_s = std::chrono::duration<double>(now - start_).count();
  const double eta_s = fraction > 0.0 ? elapsed_s * (1.0 - fraction) / fraction : 0.0;
  char line[160];
  if (terminal_) {
    if (now - last_draw_ < std::chrono::milliseconds(100) && done < total_) return;
    last_draw_ = now;
    constexpr int kWidth = 30;
    const int filled = static_cast<int>(fraction * kWidth);
    std::string bar(static_cast<std::size_t>(filled), '#');
    bar.resize(kWidth, '.');
    std::snprintf(line, sizeof(line), "\r%s [%s] %3.0f%% %zu/%zu ETA %.0f s ", stage_.c_str(),
                  bar.c_str(), 100.0 * fraction, done, total_, eta_s);
    out_ << line << std::flush;
    bar_open_ = true;
    return;
  }
  const int decile = static_cast<int>(fraction * 10.0);
  if (decile <= last_decile_) return;
  // Quick stages stay quiet: lines start once a stage has run for a second.
  if (elapsed_s < 1.0) return;
  last_decile_ = decile;
  std::snprintf(line, sizeof(line), "  %s: %3d%% (%zu/%zu), %.1f s, ETA %.1f s\n", stage_.c_str(),
                decile * 10, done, total_, elapsed_s, eta_s);
  out_ << line << std::flush;
}

void ConsoleProgress::Finish() {
  if (bar_open_) out_ << "\n" << std::flush;
  bar_open_ = false;
}

}  // namespace vilma::console
