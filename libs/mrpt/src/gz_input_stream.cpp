#include "gz_input_stream.h"

#include <zlib.h>

#include <algorithm>
#include <cerrno>
#include <climits>
#include <cstring>
#include <stdexcept>

#include "dbacov/core/errors.h"

namespace dbacov::mrpt_bridge {

GzInputStream::GzInputStream(const std::string& path) : path_(path) {
  errno = 0;
  gz_ = gzopen(path.c_str(), "rb");
  if (!gz_)
    throw InputError(path + ": cannot open rawlog for reading: " +
                     (errno ? std::strerror(errno) : "out of memory"));
}

GzInputStream::~GzInputStream() {
  if (gz_) gzclose(gz_);
}

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
  throw std::logic_error("GzInputStream::Write: " + path_ + " is read-only");
}

uint64_t GzInputStream::Seek(int64_t, TSeekOrigin) {
  throw std::logic_error("GzInputStream::Seek: " + path_ + " is read sequentially");
}

uint64_t GzInputStream::getPosition() const {
  const z_off_t at = gztell(gz_);
  return at < 0 ? 0 : static_cast<uint64_t>(at);
}

}  // namespace dbacov::mrpt_bridge
