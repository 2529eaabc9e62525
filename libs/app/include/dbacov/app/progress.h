// A progress bar on standard error, for long runs: drawn only when standard error is a terminal
// and the display is enabled (not --quiet), and only once the run has lasted half a second (short
// runs print nothing). Otherwise it is silent, so logs and pipes never see it.
//
//   [##########..........]  12/24  50%  3 s, ~3 s left  snapshots/window_000012.npz
//
// The line is redrawn in place (carriage return, erase line) at most ~10 times per second and is
// cut to the terminal's width (so that it never wraps).
#pragma once

#include <chrono>
#include <cstddef>
#include <ostream>
#include <string>

namespace dbacov::app {

class Progress {
 public:
  /// `total` = 0 when unknown. Enabled only if `enabled` and standard error is a terminal.
  Progress(std::ostream& err, std::size_t total, bool enabled);
  ~Progress();
  /// Reports that item `label` starts (items before it are done).
  void step(const std::string& label);
  /// Clears the line (before printing a message, and at the end).
  void clear();

  /// The text of the line: `done` items finished of `total` (0 = unknown: no bar, no estimate),
  /// `elapsed` seconds so far, the current item's label; at most `width` characters.
  static std::string formatLine(std::size_t done, std::size_t total, double elapsed,
                                const std::string& label, std::size_t width);

 private:
  std::ostream& err_;
  std::size_t total_, started_ = 0;
  bool enabled_, drawn_ = false;
  std::chrono::steady_clock::time_point start_, last_{};
};

}  // namespace dbacov::app
