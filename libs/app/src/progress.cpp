#include "dbacov/app/progress.h"

#include <unistd.h>

namespace dbacov::app {

Progress::Progress(std::ostream& err, std::size_t total, bool enabled)
    : err_(err), total_(total), enabled_(enabled && isatty(STDERR_FILENO)) {}

Progress::~Progress() { clear(); }

void Progress::step(const std::string& label) {
  ++done_;
  if (!enabled_) return;
  const auto now = std::chrono::steady_clock::now();
  if (drawn_ && now - last_ < std::chrono::milliseconds(100) && done_ != total_) return;
  last_ = now;
  err_ << "\r\033[K[" << done_;
  if (total_) err_ << '/' << total_;
  err_ << "] " << label << std::flush;
  drawn_ = true;
}

void Progress::clear() {
  if (!drawn_) return;
  err_ << "\r\033[K" << std::flush;
  drawn_ = false;
}

}  // namespace dbacov::app
