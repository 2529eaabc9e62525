#include "gz_streams.h"

#include <fcntl.h>
#include <libdeflate.h>
#include <sys/stat.h>
#include <unistd.h>
#include <zlib.h>

#include <algorithm>
#include <cerrno>
#include <climits>
#include <cstring>
#include <memory>
#include <new>
#include <stdexcept>
#include <utility>

#include "dbacov/core/errors.h"

namespace dbacov::mrpt_bridge {
namespace {

// One member: the 10-byte gzip header with FEXTRA, XLEN = 12, the subfield 'D','B' of 8 bytes
// (member size in bytes, then flags: bit 0 = the last member of the file), the deflate data, then
// CRC-32 and ISIZE.
constexpr std::size_t kHeaderBytes = 10 + 2 + 4 + 8;
constexpr std::size_t kTrailerBytes = 8;
constexpr std::uint32_t kLastMember = 1;
/// Largest member or uncompressed block accepted from a file (ours hold kGzBlockBytes).
constexpr std::uint32_t kMaxMemberBytes = std::uint32_t{64} << 20;

std::uint32_t load32(const unsigned char* p) {
  return static_cast<std::uint32_t>(p[0]) | static_cast<std::uint32_t>(p[1]) << 8 |
         static_cast<std::uint32_t>(p[2]) << 16 | static_cast<std::uint32_t>(p[3]) << 24;
}
void store32(unsigned char* p, std::uint32_t v) {
  for (int i = 0; i < 4; ++i) p[i] = static_cast<unsigned char>(v >> (8 * i));
}

/// True if `h` (kHeaderBytes) starts a member with the size subfield; *size and *flags from it.
bool isBlockHeader(const unsigned char* h, std::uint32_t* size, std::uint32_t* flags) {
  if (h[0] != 0x1f || h[1] != 0x8b || h[2] != 8 || h[3] != 0x04) return false;
  if (h[10] != 12 || h[11] != 0 || h[12] != 'D' || h[13] != 'B' || h[14] != 8 || h[15] != 0)
    return false;
  *size = load32(h + 16);
  *flags = load32(h + 20);
  return true;
}

/// read(2) until `n` bytes, the end of the file, or an error: the count, or -1 (errno set).
long readFull(int fd, unsigned char* p, std::size_t n) {
  std::size_t got = 0;
  while (got < n) {
    const ssize_t r = ::read(fd, p + got, n - got);
    if (r < 0 && errno == EINTR) continue;
    if (r < 0) return -1;
    if (r == 0) break;
    got += static_cast<std::size_t>(r);
  }
  return static_cast<long>(got);
}

/// write(2) of every byte: 0, or the errno of the failure.
int writeFull(int fd, const unsigned char* p, std::size_t n) {
  while (n > 0) {
    const ssize_t w = ::write(fd, p, n);
    if (w < 0 && errno == EINTR) continue;
    if (w < 0) return errno;
    if (w == 0) return EIO;
    p += w;
    n -= static_cast<std::size_t>(w);
  }
  return 0;
}

struct DecompressorFree {
  void operator()(libdeflate_decompressor* d) const { libdeflate_free_decompressor(d); }
};

libdeflate_decompressor* threadDecompressor() {
  thread_local std::unique_ptr<libdeflate_decompressor, DecompressorFree> d(
      libdeflate_alloc_decompressor());
  if (!d) throw std::bad_alloc();
  return d.get();
}

std::string systemReason(int err) {
  return err ? std::strerror(err) : "out of memory";
}

}  // namespace

uint64_t GzFileStream::Seek(int64_t, TSeekOrigin) {
  throw std::logic_error("GzFileStream::Seek: " + name_ + " is read or written sequentially");
}

GzInputStream::GzInputStream(const std::string& path) : GzFileStream(path), path_(path) {
  struct stat st {};
  errno = 0;
  if (::stat(path.c_str(), &st) == 0 && S_ISREG(st.st_mode)) {
    fd_ = ::open(path.c_str(), O_RDONLY | O_CLOEXEC);
    if (fd_ < 0)
      throw InputError(name_ + ": cannot open rawlog for reading: " + systemReason(errno));
    return;
  }
  errno = 0;
  gz_ = gzopen(path.c_str(), "rb");
  if (!gz_) throw InputError(name_ + ": cannot open rawlog for reading: " + systemReason(errno));
}

GzInputStream::~GzInputStream() {
  if (gz_) gzclose(gz_);
  if (fd_ >= 0) ::close(fd_);
}

bool GzInputStream::nextBlock() {
  block_.clear();
  at_ = 0;
  unsigned char h[kHeaderBytes];
  const long got = readFull(fd_, h, kHeaderBytes);
  if (got < 0) throw InputError(name_ + ": read error: " + std::strerror(errno));
  std::uint32_t size = 0, flags = 0;
  if (got == static_cast<long>(kHeaderBytes) && isBlockHeader(h, &size, &flags)) {
    if (size < kHeaderBytes + kTrailerBytes || size > kMaxMemberBytes)
      throw InputError(name_ + ": damaged compressed member");
    raw_.resize(size);
    std::memcpy(raw_.data(), h, kHeaderBytes);
    const std::size_t rest = size - kHeaderBytes;
    if (readFull(fd_, raw_.data() + kHeaderBytes, rest) != static_cast<long>(rest))
      throw InputError(name_ + ": truncated compressed data");
    const std::uint32_t isize = load32(raw_.data() + size - 4);
    if (isize > kMaxMemberBytes) throw InputError(name_ + ": damaged compressed member");
    block_.resize(isize);
    std::size_t out = 0;
    if (libdeflate_gzip_decompress(threadDecompressor(), raw_.data(), raw_.size(), block_.data(),
                                   block_.size(), &out) != LIBDEFLATE_SUCCESS ||
        out != isize)
      throw InputError(name_ + ": damaged compressed member");
    offset_ += size;
    last_ = (flags & kLastMember) != 0;
    return true;
  }
  if (got == 0) {
    // The end of the file: clean only after the member that says it is the last one (a file cut
    // between two members must not pass for a complete one).
    if (offset_ > 0 && !last_) throw InputError(name_ + ": truncated compressed data");
    if (offset_ > 0) return false;
  }
  // Not one of ours (or the rest of the file after our last member): zlib from here on.
  if (::lseek(fd_, static_cast<off_t>(offset_), SEEK_SET) < 0)
    throw InputError(name_ + ": cannot seek: " + std::strerror(errno));
  gz_ = gzdopen(fd_, "rb");
  if (!gz_) throw std::bad_alloc();
  fd_ = -1;  // gz_ owns it
  return false;
}

size_t GzInputStream::readZlib(unsigned char* p, size_t count) {
  size_t done = 0;
  while (done < count) {  // gzread takes at most INT_MAX bytes at a time
    const unsigned chunk = static_cast<unsigned>(std::min<size_t>(count - done, INT_MAX));
    const int n = gzread(gz_, p + done, chunk);
    if (n < 0) return done ? done : static_cast<size_t>(-1);
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

size_t GzInputStream::Read(void* buffer, size_t count) {
  auto* p = static_cast<unsigned char*>(buffer);
  size_t done = 0;
  while (done < count && !failed_) {
    if (gz_) {
      const size_t n = readZlib(p + done, count - done);
      if (n == static_cast<size_t>(-1)) {
        if (done == 0) return n;
        break;
      }
      done += n;
      break;
    }
    if (at_ == block_.size()) {
      try {
        if (fd_ < 0 || !nextBlock()) {
          if (!gz_) break;  // the end
          continue;         // zlib goes on
        }
      } catch (const InputError&) {
        failed_ = true;  // damaged or truncated: a read error, as zlib reports it
        break;
      }
      continue;
    }
    const size_t n = std::min(count - done, block_.size() - at_);
    std::memcpy(p + done, block_.data() + at_, n);
    at_ += n;
    done += n;
  }
  position_ += done;
  if (done == 0 && failed_) return static_cast<size_t>(-1);
  return done;
}

size_t GzInputStream::Write(const void*, size_t) {
  throw std::logic_error("GzInputStream::Write: " + name_ + " is read-only");
}

GzOutputStream::GzOutputStream(const std::string& path, const std::string& name)
    : GzFileStream(name) {
  errno = 0;
  fd_ = ::open(path.c_str(), O_WRONLY | O_CREAT | O_TRUNC | O_CLOEXEC, 0666);
  if (fd_ < 0)
    throw InputError(name_ + ": cannot open the rawlog output for writing: " + systemReason(errno));
  compressor_ = libdeflate_alloc_compressor(1);  // level 1, as MRPT's own rawlogs
  if (!compressor_) {
    ::close(fd_);
    throw std::bad_alloc();
  }
  pending_.reserve(kGzBlockBytes);
}

GzOutputStream::~GzOutputStream() {
  if (fd_ >= 0) ::close(fd_);
  if (compressor_) libdeflate_free_compressor(compressor_);
}

size_t GzOutputStream::Read(void*, size_t) {
  throw std::logic_error("GzOutputStream::Read: " + name_ + " is write-only");
}

int GzOutputStream::flushBlock(bool last) {
  const std::size_t bound = libdeflate_deflate_compress_bound(compressor_, pending_.size());
  member_.resize(kHeaderBytes + bound + kTrailerBytes);
  unsigned char* h = member_.data();
  const unsigned char header[16] = {0x1f, 0x8b, 8, 0x04, 0, 0, 0, 0, 0, 3, 12, 0, 'D', 'B', 8, 0};
  std::memcpy(h, header, sizeof header);
  const std::size_t n = libdeflate_deflate_compress(compressor_, pending_.data(), pending_.size(),
                                                    h + kHeaderBytes, bound);
  if (n == 0) return ENOMEM;  // cannot happen with the bound
  const std::size_t size = kHeaderBytes + n + kTrailerBytes;
  store32(h + 16, static_cast<std::uint32_t>(size));
  store32(h + 20, last ? kLastMember : 0);
  store32(h + kHeaderBytes + n, libdeflate_crc32(0, pending_.data(), pending_.size()));
  store32(h + kHeaderBytes + n + 4, static_cast<std::uint32_t>(pending_.size()));
  pending_.clear();
  return writeFull(fd_, h, size);
}

size_t GzOutputStream::Write(const void* buffer, size_t count) {
  if (fd_ < 0) throw std::logic_error("GzOutputStream::Write: " + name_ + " is closed");
  if (!failure_.empty()) throw InputError(failure_);
  const auto* p = static_cast<const unsigned char*>(buffer);
  for (size_t done = 0; done < count;) {
    const size_t n = std::min(count - done, block_bytes_ - pending_.size());
    pending_.insert(pending_.end(), p + done, p + done + n);
    done += n;
    if (pending_.size() == block_bytes_) {
      block_bytes_ = std::min(2 * block_bytes_, kGzBlockBytes);
      if (const int err = flushBlock(false)) {
        failure_ = name_ + ": write failed: " + std::strerror(err);
        throw InputError(failure_);
      }
    }
  }
  position_ += count;
  return count;
}

void GzOutputStream::close() {
  if (fd_ < 0) return;
  int err = failure_.empty() ? flushBlock(true) : EIO;
  const int fd = fd_;
  fd_ = -1;
  if (::close(fd) != 0 && !err) err = errno;
  if (err) throw InputError(name_ + ": cannot finish the compressed rawlog: " + std::strerror(err));
}

}  // namespace dbacov::mrpt_bridge
