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
  std::string out, err;
};

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
  r.err = err.str();
  return r;
}

/// Runs a shell command; returns its exit status (or −1 when killed) and captures stdout+stderr.
inline AppResult runCommand(const std::string& command) {
  AppResult r;
  FILE* p = ::popen((command + " 2>&1").c_str(), "r");
  if (!p) return r;
  char buf[4096];
  std::size_t n;
  while ((n = std::fread(buf, 1, sizeof buf, p)) > 0) r.out.append(buf, n);
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
