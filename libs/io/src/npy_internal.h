// Private helpers of dbacov_io shared by the .npy, .npz and file readers (not installed).
#pragma once

#include <cstddef>
#include <cstdint>
#include <functional>
#include <limits>
#include <string>
#include <vector>

#include "dbacov/io/npy.h"

namespace dbacov::io {

/// Little-endian load/store of an unsigned integer, independent of the host byte order.
template <typename U>
U loadLE(const unsigned char* p) {
  U v = 0;
  for (std::size_t i = 0; i < sizeof(U); ++i)
    v = static_cast<U>(v | (static_cast<U>(p[i]) << (8 * i)));
  return v;
}
template <typename U>
void storeLE(unsigned char* p, U v) {
  for (std::size_t i = 0; i < sizeof(U); ++i) p[i] = static_cast<unsigned char>(v >> (8 * i));
}

/// Product of `shape` (1 for a scalar) into *n; false if the product of the non-zero dimensions
/// overflows size_t (rejected even when another dimension is zero, as NumPy does).
inline bool checkedNumElements(const std::vector<std::size_t>& shape, std::size_t* n) {
  std::size_t p = 1;
  bool zero = false;
  for (std::size_t d : shape) {
    if (d == 0) {
      zero = true;
      continue;
    }
    if (p > std::numeric_limits<std::size_t>::max() / d) return false;
    p *= d;
  }
  *n = zero ? 0 : p;
  return true;
}

/// DType of a descr string such as "<f4"; throws InputError naming `context` otherwise.
NpyArray::DType dtypeFromDescr(const std::string& descr, const std::string& context);

/// The header text (dict, growth padding, alignment padding, '\n') that np.save writes for a
/// C-contiguous array of this dtype and shape, version 1.0.
std::string npyHeaderText(const NpyArray& array);

/// Reads up to `n` bytes into `dst`; returns the count read, 0 only at the end of the stream;
/// throws InputError on a read error.
using ByteReader = std::function<std::size_t(unsigned char* dst, std::size_t n)>;

/// Reads one .npy array from a stream that holds exactly `available` bytes. The header is parsed
/// and its declared size compared with `available` before the data buffer is allocated.
NpyArray readNpyStream(std::uint64_t available, const ByteReader& read, const std::string& context);

/// The same for a stream already in memory: `bytes` is what arrived of a container member that
/// claims `available` bytes (fewer when it was cut short). Same checks and messages as
/// readNpyStream; when complete, the data moves into the array without another buffer.
NpyArray parseNpyBuffer(ByteVector bytes, std::uint64_t available, const std::string& context);

}  // namespace dbacov::io
