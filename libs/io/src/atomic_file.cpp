// AtomicOutputFile: O_TMPFILE (or mkstemp) + fsync + linkat/rename. See atomic_file.h.
#include "dbacov/io/atomic_file.h"

#include "dbacov/io/path_guard.h"

#include <fcntl.h>
#include <signal.h>
#include <sys/resource.h>
#include <sys/stat.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <chrono>
#include <cstdlib>
#include <cstring>
#include <random>
#include <stdexcept>
#include <streambuf>
#include <vector>

namespace dbacov::io {
namespace {

/// "/proc/self/fd/<fd>": the magic link through which an O_TMPFILE inode can be opened or linked.
std::string procFdPath(int fd) {
  return "/proc/self/fd/" + std::to_string(fd);
}

/// Prefix of temporary names: "<dir>/.<name>.tmp.<pid>." (name shortened to stay below NAME_MAX).
std::string tempPrefix(const std::string& dir, const std::string& name) {
  return dir + "/." + name.substr(0, 120) + ".tmp." + std::to_string(::getpid()) + ".";
}

std::string randomSuffix() {
  static const char kChars[] = "ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz0123456789";
  thread_local std::mt19937_64 rng(
      std::random_device{}() ^
      static_cast<std::uint64_t>(std::chrono::steady_clock::now().time_since_epoch().count()));
  std::string s(6, 'X');
  for (char& c : s) c = kChars[rng() % (sizeof(kChars) - 1)];
  return s;
}

/// std::streambuf that writes through AtomicOutputFile::write and remembers the first error.
class AtomicStreamBuf : public std::streambuf {
 public:
  explicit AtomicStreamBuf(AtomicOutputFile& out) : out_(out), buf_(1 << 16) {
    setp(buf_.data(), buf_.data() + buf_.size());
  }
  const std::string& error() const { return error_; }

 protected:
  int_type overflow(int_type ch) override {
    if (!flushBuffer()) return traits_type::eof();
    if (!traits_type::eq_int_type(ch, traits_type::eof())) {
      *pptr() = traits_type::to_char_type(ch);
      pbump(1);
    }
    return traits_type::not_eof(ch);
  }
  int sync() override { return flushBuffer() ? 0 : -1; }

 private:
  bool flushBuffer() {
    if (!error_.empty()) return false;
    try {
      out_.write(pbase(), static_cast<std::size_t>(pptr() - pbase()));
    } catch (const std::exception& e) {
      error_ = e.what();
      return false;
    }
    setp(buf_.data(), buf_.data() + buf_.size());
    return true;
  }

  AtomicOutputFile& out_;
  std::vector<char> buf_;
  std::string error_;
};

/// Names the unnamed temporary `fd` in directory `dir` (linkat cannot replace a file, so a unique
/// hidden name next to `target`); returns that name. Throws InputError naming `final_path`.
std::string linkUnnamed(int fd, const std::string& final_path, const std::string& dir,
                        const std::string& target) {
  const std::string prefix = tempPrefix(dir, target.substr(target.rfind('/') + 1));
  for (int attempt = 0;; ++attempt) {
    const std::string candidate = prefix + randomSuffix();
    if (::linkat(AT_FDCWD, procFdPath(fd).c_str(), AT_FDCWD, candidate.c_str(),
                 AT_SYMLINK_FOLLOW) == 0)
      return candidate;
    if (errno != EEXIST || attempt == 100) {
      const int error = errno;
      throw InputError(final_path + ": cannot link the temporary file into directory '" + dir +
                       "': " + std::strerror(error));
    }
  }
}

/// Copies the scratch file `fd` (from its start) into the existing special file `target`, opened
/// for writing in place (no truncation, no replacement). Throws InputError naming `final_path`.
void writeInPlace(int fd, const std::string& final_path, const std::string& target) {
  const int out = ::open(target.c_str(), O_WRONLY | O_NOCTTY | O_CLOEXEC);
  if (out < 0) {
    const int error = errno;
    throw InputError(final_path + ": cannot open for writing in place: " + std::strerror(error));
  }
  std::vector<char> buf(1 << 16);
  off_t at = 0;
  for (;;) {
    const ssize_t n = ::pread(fd, buf.data(), buf.size(), at);
    if (n < 0 && errno == EINTR) continue;
    if (n == 0) break;
    for (ssize_t done = 0; n > 0 && done < n;) {
      const ssize_t w = ::write(out, buf.data() + done, static_cast<std::size_t>(n - done));
      if (w < 0 && errno == EINTR) continue;
      if (w <= 0) {
        const int error = w < 0 ? errno : EIO;
        ::close(out);
        throw InputError(final_path + ": write failed: " + std::strerror(error));
      }
      done += w;
    }
    if (n < 0) {
      const int error = errno;
      ::close(out);
      throw InputError(final_path +
                       ": cannot read the spooled output back: " + std::strerror(error));
    }
    at += n;
  }
  if (::close(out) != 0 && errno != EINTR) {
    const int error = errno;
    throw InputError(final_path + ": close failed: " + std::strerror(error));
  }
}

void fsyncDirectory(const std::string& dir) {
  // Best effort: some file systems refuse fsync on directories.
  const int dfd = ::open(dir.c_str(), O_RDONLY | O_DIRECTORY | O_CLOEXEC);
  if (dfd >= 0) {
    ::fsync(dfd);
    ::close(dfd);
  }
}

thread_local CommitGroup* g_active_group = nullptr;

}  // namespace

AtomicOutputFile::AtomicOutputFile(std::string final_path, TempKind kind)
    : final_path_(std::move(final_path)) {
  const std::size_t slash0 = final_path_.rfind('/');
  const std::string name0 =
      slash0 == std::string::npos ? final_path_ : final_path_.substr(slash0 + 1);
  if (name0.empty() || name0 == "." || name0 == "..")
    throw InputError(final_path_ + ": not a file path (it names a directory)");
  target_ = resolveOutputTarget(final_path_);
  const std::size_t slash = target_.rfind('/');
  const std::string name = slash == std::string::npos ? target_ : target_.substr(slash + 1);
  dir_ = slash == std::string::npos ? "." : slash == 0 ? "/" : target_.substr(0, slash);
  if (name.empty() || name == "." || name == "..")
    throw InputError(final_path_ + ": not a file path (it names a directory)");
  struct stat st {};
  if (::stat(target_.c_str(), &st) == 0 && S_ISDIR(st.st_mode))
    throw InputError(final_path_ + ": is a directory, expected a file path");
  if (::stat(target_.c_str(), &st) == 0 && !S_ISREG(st.st_mode)) {
    // A device, FIFO or socket: spool now, write in place at commit().
    const char* tmp = std::getenv("TMPDIR");
    const std::string scratch_dir = tmp && *tmp ? tmp : "/tmp";
    fd_ = openScratchFile(scratch_dir);
    if (fd_ < 0)
      fail("cannot create a scratch file in '" + scratch_dir +
               "' to spool the output (it is written in place, not a regular file)",
           errno);
    in_place_ = true;
    return;
  }

#ifdef O_TMPFILE
  if (kind == TempKind::kAuto) {
    fd_ = ::open(dir_.c_str(), O_TMPFILE | O_WRONLY | O_CLOEXEC, 0644);
    // writePath() and commit() need /proc; without it, use a named temporary instead.
    if (fd_ >= 0 && ::access(procFdPath(fd_).c_str(), F_OK) == 0) {
      unnamed_ = true;
      return;
    }
    if (fd_ >= 0) ::close(fd_);
    fd_ = -1;
  }
#else
  (void)kind;
#endif
  std::string templ = tempPrefix(dir_, name) + "XXXXXX";
  fd_ = ::mkstemp(templ.data());
  if (fd_ < 0) fail("cannot create a temporary file in directory '" + dir_ + "'", errno);
  temp_name_ = templ;
  ::fcntl(fd_, F_SETFD, FD_CLOEXEC);
  ::fchmod(fd_, 0644);  // mkstemp creates 0600; an output file should be readable like others
}

AtomicOutputFile::~AtomicOutputFile() {
  discard();
}

std::string AtomicOutputFile::writePath() const {
  if (fd_ < 0) throw std::logic_error("AtomicOutputFile::writePath: " + final_path_ + " is closed");
  return unnamed_ || in_place_ ? procFdPath(fd_) : temp_name_;
}

void AtomicOutputFile::write(const void* data, std::size_t size) {
  if (fd_ < 0) throw std::logic_error("AtomicOutputFile::write: " + final_path_ + " is closed");
  const char* p = static_cast<const char*>(data);
  while (size > 0) {
    const ssize_t n = ::write(fd_, p, std::min<std::size_t>(size, std::size_t{1} << 30));
    if (n < 0) {
      if (errno == EINTR) continue;
      fail("write failed", errno);
    }
    p += n;
    size -= static_cast<std::size_t>(n);
  }
}

void AtomicOutputFile::commit() {
  if (committed_ || fd_ < 0)
    throw std::logic_error("AtomicOutputFile::commit: " + final_path_ + " is closed");
  CommitGroup* group = CommitGroup::active();
  try {
    if (in_place_) {
      if (group) {
        group->adopt({final_path_, target_, dir_, "", fd_, true});
      } else {
        writeInPlace(fd_, final_path_, target_);
        ::close(fd_);
      }
      fd_ = -1;
      committed_ = true;
      return;
    }
    if (::fsync(fd_) != 0) fail("fsync failed", errno);
    if (group && unnamed_ && group->open_fds_ < group->fd_budget_) {
      group->adopt({final_path_, target_, dir_, "", fd_, false});  // named at publish()
      fd_ = -1;
      committed_ = true;
      return;
    }
    if (unnamed_) temp_name_ = linkUnnamed(fd_, final_path_, dir_, target_);
    const int fd = fd_;
    fd_ = -1;
    if (::close(fd) != 0) fail("close failed", errno);
    if (group) {
      group->adopt({final_path_, target_, dir_, temp_name_, -1, false});
      temp_name_.clear();
      committed_ = true;
      return;
    }
    if (::rename(temp_name_.c_str(), target_.c_str()) != 0)
      fail("cannot rename the temporary file '" + temp_name_ + "' to the final path", errno);
  } catch (...) {
    discard();
    throw;
  }
  temp_name_.clear();
  committed_ = true;
  fsyncDirectory(dir_);  // makes the rename itself durable
}

CommitGroup::CommitGroup() {
  if (g_active_group) throw std::logic_error("CommitGroup: a group is already active");
  g_active_group = this;
  // Unnamed temporaries stay open until publish(): allow up to half the descriptors (raising the
  // soft limit to the hard one); beyond that they are named when prepared.
  struct rlimit lim {};
  if (::getrlimit(RLIMIT_NOFILE, &lim) == 0) {
    if (lim.rlim_cur < lim.rlim_max) {
      struct rlimit raised = lim;
      raised.rlim_cur = std::min<rlim_t>(lim.rlim_max, 1 << 16);
      if (raised.rlim_cur > lim.rlim_cur && ::setrlimit(RLIMIT_NOFILE, &raised) == 0) lim = raised;
    }
    fd_budget_ = lim.rlim_cur / 2 > 64 ? static_cast<std::size_t>(lim.rlim_cur / 2 - 64) : 0;
  }
}

CommitGroup::~CommitGroup() {
  discard();
  if (g_active_group == this) g_active_group = nullptr;
}

CommitGroup* CommitGroup::active() {
  return g_active_group;
}

void CommitGroup::adopt(Entry entry) {
  if (entry.fd >= 0) ++open_fds_;
  entries_.push_back(std::move(entry));
}

void CommitGroup::discard() noexcept {
  for (Entry& e : entries_) {
    if (e.fd >= 0) ::close(e.fd);
    if (!e.temp_name.empty()) ::unlink(e.temp_name.c_str());
  }
  entries_.clear();
  open_fds_ = 0;
}

void CommitGroup::publish() {
  if (done_) throw std::logic_error("CommitGroup::publish: already published");
  done_ = true;
  if (g_active_group == this) g_active_group = nullptr;
  // Fault injection for the kill tests (tests/robustness/test_kill.cpp): SIGKILL after that many
  // renames.
  const char* kill_env = std::getenv("DBACOV_TEST_KILL_IN_COMMIT");
  const long kill_at = kill_env && *kill_env ? std::strtol(kill_env, nullptr, 10) : -1;
  std::string first_error;
  std::size_t failures = 0;
  std::vector<std::string> dirs;
  long renamed = 0;
  for (Entry& e : entries_) {  // the window: names only, no data written
    if (e.in_place) continue;
    if (renamed == kill_at) ::raise(SIGKILL);
    try {
      if (e.fd >= 0) {
        e.temp_name = linkUnnamed(e.fd, e.final_path, e.dir, e.target);
        ::close(e.fd);
        e.fd = -1;
      }
      if (::rename(e.temp_name.c_str(), e.target.c_str()) != 0) {
        const int error = errno;
        throw InputError(e.final_path + ": cannot rename the temporary file '" + e.temp_name +
                         "' to the final path: " + std::strerror(error));
      }
      e.temp_name.clear();
      ++renamed;
      if (std::find(dirs.begin(), dirs.end(), e.dir) == dirs.end()) dirs.push_back(e.dir);
    } catch (const InputError& err) {
      if (failures++ == 0) first_error = err.what();
    }
  }
  if (renamed == kill_at) ::raise(SIGKILL);
  for (Entry& e : entries_) {
    if (!e.in_place) continue;
    try {
      writeInPlace(e.fd, e.final_path, e.target);
    } catch (const InputError& err) {
      if (failures++ == 0) first_error = err.what();
    }
  }
  for (const std::string& dir : dirs) fsyncDirectory(dir);
  discard();
  if (failures)
    throw InputError(first_error + (failures > 1 ? " (and " + std::to_string(failures - 1) +
                                                       " more files not written)"
                                                 : std::string()));
}

void AtomicOutputFile::fail(const std::string& what, int err) const {
  throw InputError(final_path_ + ": " + what + ": " + std::strerror(err));
}

void AtomicOutputFile::discard() noexcept {
  if (fd_ >= 0) ::close(fd_);
  fd_ = -1;
  if (!temp_name_.empty()) ::unlink(temp_name_.c_str());
  temp_name_.clear();
}

int openScratchFile(const std::string& dir) {
  int fd = -1;
#ifdef O_TMPFILE
  fd = ::open(dir.c_str(), O_TMPFILE | O_RDWR | O_CLOEXEC, 0600);
#endif
  if (fd < 0) {
    std::string templ = dir + "/.dbacov_scratch.XXXXXX";
    fd = ::mkstemp(templ.data());
    if (fd < 0) return -1;
    ::unlink(templ.c_str());
    ::fcntl(fd, F_SETFD, FD_CLOEXEC);
  }
  return fd;
}

void writeFileAtomically(const std::string& path,
                         const std::function<void(std::ostream&)>& writer) {
  AtomicOutputFile out(path);
  AtomicStreamBuf buf(out);
  std::ostream os(&buf);
  writer(os);  // an exception propagates; `out` then discards everything
  os.flush();
  if (!os.good())
    throw InputError(!buf.error().empty()
                         ? buf.error()
                         : path + ": the writer left the output stream in a failed state");
  out.commit();
}

}  // namespace dbacov::io
