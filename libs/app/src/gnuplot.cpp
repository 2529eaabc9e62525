#include "gnuplot.h"

#include <fcntl.h>
#include <spawn.h>
#include <sys/mman.h>
#include <sys/wait.h>
#include <unistd.h>

#include <cerrno>
#include <cstring>
#include <sstream>
#include <vector>

#include "dbacov/core/errors.h"

extern char** environ;

namespace dbacov::app::detail {
namespace {

/// The last `n` non-empty lines of `text`, joined by " | ".
std::string tail(const std::string& text, std::size_t n) {
  std::istringstream in(text);
  std::vector<std::string> lines;
  for (std::string l; std::getline(in, l);)
    if (!l.empty()) lines.push_back(l);
  std::string out;
  for (std::size_t i = lines.size() > n ? lines.size() - n : 0; i < lines.size(); ++i)
    out += (out.empty() ? "" : " | ") + lines[i];
  return out;
}

/// Runs gnuplot with `args`, stdout and stderr to `log_fd`, the descriptors `inherit` kept open
/// under the same numbers; returns its exit status (127: not started).
int spawnGnuplot(const std::vector<std::string>& args, int log_fd,
                 const std::vector<int>& inherit) {
  posix_spawn_file_actions_t actions;
  posix_spawn_file_actions_init(&actions);
  posix_spawn_file_actions_addopen(&actions, 0, "/dev/null", O_RDONLY, 0);
  posix_spawn_file_actions_adddup2(&actions, log_fd, 1);
  posix_spawn_file_actions_adddup2(&actions, log_fd, 2);
  // dup2 onto the same number clears FD_CLOEXEC in the child (POSIX; glibc >= 2.29).
  for (int fd : inherit) posix_spawn_file_actions_adddup2(&actions, fd, fd);
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

MemFile::MemFile(const std::string& name) {
  fd_ = ::memfd_create(("dbacov_" + name).c_str(), MFD_CLOEXEC);
  if (fd_ < 0)
    throw InputError("cannot create the in-memory file '" + name +
                     "' for gnuplot: " + std::strerror(errno));
}

MemFile::~MemFile() {
  if (fd_ >= 0) ::close(fd_);
}

std::string MemFile::path() const {
  return "/proc/self/fd/" + std::to_string(fd_);
}

std::string MemFile::contents() const {
  std::string text;
  char buf[4096];
  for (off_t at = 0;;) {
    const ssize_t n = ::pread(fd_, buf, sizeof buf, at);
    if (n < 0 && errno == EINTR) continue;
    if (n <= 0) break;
    text.append(buf, static_cast<std::size_t>(n));
    at += n;
  }
  return text;
}

void runGnuplot(const std::string& script, const MemFile& log, const std::vector<int>& inherit,
                const std::string& what) {
  const int rc = spawnGnuplot({script}, log.fd(), inherit);
  if (rc == 127) throw InputError(what + ": cannot run gnuplot (Debian package gnuplot-nox)");
  if (rc != 0)
    throw InputError(what + ": gnuplot failed (status " + std::to_string(rc) +
                     "): " + tail(log.contents(), 4));
}

void requireGnuplot() {
  const MemFile log("probe.log");
  const int rc = spawnGnuplot({"-e", "set terminal pngcairo"}, log.fd(), {});
  if (rc != 0)
    throw InputError(
        "--plots needs gnuplot with the pngcairo terminal (Debian package gnuplot-nox): " +
        (rc == 127 ? std::string("gnuplot not found") : tail(log.contents(), 2)));
}

std::string gnuplotQuote(const std::string& s) {
  std::string q = "'";
  for (char c : s) q += c == '\'' ? std::string("''") : std::string(1, c);
  return q + "'";
}

}  // namespace dbacov::app::detail
