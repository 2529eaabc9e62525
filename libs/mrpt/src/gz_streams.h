// Private to dbacov_mrpt: MRPT streams over zlib's gzread / gzwrite, for rawlogs.
//
// GzInputStream: mrpt::io::CFileGZInputStream asks the file system for the file's size when it
// opens it, which throws for a FIFO or /dev/stdin; this stream reads any readable path
// (gz-compressed or plain, zlib detects which) and never seeks. Read() returns the bytes read, 0 at
// the end of the data, and (size_t)-1 on a read error (damaged compressed data, or compressed data
// that ends before its end marker: a truncated file), as CFileGZInputStream does for damaged data.
//
// GzOutputStream: mrpt::io::CFileGZOutputStream::close() ignores what gzclose() returns, so a
// failure to write the last compressed block and the trailer (disk full, quota) goes unnoticed and
// a damaged rawlog would be committed. close() here throws instead, and so does Write().
#pragma once

#include <string>

#include <mrpt/io/CStream.h>

struct gzFile_s;

namespace dbacov::mrpt_bridge {

/// What both streams share: the gzFile, opened by the constructor and closed by the destructor;
/// no seeking; the position in the uncompressed data.
class GzFileStream : public mrpt::io::CStream {
 public:
  ~GzFileStream() override;
  GzFileStream(const GzFileStream&) = delete;
  GzFileStream& operator=(const GzFileStream&) = delete;

  uint64_t Seek(int64_t offset, TSeekOrigin origin) override;  ///< throws std::logic_error
  uint64_t getTotalBytesCount() const override { return 0; }   ///< unknown (may be a pipe)
  uint64_t getPosition() const override;
  std::string getStreamDescription() const override { return "rawlog " + name_; }

 protected:
  /// gzopen(path, mode); InputError "<name>: cannot open <what>: <reason>" on failure.
  GzFileStream(const std::string& path, std::string name, const char* mode, const char* what);

  std::string name_;  ///< the file as messages name it
  gzFile_s* gz_ = nullptr;
};

class GzInputStream : public GzFileStream {
 public:
  /// Opens `path`; throws InputError naming it (and the system's reason) when it cannot.
  explicit GzInputStream(const std::string& path);

  size_t Read(void* buffer, size_t count) override;
  size_t Write(const void* buffer, size_t count) override;  ///< throws std::logic_error
};

class GzOutputStream : public GzFileStream {
 public:
  /// Creates `path` (gzip, compression level 1, as MRPT's rawlogs); messages name the file
  /// `name` (e.g. the final path of an atomic output). InputError on failure. Destroyed without
  /// close(), the stream is abandoned (its file is the caller's to discard).
  GzOutputStream(const std::string& path, const std::string& name);

  size_t Read(void* buffer, size_t count) override;  ///< throws std::logic_error
  /// Writes every byte or throws InputError naming the file and zlib's or the system's reason.
  size_t Write(const void* buffer, size_t count) override;

  /// Flushes the last block and the gzip trailer; InputError when that fails.
  void close();
  /// The message of the last failed Write() ("" if none).
  const std::string& failure() const { return failure_; }

 private:
  std::string failure_;
};

}  // namespace dbacov::mrpt_bridge
