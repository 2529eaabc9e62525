#include "dbacov/app/progress.h"

#include <sys/ioctl.h>
#include <unistd.h>

#include <algorithm>
#include <cmath>
#include <cstdio>

namespace dbacov::app {
namespace {

std::size_t terminalWidth() {
  winsize ws{};
  if (::ioctl(STDERR_FILENO, TIOCGWINSZ, &ws) == 0 && ws.ws_col > 0) return ws.ws_col;
  return 80;
}

std::string seconds(double s) {
  char buf[32];
  if (s < 60)
    std::snprintf(buf, sizeof buf, "%.0f s", s);
  else if (s < 3600)
    std::snprintf(buf, sizeof buf, "%d min %02d s", static_cast<int>(s / 60),
                  static_cast<int>(s) % 60);
  else
    std::snprintf(buf, sizeof buf, "%d h %02d min", static_cast<int>(s / 3600),
                  static_cast<int>(s / 60) % 60);
  return buf;
}

}  // namespace

std::string Progress::formatLine(std::size_t done, std::size_t total, double elapsed,
                                 const std::string& label, std::size_t width) {
  std::string line;
  if (total > 0) {
    const std::size_t bar = 20, d = std::min(done, total);
    const std::size_t filled = bar * d / total;
    line = "[" + std::string(filled, '#') + std::string(bar - filled, '.') + "]  " +
           std::to_string(d) + "/" + std::to_string(total) + "  " +
           std::to_string(100 * d / total) + "%  " + seconds(elapsed);
    if (d > 0 && d < total)
      line += ", ~" + seconds(elapsed / static_cast<double>(d) * static_cast<double>(total - d)) +
              " left";
  } else {
    line = std::to_string(done) + " done  " + seconds(elapsed);
  }
  line += "  " + label;
  if (line.size() > width) line.resize(width);
  return line;
}

Progress::Progress(std::ostream& err, std::size_t total, bool enabled)
    : err_(err),
      total_(total),
      enabled_(enabled && isatty(STDERR_FILENO)),
      start_(std::chrono::steady_clock::now()) {}

Progress::~Progress() {
  clear();
}

void Progress::step(const std::string& label) {
  ++started_;
  if (!enabled_) return;
  const auto now = std::chrono::steady_clock::now();
  if (now - start_ < std::chrono::milliseconds(500)) return;  // short runs: nothing
  if (drawn_ && now - last_ < std::chrono::milliseconds(100)) return;
  last_ = now;
  const double elapsed = std::chrono::duration<double>(now - start_).count();
  // Keep one column free: a line exactly as wide as the terminal wraps on some terminals.
  err_ << "\r\033[K" << formatLine(started_ - 1, total_, elapsed, label, terminalWidth() - 1)
       << std::flush;
  drawn_ = true;
}

void Progress::clear() {
  if (!drawn_) return;
  err_ << "\r\033[K" << std::flush;
  drawn_ = false;
}

}  // namespace dbacov::app
