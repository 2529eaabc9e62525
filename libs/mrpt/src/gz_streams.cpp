#include "gz_streams.h"

#include <zlib.h>

#include <algorithm>
#include <cerrno>
#include <climits>
#include <cstring>
#include <stdexcept>
#include <utility>

#include "dbacov/core/errors.h"

namespace dbacov::mrpt_bridge {

GzFileStream::GzFileStream(const std::string& path, std::string name, const char* mode,
                           const char* what)
    : name_(std::move(name)) {
  errno = 0;
  gz_ = gzopen(path.c_str(), mode);
  if (!gz_)
    throw InputError(name_ + ": cannot open " + what + ": " +
                     (errno ? std::strerror(errno) : "out of memory"));
}

GzFileStream::~GzFileStream() {
  if (gz_) gzclose(gz_);
}

uint64_t GzFileStream::Seek(int64_t, TSeekOrigin) {
  throw std::logic_error("GzFileStream::Seek: " + name_ + " is read or written sequentially");
}

uint64_t GzFileStream::getPosition() const {
  const z_off_t at = gz_ ? gztell(gz_) : -1;
  return at < 0 ? 0 : static_cast<uint64_t>(at);
}

GzInputStream::GzInputStream(const std::string& path)
    : GzFileStream(path, path, "rb", "rawlog for reading") {}

size_t GzInputStream::Read(void* buffer, size_t count) {
  auto* p = static_cast<unsigned char*>(buffer);
  size_t done = 0;
  while (done < count) {  // gzread takes at most INT_MAX bytes at a time
    const unsigned chunk = static_cast<unsigned>(std::min<size_t>(count - done, INT_MAX));
    const int n = gzread(gz_, p + done, chunk);
    if (n < 0) return static_cast<size_t>(-1);
    if (n == 0) {
      // gzread also returns 0 when the compressed data ends early (truncated file or pipe);
      // only gzerror tells that apart from the end of the data (Z_BUF_ERROR).
      int status = Z_OK;
      gzerror(gz_, &status);
      if (status != Z_OK && done == 0) return static_cast<size_t>(-1);
      break;
    }
    done += static_cast<size_t>(n);
  }
  return done;
}

size_t GzInputStream::Write(const void*, size_t) {
  throw std::logic_error("GzInputStream::Write: " + name_ + " is read-only");
}

namespace {

/// zlib's description of the stream's last error, or the system's when it is an I/O error.
std::string gzReason(gzFile_s* gz) {
  int code = Z_OK;
  const char* message = gzerror(gz, &code);
  return code == Z_ERRNO ? std::strerror(errno) : std::string(message ? message : "zlib error");
}

}  // namespace

GzOutputStream::GzOutputStream(const std::string& path, const std::string& name)
    : GzFileStream(path, name, "wb1", "the rawlog output for writing") {}

size_t GzOutputStream::Read(void*, size_t) {
  throw std::logic_error("GzOutputStream::Read: " + name_ + " is write-only");
}

size_t GzOutputStream::Write(const void* buffer, size_t count) {
  if (!gz_) throw std::logic_error("GzOutputStream::Write: " + name_ + " is closed");
  const auto* p = static_cast<const unsigned char*>(buffer);
  for (size_t done = 0; done < count;) {  // gzwrite takes at most INT_MAX bytes at a time
    const unsigned chunk = static_cast<unsigned>(std::min<size_t>(count - done, INT_MAX));
    errno = 0;
    const int n = gzwrite(gz_, p + done, chunk);
    if (n <= 0) {
      failure_ = name_ + ": write failed: " + gzReason(gz_);
      throw InputError(failure_);
    }
    done += static_cast<size_t>(n);
  }
  return count;
}

void GzOutputStream::close() {
  if (!gz_) return;
  errno = 0;
  const int status = gzclose(gz_);
  gz_ = nullptr;
  if (status != Z_OK)
    throw InputError(name_ + ": cannot finish the compressed rawlog: " +
                     (status == Z_ERRNO ? std::string(std::strerror(errno))
                                        : "zlib error " + std::to_string(status)));
}

}  // namespace dbacov::mrpt_bridge
