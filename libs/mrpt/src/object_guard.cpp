#include "object_guard.h"

#include <algorithm>
#include <cstring>

#include "dbacov/core/errors.h"
#include "dbacov/mrpt/mrpt_errors.h"

namespace dbacov::mrpt_bridge {

std::size_t PeekStream::peek(std::size_t n) {
  unsigned char chunk[256];
  while (buffer_.size() < n) {
    const std::size_t want = std::min(sizeof chunk, n - buffer_.size());
    const std::size_t got = in_->Read(chunk, want);
    if (got > want) failed_ = true;  // a read error ((size_t)-1)
    if (got == 0 || got > want) break;
    buffer_.insert(buffer_.end(), chunk, chunk + got);
  }
  return std::min(n, buffer_.size());
}

bool PeekStream::readExact(void* out, std::size_t n) {
  return peek(n) == n && Read(out, n) == n;
}

size_t PeekStream::Read(void* buffer, size_t count) {
  if (buffer_.empty()) return in_->Read(buffer, count);
  // The peeked bytes first, then the rest from the stream: MRPT takes a short read for the end.
  const std::size_t n = std::min(count, buffer_.size());
  std::memcpy(buffer, buffer_.data(), n);
  buffer_.erase(buffer_.begin(), buffer_.begin() + static_cast<std::ptrdiff_t>(n));
  if (n == count) return n;
  const std::size_t more = in_->Read(static_cast<unsigned char*>(buffer) + n, count - n);
  return more > count - n ? more : n + more;  // (size_t)-1: the stream's read error
}

std::optional<ObjectHeader> peekObjectHeader(PeekStream& in) {
  if (in.peek(1) == 0) {
    if (in.failed())
      throw InputError("read error: the compressed data is damaged or ends early (truncated)");
    return std::nullopt;
  }
  const unsigned char first = in.peeked()[0];
  if (!(first & 0x80))
    throw InputError(
        "not an object in MRPT's serialization format (a rawlog written by MRPT >= "
        "0.5.5 is expected)");
  const std::size_t length = first & 0x7F;
  if (length > 120)
    throw InputError("the object's class name has " + std::to_string(length) +
                     " bytes, more than MRPT's 120");
  ObjectHeader h;
  h.bytes = 1 + length + 1;
  if (in.peek(h.bytes) < h.bytes) throw InputError("the object's header is truncated");
  const auto name = in.peeked().begin() + 1;
  h.class_name.assign(name, std::find(name, name + static_cast<long>(length), '\0'));
  const std::size_t colons = h.class_name.rfind("::");
  h.short_name = h.class_name.substr(colons == std::string::npos ? 0 : colons + 2);
  h.version = in.peeked()[1 + length];
  return h;
}

std::uint32_t readFrameStart(PeekStream& in, const ObjectHeader& h) {
  std::vector<unsigned char> skip(h.bytes);
  in.readExact(skip.data(), skip.size());  // peeked: always there
  // Versions 0 and 1 start with a uint32 ID, version 0 then a uint64 time stamp; every version
  // goes on with the uint32 observation count.
  if (h.version > 2)
    throw InputError("CSensoryFrame of unknown serialization version " + std::to_string(h.version));
  const std::size_t before = h.version == 2 ? 0 : h.version == 1 ? 4 : 12;
  unsigned char fields[16];
  if (!in.readExact(fields, before + 4)) throw InputError("CSensoryFrame truncated");
  std::uint32_t count = 0;
  for (std::size_t i = 0; i < 4; ++i)
    count |= static_cast<std::uint32_t>(fields[before + i]) << (8 * i);
  if (count > kMaxFrameObservations)
    throw InputError("CSensoryFrame declares " + std::to_string(count) +
                     " observations, more than the " + std::to_string(kMaxFrameObservations) +
                     " accepted");
  return count;
}

void readEndFlag(PeekStream& in, const ObjectHeader& h) {
  unsigned char flag = 0;
  if (!in.readExact(&flag, 1) || flag != 0x88)
    throw InputError("the " + printable(h.class_name) +
                     " object does not end with MRPT's end flag (damaged)");
}

}  // namespace dbacov::mrpt_bridge
