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
/// Compressed bytes read at a time in zlib mode.
constexpr std::size_t kZlibInputBytes = std::size_t{64} << 10;
/// Uncompressed bytes inflated ahead in zlib mode (gzread's buffer).
constexpr std::size_t kZlibOutputBytes = std::size_t{16} << 10;

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
  const bool regular = ::stat(path.c_str(), &st) == 0 && S_ISREG(st.st_mode);
  errno = 0;
  fd_ = ::open(path.c_str(), O_RDONLY | O_CLOEXEC);  // a FIFO or /dev/stdin will do
  if (fd_ < 0) throw InputError(name_ + ": cannot open rawlog for reading: " + systemReason(errno));
  if (!regular) startZlib();
}

GzInputStream::~GzInputStream() {
  if (z_) inflateEnd(z_.get());
  if (fd_ >= 0) ::close(fd_);
}

void GzInputStream::startZlib() {
  z_ = std::make_unique<z_stream>();
  if (inflateInit2(z_.get(), 15 + 16 /* gzip */) != Z_OK) {
    z_.reset();
    throw std::bad_alloc();
  }
  input_.resize(kZlibInputBytes);
  z_->next_in = input_.data();
  z_->avail_in = 0;
  mode_ = Mode::MemberStart;
}

bool GzInputStream::nextBlock() {
  block_end_ = 0;
  at_ = 0;
  unsigned char h[kHeaderBytes];
  const long got = readFull(fd_, h, kHeaderBytes);
  if (got < 0) throw InputError(name_ + ": read error: " + std::strerror(errno));
  std::uint32_t size = 0, flags = 0;
  if (got == static_cast<long>(kHeaderBytes) && isBlockHeader(h, &size, &flags)) {
    compressed_ = members_ = true;
    if (size < kHeaderBytes + kTrailerBytes || size > kMaxMemberBytes)
      throw InputError(name_ + ": damaged compressed member");
    if (raw_.size() < size) raw_.resize(size);  // grown, never shrunk: no zero-filling per member
    std::memcpy(raw_.data(), h, kHeaderBytes);
    const std::size_t rest = size - kHeaderBytes;
    if (readFull(fd_, raw_.data() + kHeaderBytes, rest) != static_cast<long>(rest))
      throw InputError(name_ + ": truncated compressed data");
    const std::uint32_t isize = load32(raw_.data() + size - 4);
    if (isize > kMaxMemberBytes) throw InputError(name_ + ": damaged compressed member");
    if (block_.size() < isize) block_.resize(isize);
    std::size_t out = 0;
    if (libdeflate_gzip_decompress(threadDecompressor(), raw_.data(), size, block_.data(), isize,
                                   &out) != LIBDEFLATE_SUCCESS ||
        out != isize)
      throw InputError(name_ + ": damaged compressed member");
    block_end_ = isize;
    offset_ += size;
    last_ = (flags & kLastMember) != 0;
    return true;
  }
  if (got == 0 && offset_ > 0) {
    // The end of the file: clean only after the member that says it is the last one (a file cut
    // between two members must not pass for a complete one).
    if (!last_) throw InputError(name_ + ": truncated compressed data");
    mode_ = Mode::End;
    return false;
  }
  // Not one of ours (or the rest of the file after our last member: another writer's member is
  // legal, other bytes are refused there): zlib from here on.
  if (::lseek(fd_, static_cast<off_t>(offset_), SEEK_SET) < 0)
    throw InputError(name_ + ": cannot seek: " + std::strerror(errno));
  file_read_ = offset_;
  startZlib();
  return false;
}

bool GzInputStream::fill() {
  if (eof_) return false;
  z_stream& z = *z_;
  if (z.avail_in > 0 && z.next_in != input_.data())
    std::memmove(input_.data(), z.next_in, z.avail_in);
  z.next_in = input_.data();
  ssize_t r = 0;
  do {
    r = ::read(fd_, input_.data() + z.avail_in, input_.size() - z.avail_in);
  } while (r < 0 && errno == EINTR);
  if (r < 0) {
    failure_ = std::string("read error: ") + std::strerror(errno);
    failed_ = true;
    return false;
  }
  if (r == 0) eof_ = true;
  z.avail_in += static_cast<unsigned>(r);
  file_read_ += static_cast<uint64_t>(r);
  return r > 0;
}

void GzInputStream::refuseTrailingBytes() {
  z_stream& z = *z_;
  const uint64_t at = file_read_ - z.avail_in;
  std::string start;
  for (unsigned i = 0; i < std::min(z.avail_in, 8u); ++i) {
    static const char* hex = "0123456789abcdef";
    start += std::string(i ? " " : "") + hex[z.next_in[i] >> 4] + hex[z.next_in[i] & 15];
  }
  uint64_t n = z.avail_in;
  z.avail_in = 0;
  while (fill()) {  // count them (to the end of the file)
    n += z.avail_in;
    z.avail_in = 0;
  }
  failure_ = std::to_string(n) + " byte" + (n == 1 ? "" : "s") + " at byte " + std::to_string(at) +
             " of the file, after the last gzip member, " + (n == 1 ? "is" : "are") +
             " not gzip data (starting " + start +
             "): a gzip file holds only gzip members; was it appended to or damaged?";
  failed_ = true;
  mode_ = Mode::End;
}

size_t GzInputStream::readZlib(unsigned char* p, size_t count) {
  z_stream& z = *z_;
  size_t done = 0;
  while (done < count && !failed_) {
    if (out_at_ < out_.size()) {  // inflated ahead (see below), also after the member's end
      const size_t n = std::min(count - done, out_.size() - out_at_);
      std::memcpy(p + done, out_.data() + out_at_, n);
      out_at_ += n;
      done += n;
      continue;
    }
    if (mode_ == Mode::End) break;
    if (mode_ == Mode::MemberStart) {
      while (z.avail_in < 2 && fill()) {
      }
      if (failed_) break;
      if (z.avail_in == 0) {  // the end of the file, at a member boundary
        mode_ = Mode::End;
        break;
      }
      if (z.avail_in >= 2 && z.next_in[0] == 0x1f && z.next_in[1] == 0x8b) {
        if (inflateReset(&z) != Z_OK) throw std::bad_alloc();
        compressed_ = members_ = true;
        mode_ = Mode::Member;
      } else if (!members_) {
        mode_ = Mode::Plain;  // not compressed: the bytes themselves
      } else {
        refuseTrailingBytes();
      }
      continue;
    }
    if (mode_ == Mode::Plain) {
      if (z.avail_in == 0 && !fill()) {
        if (!failed_) mode_ = Mode::End;
        break;
      }
      const size_t n = std::min<size_t>(count - done, z.avail_in);
      std::memcpy(p + done, z.next_in, n);
      z.next_in += n;
      z.avail_in -= static_cast<unsigned>(n);
      done += n;
      continue;
    }
    // Inside a member. Small reads are served from out_, inflated ahead 16 KiB at a time as zlib's
    // gzread does, so that damage shows (as a read error) before the bytes around it are handed
    // out; large reads are inflated in place.
    // Compressed data that ends before its end marker is a truncated file.
    if (z.avail_in == 0 && !fill()) {
      failed_ = true;
      break;
    }
    const bool direct = count - done >= kZlibOutputBytes;
    const unsigned room =
        static_cast<unsigned>(direct ? std::min<size_t>(count - done, UINT_MAX) : kZlibOutputBytes);
    if (!direct) {
      out_.resize(kZlibOutputBytes);
      out_at_ = 0;
    }
    z.next_out = direct ? p + done : out_.data();
    z.avail_out = room;
    int status = Z_OK;
    do {  // fill out_ (or the caller's buffer) unless the member or the input ends first
      status = inflate(&z, Z_NO_FLUSH);
    } while (status == Z_OK && z.avail_out > 0 && (z.avail_in > 0 || fill()));
    if (direct)
      done += room - z.avail_out;
    else
      out_.resize(room - z.avail_out);
    if (status == Z_STREAM_END) {
      mode_ = Mode::MemberStart;  // CRC-32 and size checked; another member may follow
    } else if (status != Z_OK && status != Z_BUF_ERROR) {
      // Damaged (Z_DATA_ERROR) or out of memory: what this call inflated may already be wrong
      // (the CRC-32 comes at the member's end), so none of it is returned, as gzread does.
      out_.clear();
      out_at_ = 0;
      failed_ = true;
      return static_cast<size_t>(-1);
    }
  }
  return done;
}

size_t GzInputStream::Read(void* buffer, size_t count) {
  auto* p = static_cast<unsigned char*>(buffer);
  size_t done = 0;
  while (done < count && !failed_ && mode_ != Mode::End) {
    if (mode_ != Mode::Blocks) {
      const size_t n = readZlib(p + done, count - done);
      if (n != static_cast<size_t>(-1)) done += n;
      break;
    }
    if (at_ == block_end_) {
      try {
        nextBlock();  // false: mode_ changed (zlib, or the end)
      } catch (const InputError&) {
        failed_ = true;  // damaged or truncated: a read error, as zlib reports it
      }
      continue;
    }
    const size_t n = std::min(count - done, block_end_ - at_);
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
  pending_.reserve(kGzBlockBytes);  // before anything that the destructor would have to release
  errno = 0;
  fd_ = ::open(path.c_str(), O_WRONLY | O_CREAT | O_TRUNC | O_CLOEXEC, 0666);
  if (fd_ < 0)
    throw InputError(name_ + ": cannot open the rawlog output for writing: " + systemReason(errno));
  compressor_ = libdeflate_alloc_compressor(1);  // level 1, as MRPT's own rawlogs
  if (!compressor_) {
    ::close(fd_);
    throw std::bad_alloc();
  }
  store_ = libdeflate_alloc_compressor(0);  // stored blocks; null if the library lacks level 0
}

GzOutputStream::~GzOutputStream() {
  if (fd_ >= 0) ::close(fd_);
  if (compressor_) libdeflate_free_compressor(compressor_);
  if (store_) libdeflate_free_compressor(store_);
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
  // Level 1 into half the member's size. When that does not fit (0), deflate saves less than
  // half and the member is written as stored blocks instead (libdeflate level 0; a libdeflate
  // without it: level 1 after all).
  std::size_t n = libdeflate_deflate_compress(compressor_, pending_.data(), pending_.size(),
                                              h + kHeaderBytes, pending_.size() / 2);
  if (n == 0)
    n = libdeflate_deflate_compress(store_ ? store_ : compressor_, pending_.data(), pending_.size(),
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
