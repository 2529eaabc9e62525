// Runs an app's library entry point in-process with captured output (tests only), and the real
// binary when the test is about the executable itself.
#pragma once

#include <sys/wait.h>

#include <cstdio>
#include <cstdlib>
#include <fstream>
#include <functional>
#include <initializer_list>
#include <sstream>
#include <string>
#include <vector>

namespace dbacov::testing {

struct AppResult {
  int code = -1;
  std::string out;
  /// Standard error less the lines about the noise model (`noise`), which most tests are not
  /// about: the run summary's "noise model: ..." line and the self-calibration's warning that a
  /// state is far from its optimum (the tests' synthetic snapshots hold the truth, not DBA's
  /// optimum).
  std::string err;
  std::string noise;  ///< those lines, in order
};

/// Whether a line of an app's standard error is about the noise model (AppResult::noise).
inline bool isNoiseModelLine(const std::string& line) {
  return line.find(": noise model: ") != std::string::npos ||
         line.find("the state is far from the optimum of its factors") != std::string::npos;
}

using AppMain = std::function<int(int, const char* const*, std::ostream&, std::ostream&)>;

inline AppResult runApp(const AppMain& main_fn, const std::string& name,
                        const std::vector<std::string>& args) {
  std::vector<const char*> argv{name.c_str()};
  for (const auto& a : args) argv.push_back(a.c_str());
  argv.push_back(nullptr);
  std::ostringstream out, err;
  AppResult r;
  r.code = main_fn(static_cast<int>(argv.size() - 1), argv.data(), out, err);
  r.out = out.str();
  std::istringstream lines(err.str());
  for (std::string line; std::getline(lines, line);)
    (isNoiseModelLine(line) ? r.noise : r.err) += line + "\n";
  return r;
}

/// Runs a shell command; returns its exit status (or −1 when killed) and captures stdout+stderr
/// (less the noise-model lines, in `noise`, as runApp).
inline AppResult runCommand(const std::string& command) {
  AppResult r;
  FILE* p = ::popen((command + " 2>&1").c_str(), "r");
  if (!p) return r;
  char buf[4096];
  std::size_t n;
  std::string all;
  while ((n = std::fread(buf, 1, sizeof buf, p)) > 0) all.append(buf, n);
  std::istringstream lines(all);
  for (std::string line; std::getline(lines, line);)
    (isNoiseModelLine(line) ? r.noise : r.out) += line + "\n";
  if (!all.empty() && all.back() != '\n' && !r.out.empty()) r.out.pop_back();
  const int status = ::pclose(p);
  r.code = WIFEXITED(status) ? WEXITSTATUS(status) : -1;
  return r;
}

inline std::string readFile(const std::string& path) {
  std::ifstream f(path, std::ios::binary);
  return std::string(std::istreambuf_iterator<char>(f), std::istreambuf_iterator<char>());
}

inline std::vector<std::string> splitLines(const std::string& s) {
  std::vector<std::string> lines;
  std::istringstream is(s);
  for (std::string l; std::getline(is, l);) lines.push_back(l);
  return lines;
}

inline std::vector<std::string> splitCsv(const std::string& line) {
  std::vector<std::string> f;
  std::istringstream is(line);
  for (std::string x; std::getline(is, x, ',');) f.push_back(x);
  return f;
}

}  // namespace dbacov::testing
