// Private to dbacov_mrpt: MRPT streams over gzip files, for rawlogs.
//
// GzOutputStream writes gzip in independent members (the first of 8 KiB uncompressed, as zlib's
// buffer, so that a full disk shows at once; each next one twice as large, up to kGzBlockBytes),
// each compressed whole with libdeflate (level 1, as MRPT's rawlogs) and carrying its own total
// size in a gzip extra subfield ('D','B', 4 bytes, little-endian; RFC 1952 §2.3.1.1), like BGZF's
// block size. Any gzip reader reads the file (a gzip file may hold several members).
// mrpt::io::CFileGZOutputStream::close() ignores what gzclose() returns, so a failure to write the
// last block (disk full, quota) would go unnoticed and a damaged rawlog would be committed;
// Write() and close() here throw instead.
//
// GzInputStream: mrpt::io::CFileGZInputStream asks the file system for the file's size when it
// opens it, which throws for a FIFO or /dev/stdin; this stream reads any readable path
// (gz-compressed or plain) and never seeks. A regular file whose members carry the size subfield
// is read member by member with libdeflate (each member inflated whole, CRC-32 and size checked);
// anything else (other gzip writers, plain files, pipes, or the rest of a file from the first
// member without the subfield) goes through zlib's gzread. Read() returns the bytes read, 0 at the
// end of the data, and (size_t)-1 on a read error (damaged compressed data, or compressed data
// that ends before its end marker: a truncated file), as CFileGZInputStream does for damaged data.
#pragma once

#include <cstddef>
#include <string>
#include <vector>

#include <mrpt/io/CStream.h>

struct gzFile_s;
struct libdeflate_compressor;

namespace dbacov::mrpt_bridge {

/// Uncompressed bytes of GzOutputStream's first gzip member, and of its largest.
inline constexpr std::size_t kGzFirstBlockBytes = std::size_t{8} << 10;
inline constexpr std::size_t kGzBlockBytes = std::size_t{256} << 10;

/// What both streams share: the name, no seeking, the position in the uncompressed data.
class GzFileStream : public mrpt::io::CStream {
 public:
  GzFileStream(const GzFileStream&) = delete;
  GzFileStream& operator=(const GzFileStream&) = delete;

  uint64_t Seek(int64_t offset, TSeekOrigin origin) override;  ///< throws std::logic_error
  uint64_t getTotalBytesCount() const override { return 0; }   ///< unknown (may be a pipe)
  uint64_t getPosition() const override { return position_; }
  std::string getStreamDescription() const override { return "rawlog " + name_; }

 protected:
  explicit GzFileStream(std::string name) : name_(std::move(name)) {}

  std::string name_;       ///< the file as messages name it
  uint64_t position_ = 0;  ///< uncompressed bytes read or written
};

class GzInputStream : public GzFileStream {
 public:
  /// Opens `path`; throws InputError "<path>: cannot open rawlog for reading: <reason>".
  explicit GzInputStream(const std::string& path);
  ~GzInputStream() override;

  size_t Read(void* buffer, size_t count) override;
  size_t Write(const void* buffer, size_t count) override;  ///< throws std::logic_error

 private:
  /// Reads and inflates the next member with the size subfield into block_; false at the end of
  /// the file or when the next member is not one (then gz_ continues from there); throws on damage.
  bool nextBlock();
  size_t readZlib(unsigned char* p, size_t count);

  std::string path_;
  int fd_ = -1;                       ///< block mode: the file, at offset_
  uint64_t offset_ = 0;               ///< compressed bytes consumed in block mode
  std::vector<unsigned char> block_;  ///< the current member's uncompressed bytes
  std::size_t at_ = 0;                ///< bytes of block_ already returned
  std::vector<unsigned char> raw_;    ///< the current member's compressed bytes
  gzFile_s* gz_ = nullptr;            ///< zlib mode
  bool failed_ = false;
  bool last_ = false;  ///< the member just read said it is the file's last
};

class GzOutputStream : public GzFileStream {
 public:
  /// Creates `path`; messages name the file `name` (e.g. the final path of an atomic output).
  /// InputError "<name>: cannot open the rawlog output for writing: <reason>" on failure.
  /// Destroyed without close(), the stream is abandoned (its file is the caller's to discard).
  GzOutputStream(const std::string& path, const std::string& name);
  ~GzOutputStream() override;

  size_t Read(void* buffer, size_t count) override;  ///< throws std::logic_error
  /// Writes every byte or throws InputError "<name>: write failed: <reason>".
  size_t Write(const void* buffer, size_t count) override;

  /// Writes the last member and closes the file; InputError "<name>: cannot finish the
  /// compressed rawlog: <reason>" when that fails.
  void close();
  /// The message of the last failed Write() ("" if none).
  const std::string& failure() const { return failure_; }

 private:
  /// Compresses pending_ into one member (`last`: the file's last) and writes it; returns errno
  /// (0 on success).
  int flushBlock(bool last);

  int fd_ = -1;
  libdeflate_compressor* compressor_ = nullptr;
  std::size_t block_bytes_ = kGzFirstBlockBytes;  ///< uncompressed bytes of the next member
  std::vector<unsigned char> pending_;            ///< uncompressed bytes of the member being filled
  std::vector<unsigned char> member_;             ///< the compressed member being written
  std::string failure_;
};

}  // namespace dbacov::mrpt_bridge
