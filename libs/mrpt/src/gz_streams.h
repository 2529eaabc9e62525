// Private to dbacov_mrpt: MRPT streams over gzip files, for rawlogs.
//
// GzOutputStream writes gzip in independent members (the first of 8 KiB uncompressed, as zlib's
// buffer, so that a full disk shows at once; each next one twice as large, up to kGzBlockBytes),
// each compressed whole with libdeflate (level 1, as MRPT's rawlogs) and carrying its own total
// size in a gzip extra subfield ('D','B', 4 bytes, little-endian; RFC 1952 §2.3.1.1), like BGZF's
// block size. A member that level 1 shrinks by less than half (a DBA snapshot's float32 flows,
// depth maps and confidences: 0.60-0.91 of their size) is written as deflate's stored blocks
// instead: inflating such data costs 2-2.5 ms per MB, more than reading the bytes it saved from
// a disk faster than ≈ 200 MB/s, while stored blocks read at memory speed (the CRC-32 is checked
// either way). Any gzip reader reads the file (a gzip file may hold several members; stored
// blocks are plain deflate).
// mrpt::io::CFileGZOutputStream::close() ignores what gzclose() returns, so a failure to write the
// last block (disk full, quota) would go unnoticed and a damaged rawlog would be committed;
// Write() and close() here throw instead.
//
// GzInputStream: mrpt::io::CFileGZInputStream asks the file system for the file's size when it
// opens it, which throws for a FIFO or /dev/stdin; this stream reads any readable path
// (gz-compressed or plain) and never seeks. A regular file whose members carry the size subfield
// is read member by member with libdeflate (each member inflated whole, CRC-32 and size checked);
// anything else (other gzip writers, plain files, pipes, or the rest of a file from the first
// member without the subfield) goes through zlib's inflate, member by member. Read() returns the
// bytes read, 0 at the end of the data, and (size_t)-1 on a read error (damaged compressed data,
// or compressed data that ends before its end marker: a truncated file), as CFileGZInputStream
// does for damaged data. A gzip file may hold several members (concatenation is legal), but bytes
// after the last member that do not start another one are a read error too, explained by
// failure(): zlib's gzread ignores such trailing garbage silently, so it is not used.
#pragma once

#include <cstddef>
#include <memory>
#include <string>
#include <vector>

#include <mrpt/io/CStream.h>

struct libdeflate_compressor;
struct z_stream_s;

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

  /// Why the last read failed, when the reason is not damaged or truncated compressed data (which
  /// the readers report in their own words): "N bytes at byte X of the file, after the last gzip
  /// member, are not gzip data (...)". "" otherwise.
  const std::string& failure() const { return failure_; }
  /// True when the file is gzip-compressed (known once the first byte has been read).
  bool compressed() const { return compressed_; }

 private:
  enum class Mode { Blocks, MemberStart, Member, Plain, End };

  /// Reads and inflates the next member with the size subfield into block_; false at the end of
  /// the file or when the next member is not one (then zlib continues from there, mode_ =
  /// MemberStart); throws on damage.
  bool nextBlock();
  /// Switches to zlib at the current file position (mode_ = MemberStart).
  void startZlib();
  /// Reads more of the file after the `z_` input not yet consumed; false at the end of the file.
  bool fill();
  /// zlib modes: the next bytes (fewer after a failure, which sets failed_), 0 at the end, or
  /// (size_t)-1 for damaged compressed data (then nothing of this call is returned).
  size_t readZlib(unsigned char* p, size_t count);
  /// The bytes after the last member are not gzip data: counts them and sets failure_.
  void refuseTrailingBytes();

  std::string path_;
  int fd_ = -1;
  Mode mode_ = Mode::Blocks;          ///< Blocks: regular files first; zlib modes after
  uint64_t offset_ = 0;               ///< compressed bytes consumed in block mode
  std::vector<unsigned char> block_;  ///< the current member's uncompressed bytes, [0, block_end_)
  std::size_t block_end_ = 0;
  std::size_t at_ = 0;                ///< bytes of block_ already returned
  std::vector<unsigned char> raw_;    ///< the current member's compressed bytes (a prefix)
  std::unique_ptr<z_stream_s> z_;     ///< zlib modes: the inflater, its input in input_
  std::vector<unsigned char> input_;  ///< zlib modes: file bytes read, from z_->next_in on unused
  std::vector<unsigned char> out_;    ///< zlib modes: bytes inflated ahead, from out_at_ on unread
  std::size_t out_at_ = 0;
  uint64_t file_read_ = 0;  ///< bytes of the file read so far (block and zlib modes)
  bool eof_ = false;        ///< zlib modes: read(2) returned 0
  bool members_ = false;    ///< a gzip member was decoded (so the file is gzip)
  bool compressed_ = false;
  bool failed_ = false;
  bool last_ = false;  ///< the member just read said it is the file's last
  std::string failure_;
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
  libdeflate_compressor* compressor_ = nullptr;   ///< level 1
  libdeflate_compressor* store_ = nullptr;        ///< level 0: stored blocks
  std::size_t block_bytes_ = kGzFirstBlockBytes;  ///< uncompressed bytes of the next member
  std::vector<unsigned char> pending_;            ///< uncompressed bytes of the member being filled
  std::vector<unsigned char> member_;             ///< the compressed member being written
  std::string failure_;
};

}  // namespace dbacov::mrpt_bridge
