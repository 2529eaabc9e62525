#include "gnuplot.h"

#include <fcntl.h>
#include <spawn.h>
#include <stdlib.h>
#include <sys/wait.h>

#include <cerrno>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <vector>

#include "dbacov/core/errors.h"

extern char** environ;

namespace dbacov::app::detail {
namespace {

/// The last `n` lines of a text file.
std::string tail(const std::string& path, std::size_t n) {
  std::ifstream in(path);
  std::vector<std::string> lines;
  for (std::string l; std::getline(in, l);)
    if (!l.empty()) lines.push_back(l);
  std::string out;
  for (std::size_t i = lines.size() > n ? lines.size() - n : 0; i < lines.size(); ++i)
    out += (out.empty() ? "" : " | ") + lines[i];
  return out;
}

/// Runs gnuplot with `args`, stdout and stderr to `log`; returns its exit status (127: not
/// started).
int spawnGnuplot(const std::vector<std::string>& args, const std::string& log) {
  posix_spawn_file_actions_t actions;
  posix_spawn_file_actions_init(&actions);
  posix_spawn_file_actions_addopen(&actions, 0, "/dev/null", O_RDONLY, 0);
  posix_spawn_file_actions_addopen(&actions, 1, log.c_str(), O_WRONLY | O_CREAT | O_TRUNC, 0644);
  posix_spawn_file_actions_adddup2(&actions, 1, 2);
  std::vector<char*> argv;
  std::vector<std::string> storage{"gnuplot"};
  storage.insert(storage.end(), args.begin(), args.end());
  for (auto& a : storage) argv.push_back(a.data());
  argv.push_back(nullptr);
  pid_t pid = 0;
  const int rc = posix_spawnp(&pid, "gnuplot", &actions, nullptr, argv.data(), environ);
  posix_spawn_file_actions_destroy(&actions);
  if (rc != 0) return 127;
  int status = 0;
  while (waitpid(pid, &status, 0) < 0)
    if (errno != EINTR) return 127;
  return WIFEXITED(status) ? WEXITSTATUS(status) : 128;
}

}  // namespace

ScratchDir::ScratchDir() {
  std::string templ = (std::filesystem::temp_directory_path() / "dbacov_plots.XXXXXX").string();
  if (!::mkdtemp(templ.data()))
    throw InputError(templ + ": cannot create a scratch directory for the figures");
  path_ = templ;
}

ScratchDir::~ScratchDir() {
  std::error_code ec;
  std::filesystem::remove_all(path_, ec);
}

void runGnuplot(const std::string& script, const std::string& log, const std::string& what) {
  const int rc = spawnGnuplot({script}, log);
  if (rc == 127) throw InputError(what + ": cannot run gnuplot (Debian package gnuplot-nox)");
  if (rc != 0)
    throw InputError(what + ": gnuplot failed (status " + std::to_string(rc) +
                     "): " + tail(log, 4));
}

void requireGnuplot() {
  ScratchDir scratch;
  const int rc = spawnGnuplot({"-e", "set terminal pngcairo"}, scratch.file("probe.log"));
  if (rc != 0)
    throw InputError(
        "--plots needs gnuplot with the pngcairo terminal (Debian package gnuplot-nox): " +
        (rc == 127 ? std::string("gnuplot not found") : tail(scratch.file("probe.log"), 2)));
}

std::string gnuplotQuote(const std::string& s) {
  std::string q = "'";
  for (char c : s) q += c == '\'' ? std::string("''") : std::string(1, c);
  return q + "'";
}

}  // namespace dbacov::app::detail
