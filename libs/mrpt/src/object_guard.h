// Private to dbacov_mrpt: the object headers of a rawlog, read before MRPT deserializes anything.
//
// MRPT's deserializers trust the sizes they read: a CSensoryFrame that declares 4 billion
// observations makes MRPT grow a container until memory runs out, and so would other classes.
// RawlogReader therefore looks at each object's header first (PeekStream hands the same bytes on
// to MRPT unchanged): it reads CSensoryFrame containers itself, with a bounded count, and lets
// MRPT deserialize only the classes its caller accepts.
//
// MRPT's object format (CArchive::WriteObject, MRPT >= 0.5.5): a byte 0x80 | n, the class name
// in n <= 120 bytes (MRPT reads it up to the first NUL and also finds a class by its name
// without namespace), a version byte, the object's data, the end flag 0x88.
#pragma once

#include <cstddef>
#include <cstdint>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include <mrpt/io/CStream.h>

namespace dbacov::mrpt_bridge {

/// Most observations accepted in one CSensoryFrame of a rawlog.
/// (A frame is held in memory while its observations are handed out; DBA rawlogs hold one
/// snapshot per frame.)
constexpr std::uint32_t kMaxFrameObservations = 1u << 16;

/// An input stream whose next bytes can be looked at before they are read.
class PeekStream : public mrpt::io::CStream {
 public:
  explicit PeekStream(std::unique_ptr<mrpt::io::CStream> in) : in_(std::move(in)) {}
  /// Makes at least `n` bytes available in peeked() unless the stream ends (or fails) first;
  /// returns how many are available.
  std::size_t peek(std::size_t n);
  const std::vector<unsigned char>& peeked() const { return buffer_; }
  /// True once the stream reported a read error while peeking (see GzInputStream::Read).
  bool failed() const { return failed_; }
  /// Reads exactly `n` bytes into `out`; false if the stream ends first.
  bool readExact(void* out, std::size_t n);

  size_t Read(void* buffer, size_t count) override;
  size_t Write(const void* buffer, size_t count) override { return in_->Write(buffer, count); }
  uint64_t Seek(int64_t offset, TSeekOrigin origin) override { return in_->Seek(offset, origin); }
  uint64_t getTotalBytesCount() const override { return in_->getTotalBytesCount(); }
  uint64_t getPosition() const override { return in_->getPosition() - buffer_.size(); }

 private:
  std::unique_ptr<mrpt::io::CStream> in_;
  std::vector<unsigned char> buffer_;  ///< bytes read from in_ but not yet handed out
  bool failed_ = false;
};

struct ObjectHeader {
  std::string class_name;  ///< as MRPT reads it (up to the first NUL)
  std::string short_name;  ///< without namespace: what MRPT looks the class up by
  int version = 0;
  std::size_t bytes = 0;  ///< length of the header (length byte, name, version)
};

/// The header of the next object, left in the stream (peeked); std::nullopt at the end of the
/// stream. Throws InputError (saying what, not where) for a read error, a truncated header, a
/// class name longer than MRPT accepts, or MRPT's pre-0.5.5 object format.
std::optional<ObjectHeader> peekObjectHeader(PeekStream& in);

/// After `header` of a CSensoryFrame (still in the stream): consumes it and the frame's fields up
/// to its observations, and returns how many it declares. Throws InputError for an unknown
/// version, a truncated frame, or more than kMaxFrameObservations observations.
std::uint32_t readFrameStart(PeekStream& in, const ObjectHeader& header);

/// Consumes the end flag (0x88) that follows every object; InputError if it is not there.
void readEndFlag(PeekStream& in, const ObjectHeader& header);

}  // namespace dbacov::mrpt_bridge
