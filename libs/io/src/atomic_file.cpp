// AtomicOutputFile: O_TMPFILE (or mkstemp) + fsync + linkat/rename. See atomic_file.h.
#include "dbacov/io/atomic_file.h"

#include <fcntl.h>
#include <sys/stat.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <chrono>
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

}  // namespace

AtomicOutputFile::AtomicOutputFile(std::string final_path, TempKind kind)
    : final_path_(std::move(final_path)) {
  const std::size_t slash = final_path_.rfind('/');
  const std::string name = slash == std::string::npos ? final_path_ : final_path_.substr(slash + 1);
  dir_ = slash == std::string::npos ? "." : slash == 0 ? "/" : final_path_.substr(0, slash);
  if (name.empty() || name == "." || name == "..")
    throw InputError(final_path_ + ": not a file path (it names a directory)");
  struct stat st {};
  if (::stat(final_path_.c_str(), &st) == 0 && S_ISDIR(st.st_mode))
    throw InputError(final_path_ + ": is a directory, expected a file path");

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
  return unnamed_ ? procFdPath(fd_) : temp_name_;
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
  try {
    if (::fsync(fd_) != 0) fail("fsync failed", errno);
    if (unnamed_) {
      // Give the inode a name in the same directory, then rename it over the final path (linkat
      // cannot replace an existing file).
      const std::string prefix = tempPrefix(dir_, final_path_.substr(final_path_.rfind('/') + 1));
      for (int attempt = 0; temp_name_.empty(); ++attempt) {
        const std::string candidate = prefix + randomSuffix();
        if (::linkat(AT_FDCWD, procFdPath(fd_).c_str(), AT_FDCWD, candidate.c_str(),
                     AT_SYMLINK_FOLLOW) == 0)
          temp_name_ = candidate;
        else if (errno != EEXIST || attempt == 100)
          fail("cannot link the temporary file into directory '" + dir_ + "'", errno);
      }
    }
    const int fd = fd_;
    fd_ = -1;
    if (::close(fd) != 0) fail("close failed", errno);
    if (::rename(temp_name_.c_str(), final_path_.c_str()) != 0)
      fail("cannot rename the temporary file '" + temp_name_ + "' to the final path", errno);
  } catch (...) {
    discard();
    throw;
  }
  temp_name_.clear();
  committed_ = true;
  // Make the rename itself durable (best effort: some file systems refuse fsync on directories).
  const int dfd = ::open(dir_.c_str(), O_RDONLY | O_DIRECTORY | O_CLOEXEC);
  if (dfd >= 0) {
    ::fsync(dfd);
    ::close(dfd);
  }
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
