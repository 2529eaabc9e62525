// A progress bar on standard error, for long runs: drawn only when standard error is a terminal
// and the display is enabled (not --quiet), and only once the run has lasted half a second (short
// runs print nothing). Otherwise it is silent, so logs and pipes never see it.
//
//   [##########..........]  12/24  50%  3 s, ~3 s left  snapshots/window_000012.npz
//
// The line is redrawn in place (carriage return, erase line) at most ~10 times per second and is
// cut to the terminal's width (so that it never wraps).
//
// When standard error is not a terminal (a log file, a pipe) and the display is enabled, a plain
// line is printed instead every few seconds (DBACOV_PROGRESS_PERIOD seconds, default 5; 0 = at
// every item), so that a long run in a log shows where it is:
//
//   progress: 12/24 snapshots (50%), 3.9 snapshots/s, 3 s elapsed, ~3 s left
#pragma once

#include <chrono>
#include <cstddef>
#include <functional>
#include <ostream>
#include <string>

namespace dbacov::app {

class Progress {
 public:
  /// How the progress is shown; the default constructor's choice is described above.
  struct Display {
    bool terminal = false;          ///< draw the bar in place
    bool log = false;               ///< print a line every `log_period_s` seconds
    double log_period_s = 5;        ///< 0: a line at every item
    std::function<double()> clock;  ///< seconds on any monotonic clock (default: steady_clock)
    std::string unit = "snapshots";
  };
  /// `total` = 0 when unknown. If `enabled`: the bar when standard error is a terminal, else the
  /// periodic log line (`unit` names the items in it).
  Progress(std::ostream& err, std::size_t total, bool enabled,
           const std::string& unit = "snapshots");
  Progress(std::ostream& err, std::size_t total, Display display);
  ~Progress();
  /// Reports that item `label` starts (items before it are done).
  void step(const std::string& label);
  /// Reports where the current item is (`label`, e.g. "snapshot_0000.npz: DBA solve, iteration
  /// 12"), without counting an item: for one long item. The log line then ends with the label.
  void status(const std::string& label);
  /// Clears the line (before printing a message, and at the end).
  void clear();

  /// The text of the line: `done` items finished of `total` (0 = unknown: no bar, no estimate),
  /// `elapsed` seconds so far, the current item's label; at most `width` characters.
  static std::string formatLine(std::size_t done, std::size_t total, double elapsed,
                                const std::string& label, std::size_t width);
  /// The log line (no newline): `done` of `total` (0 = unknown: no percentage, no estimate)
  /// `unit` after `elapsed` seconds, with the rate and the estimated time left.
  static std::string formatLogLine(std::size_t done, std::size_t total, double elapsed,
                                   const std::string& unit);

 private:
  double now() const;
  void show(const std::string& label, bool with_label_in_log);
  std::ostream& err_;
  std::size_t total_, started_ = 0;
  Display display_;
  bool drawn_ = false;
  double start_ = 0, last_ = 0;
};

}  // namespace dbacov::app
