#include "dbacov/app/progress.h"

#include <sys/ioctl.h>
#include <unistd.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <utility>

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

/// DBACOV_PROGRESS_PERIOD (seconds between log lines), when set to a number >= 0.
double logPeriod() {
  const char* v = std::getenv("DBACOV_PROGRESS_PERIOD");
  if (!v || !*v) return 5;
  char* end = nullptr;
  const double p = std::strtod(v, &end);
  return (*end == '\0' && p >= 0 && std::isfinite(p)) ? p : 5;
}

Progress::Display defaultDisplay(bool enabled, const std::string& unit) {
  Progress::Display d;
  const bool tty = isatty(STDERR_FILENO) != 0;
  d.terminal = enabled && tty;
  d.log = enabled && !tty;
  d.log_period_s = logPeriod();
  d.unit = unit;
  return d;
}

}  // namespace

std::string Progress::formatLogLine(std::size_t done, std::size_t total, double elapsed,
                                    const std::string& unit) {
  std::string line = "progress: " + std::to_string(done);
  if (total > 0) line += "/" + std::to_string(total);
  line += " " + unit;
  if (total > 0) line += " (" + std::to_string(100 * std::min(done, total) / total) + "%)";
  char rate[48];
  if (elapsed > 0 && done > 0) {
    std::snprintf(rate, sizeof rate, ", %.3g %s/s", static_cast<double>(done) / elapsed,
                  unit.c_str());
    line += rate;
  }
  line += ", " + seconds(elapsed) + " elapsed";
  if (total > 0 && done > 0 && done < total)
    line += ", ~" +
            seconds(elapsed / static_cast<double>(done) * static_cast<double>(total - done)) +
            " left";
  return line;
}

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

Progress::Progress(std::ostream& err, std::size_t total, bool enabled, const std::string& unit)
    : Progress(err, total, defaultDisplay(enabled, unit)) {}

Progress::Progress(std::ostream& err, std::size_t total, Display display)
    : err_(err), total_(total), display_(std::move(display)) {
  start_ = last_ = now();
}

double Progress::now() const {
  if (display_.clock) return display_.clock();
  return std::chrono::duration<double>(std::chrono::steady_clock::now().time_since_epoch()).count();
}

Progress::~Progress() {
  clear();
}

void Progress::step(const std::string& label) {
  ++started_;
  show(label, false);
}

void Progress::status(const std::string& label) {
  show(label, true);
}

void Progress::show(const std::string& label, bool with_label_in_log) {
  const std::size_t done = started_ > 0 ? started_ - 1 : 0;
  if (display_.log) {
    const double t = now();
    // One line per period: the first after one period, then one period after the previous line.
    if (t - last_ < display_.log_period_s) return;
    last_ = t;
    err_ << formatLogLine(done, total_, t - start_, display_.unit)
         << (with_label_in_log ? ": " + label : "") << '\n'
         << std::flush;
    return;
  }
  if (!display_.terminal) return;
  const double t = now();
  if (t - start_ < 0.5) return;  // short runs: nothing
  if (drawn_ && t - last_ < 0.1) return;
  last_ = t;
  const double elapsed = t - start_;
  // Keep one column free: a line exactly as wide as the terminal wraps on some terminals.
  err_ << "\r\033[K" << formatLine(done, total_, elapsed, label, terminalWidth() - 1) << std::flush;
  drawn_ = true;
}

void Progress::clear() {
  if (!drawn_) return;
  err_ << "\r\033[K" << std::flush;
  drawn_ = false;
}

}  // namespace dbacov::app
