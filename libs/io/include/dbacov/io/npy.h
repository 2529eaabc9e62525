// NumPy `.npy` arrays: a strict, hand-written parser and writer (format versions 1.0, 2.0, 3.0).
//
// What is accepted:
//   - magic "\x93NUMPY", versions 1.0 (uint16 header length), 2.0 and 3.0 (uint32 header length);
//   - a header dict with exactly the keys 'descr', 'fortran_order', 'shape' in any order, with
//     arbitrary spaces and an optional trailing comma (single or double quotes);
//   - descr '<f4' '<f8' '<i4' '<i8' (little-endian) and '|u1' '|b1' (byte-sized; '<u1' '<b1' too);
//   - fortran_order False only; shape a tuple of non-negative integers: `()` is a scalar (one
//     element), `(5,)` a vector; `(5)` and Python-2 longs `5L` are tolerated;
//   - a data section of exactly prod(shape) * itemsize bytes after the header.
// Everything else throws dbacov::InputError: big-endian ('>'), native ('='), object ('|O'),
// structured (a list descr), other dtypes, Fortran order, a truncated or oversized data section,
// a malformed header, a header longer than kMaxNpyHeaderBytes. Every message starts with the
// caller's `context` (e.g. "droid.npz: key 'target'") and says what was wrong.
//
// Size safety: the byte count that a header declares is computed with overflow checks and compared
// with the bytes actually available before anything is allocated, so a forged shape can never
// trigger a large allocation.
//
// Byte order of the data is decoded explicitly (little-endian in the file, any host order).
#pragma once

#include <cstddef>
#include <cstdint>
#include <memory>
#include <new>
#include <string>
#include <type_traits>
#include <utility>
#include <vector>

#include "dbacov/core/errors.h"

namespace dbacov::io {

/// Longest accepted header (dict text plus padding). NumPy itself refuses more than 10000 bytes.
inline constexpr std::size_t kMaxNpyHeaderBytes = 65536;
/// Most dimensions accepted in a shape (NumPy 2 allows 64).
inline constexpr std::size_t kMaxNpyDims = 64;

/// std::allocator, except that elements a vector adds without a value (resize(n), vector(n)) are
/// default-initialized: for bytes, left as they are instead of zeroed. An array's bytes are written
/// once, by a file read or an inflater, so zeroing them first would cost another pass over
/// megabytes per snapshot (4.6 % of a 60-snapshot run's time). (libstdc++ copies through such
/// an allocator element by element; optimized builds turn those loops back into memcpy.)
template <typename T>
struct DefaultInitAllocator : std::allocator<T> {
  template <typename U>
  struct rebind {
    using other = DefaultInitAllocator<U>;
  };
  DefaultInitAllocator() noexcept = default;
  template <typename U>
  DefaultInitAllocator(const DefaultInitAllocator<U>&) noexcept {}  // NOLINT: rebinding
  template <typename U>
  void construct(U* p) noexcept(std::is_nothrow_default_constructible_v<U>) {
    ::new (static_cast<void*>(p)) U;
  }
  template <typename U, typename... Args>
  void construct(U* p, Args&&... args) {
    ::new (static_cast<void*>(p)) U(std::forward<Args>(args)...);
  }
};

/// Bytes that resize() does not zero (DefaultInitAllocator).
using ByteVector = std::vector<unsigned char, DefaultInitAllocator<unsigned char>>;
// Without its own rebind, C++17's std::allocator::rebind would quietly make vectors of
// std::allocator again, which zero.
static_assert(
    std::is_same_v<std::allocator_traits<DefaultInitAllocator<unsigned char>>::rebind_alloc<int>,
                   DefaultInitAllocator<int>>);
static_assert(std::is_same_v<ByteVector::allocator_type, DefaultInitAllocator<unsigned char>>);

/// One array: dtype, C-order shape and the raw little-endian element bytes.
struct NpyArray {
  enum class DType { Float32, Float64, Int32, Int64, UInt8, Bool };
  DType dtype = DType::Float64;
  std::vector<std::size_t> shape;  ///< empty = scalar (one element)
  ByteVector data;  ///< numElements(shape) * itemSize(dtype) bytes, little-endian (resize() does
                    ///< not zero new bytes: write them)

  /// Number of elements (product of shape; 1 for a scalar).
  std::size_t size() const;
};

/// Bytes per element: 4, 8, 4, 8, 1, 1.
std::size_t itemSize(NpyArray::DType dtype);
/// "float32", "float64", "int32", "int64", "uint8", "bool".
const char* dtypeName(NpyArray::DType dtype);
/// NumPy's descr string: "<f4", "<f8", "<i4", "<i8", "|u1", "|b1".
const char* dtypeDescr(NpyArray::DType dtype);
/// "(58,2,49,61)", "(5,)", "()" — the form used in error messages.
std::string shapeToString(const std::vector<std::size_t>& shape);

/// The parsed header of an .npy byte stream.
struct NpyHeader {
  NpyArray::DType dtype = NpyArray::DType::Float64;
  std::vector<std::size_t> shape;
  std::size_t data_offset = 0;  ///< bytes before the data section (preamble + header text)
  std::size_t data_bytes = 0;   ///< prod(shape) * itemsize, overflow-checked
};

/// Bytes needed to know the header length: 10 for version 1.0, 12 for 2.0/3.0. Given at least the
/// first 8 bytes (magic + version), returns the preamble size; throws InputError on a bad magic or
/// an unsupported version.
std::size_t npyPreambleSize(const unsigned char* bytes, std::size_t size,
                            const std::string& context);

/// Total bytes of preamble + header text (= NpyHeader::data_offset), from the first
/// npyPreambleSize() bytes. Throws InputError if they are missing or the header is too long.
std::size_t npyHeaderSize(const unsigned char* bytes, std::size_t size, const std::string& context);

/// Parses the header from `bytes` (which must hold at least npyHeaderSize() bytes; the data may
/// follow but is not needed). Throws InputError on anything not accepted above.
NpyHeader parseNpyHeader(const unsigned char* bytes, std::size_t size, const std::string& context);

/// Parses a complete .npy byte stream. The data section must be exactly the declared size.
NpyArray parseNpy(const unsigned char* bytes, std::size_t size, const std::string& context);
inline NpyArray parseNpy(const std::vector<unsigned char>& bytes, const std::string& context) {
  return parseNpy(bytes.data(), bytes.size(), context);
}

/// Serializes as NumPy's np.save does for a C-contiguous array: version 1.0, header dict with
/// sorted keys and NumPy's growth padding, total header length a multiple of 64 ending in '\n'.
/// Throws std::invalid_argument (misuse) if data.size() does not match shape and dtype.
std::vector<unsigned char> serializeNpy(const NpyArray& array);

/// Builds an array from values in C order; `shape` {} means a scalar. Throws std::invalid_argument
/// if values.size() differs from the product of shape.
NpyArray makeNpy(const std::vector<float>& values, std::vector<std::size_t> shape);
NpyArray makeNpy(const std::vector<double>& values, std::vector<std::size_t> shape);
NpyArray makeNpy(const std::vector<std::int32_t>& values, std::vector<std::size_t> shape);
NpyArray makeNpy(const std::vector<std::int64_t>& values, std::vector<std::size_t> shape);
NpyArray makeNpy(const std::vector<std::uint8_t>& values, std::vector<std::size_t> shape);

/// Values of a float32/float64 array as double. Any other dtype throws InputError naming
/// `context`, the dtype found and "expected float32 or float64".
std::vector<double> npyToDoubles(const NpyArray& array, const std::string& context);
/// Values of a float32/float64 array as float. A finite float64 outside the float32 range throws.
std::vector<float> npyToFloats(const NpyArray& array, const std::string& context);
/// Values of an int32/int64 array (index arrays). Floats, bool and uint8 throw InputError.
std::vector<std::int64_t> npyToInt64s(const NpyArray& array, const std::string& context);

/// Reads a single .npy file. The file size is checked against the header before the data is
/// allocated. Errors (cannot open, truncated, bad header) throw InputError naming the path.
NpyArray readNpyFile(const std::string& path);

/// Writes a single .npy file atomically (see AtomicOutputFile): on any failure the previous file at
/// `path`, if any, is untouched. Throws InputError naming the path.
void writeNpyFileAtomically(const std::string& path, const NpyArray& array);

}  // namespace dbacov::io
