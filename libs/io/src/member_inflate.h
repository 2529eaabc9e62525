// Private to dbacov_io: whole-buffer inflation of zip members with libdeflate (not installed).
#pragma once

#include <cstddef>
#include <cstdint>
#include <string>

#include "dbacov/io/npy.h"

namespace dbacov::io {

/// What inflateMember() found.
enum class InflateStatus {
  Ok,       ///< exactly `size` bytes, CRC-32 matches
  BadData,  ///< the deflate stream is invalid
  Short,    ///< the stream ends before `size` bytes (the bytes that did arrive are returned)
  TooLong,  ///< the stream holds more than `size` bytes
  BadCrc,   ///< `size` bytes, but their CRC-32 is not `crc`
};

struct InflatedMember {
  InflateStatus status = InflateStatus::Ok;
  ByteVector bytes;  ///< the uncompressed bytes (Ok, BadCrc, Short; empty otherwise)
};

/// Inflates the raw deflate stream `in` that should hold `size` bytes with CRC-32 `crc`
/// (deflated = false: `in` is a stored member, only its CRC is checked and `in` itself becomes
/// the result). Thread-safe (one libdeflate decompressor per thread).
InflatedMember inflateMember(ByteVector in, std::uint64_t size, std::uint32_t crc, bool deflated);

/// CRC-32 (zip / gzip polynomial) of `n` bytes, continuing from `crc` (0 to start).
std::uint32_t crc32Of(const unsigned char* p, std::size_t n, std::uint32_t crc = 0);

}  // namespace dbacov::io
