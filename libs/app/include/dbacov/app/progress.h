// A one-line progress indicator on standard error: only when it is a terminal and not --quiet.
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
  /// Reports that item `label` starts (redraws at most ~10 times per second).
  void step(const std::string& label);
  /// Clears the line (before printing a message, and at the end).
  void clear();

 private:
  std::ostream& err_;
  std::size_t total_, done_ = 0;
  bool enabled_, drawn_ = false;
  std::chrono::steady_clock::time_point last_{};
};

}  // namespace dbacov::app
