// .npy arrays: element access, serialization, typed construction and conversion, single files.
#include "dbacov/io/npy.h"

#include <algorithm>
#include <cerrno>
#include <cmath>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <limits>
#include <stdexcept>
#include <type_traits>

#include "dbacov/io/atomic_file.h"
#include "npy_internal.h"

namespace dbacov::io {
namespace {

using DType = NpyArray::DType;

/// Element count of a well-formed array; throws std::invalid_argument (misuse) otherwise.
std::size_t checkedByteSize(const NpyArray& a) {
  std::size_t n = 0;
  if (!checkedNumElements(a.shape, &n) || a.data.size() / itemSize(a.dtype) != n ||
      a.data.size() % itemSize(a.dtype) != 0)
    throw std::invalid_argument("NpyArray: " + std::to_string(a.data.size()) +
                                " data bytes do not match shape " + shapeToString(a.shape) +
                                " of " + dtypeName(a.dtype));
  return n;
}

template <typename T, typename U>
NpyArray makeTyped(const std::vector<T>& values, std::vector<std::size_t> shape, DType dtype) {
  static_assert(sizeof(T) == sizeof(U));
  std::size_t n = 0;
  if (!checkedNumElements(shape, &n) || n != values.size())
    throw std::invalid_argument("makeNpy: " + std::to_string(values.size()) +
                                " values do not fill shape " + shapeToString(shape));
  NpyArray a;
  a.dtype = dtype;
  a.shape = std::move(shape);
  a.data.resize(n * sizeof(T));
  for (std::size_t i = 0; i < n; ++i) {
    U bits;
    std::memcpy(&bits, &values[i], sizeof(T));
    storeLE<U>(&a.data[i * sizeof(T)], bits);
  }
  return a;
}

template <typename T, typename U>
T loadValue(const unsigned char* p) {
  const U bits = loadLE<U>(p);
  T v;
  std::memcpy(&v, &bits, sizeof(T));
  return v;
}

/// Reads consecutive little-endian elements (C++ type T, stored as U bits) as Out, so that a
/// vector is built from the bytes in one pass (a range constructor), without the zero-filling
/// pass that `std::vector<Out>(n)` and a copy would add. A proxy iterator: `reference` is a value.
template <typename Out, typename T, typename U>
class ElementReader {
 public:
  using iterator_category = std::random_access_iterator_tag;
  using value_type = Out;
  using difference_type = std::ptrdiff_t;
  using pointer = const Out*;
  using reference = Out;

  ElementReader() = default;
  explicit ElementReader(const unsigned char* p) : p_(p) {}
  Out operator*() const {
#if defined(__BYTE_ORDER__) && __BYTE_ORDER__ == __ORDER_LITTLE_ENDIAN__
    if constexpr (std::is_same_v<Out, T>) {  // the file's bytes are the host's value
      Out v;
      std::memcpy(&v, p_, sizeof v);
      return v;
    }
#endif
    return static_cast<Out>(loadValue<T, U>(p_));
  }
  Out operator[](difference_type i) const {
    return *(*this + i);
  }
  ElementReader& operator++() {
    p_ += sizeof(T);
    return *this;
  }
  ElementReader operator++(int) {
    ElementReader old = *this;
    ++*this;
    return old;
  }
  ElementReader& operator--() {
    p_ -= sizeof(T);
    return *this;
  }
  ElementReader operator--(int) {
    ElementReader old = *this;
    --*this;
    return old;
  }
  ElementReader& operator+=(difference_type d) {
    p_ += d * static_cast<difference_type>(sizeof(T));
    return *this;
  }
  ElementReader& operator-=(difference_type d) {
    return *this += -d;
  }
  friend ElementReader operator+(ElementReader a, difference_type d) {
    return a += d;
  }
  friend ElementReader operator+(difference_type d, ElementReader a) {
    return a += d;
  }
  friend ElementReader operator-(ElementReader a, difference_type d) {
    return a -= d;
  }
  friend difference_type operator-(const ElementReader& a, const ElementReader& b) {
    return (a.p_ - b.p_) / static_cast<difference_type>(sizeof(T));
  }
  friend bool operator==(const ElementReader& a, const ElementReader& b) {
    return a.p_ == b.p_;
  }
  friend bool operator!=(const ElementReader& a, const ElementReader& b) {
    return a.p_ != b.p_;
  }
  friend bool operator<(const ElementReader& a, const ElementReader& b) {
    return a.p_ < b.p_;
  }
  friend bool operator>(const ElementReader& a, const ElementReader& b) {
    return b < a;
  }
  friend bool operator<=(const ElementReader& a, const ElementReader& b) {
    return !(b < a);
  }
  friend bool operator>=(const ElementReader& a, const ElementReader& b) {
    return !(a < b);
  }

 private:
  const unsigned char* p_ = nullptr;
};

/// Decodes every element of `a` (of C++ type T, stored as U bits) into Out.
template <typename Out, typename T, typename U>
std::vector<Out> decodeAll(const NpyArray& a, std::size_t n) {
  const ElementReader<Out, T, U> first(a.data.data());
  return std::vector<Out>(first, first + static_cast<std::ptrdiff_t>(n));
}

[[noreturn]] void wrongDtype(const NpyArray& a, const std::string& context, const char* expected) {
  throw InputError(context + " has dtype " + dtypeName(a.dtype) + ", expected " + expected);
}

}  // namespace

std::size_t NpyArray::size() const {
  std::size_t n = 0;
  if (!checkedNumElements(shape, &n))
    throw std::invalid_argument("NpyArray: shape " + shapeToString(shape) + " overflows");
  return n;
}

std::size_t itemSize(DType dtype) {
  switch (dtype) {
    case DType::Float32:
    case DType::Int32:
      return 4;
    case DType::Float64:
    case DType::Int64:
      return 8;
    case DType::UInt8:
    case DType::Bool:
      return 1;
  }
  throw std::invalid_argument("itemSize: invalid DType");
}

const char* dtypeName(DType dtype) {
  switch (dtype) {
    case DType::Float32:
      return "float32";
    case DType::Float64:
      return "float64";
    case DType::Int32:
      return "int32";
    case DType::Int64:
      return "int64";
    case DType::UInt8:
      return "uint8";
    case DType::Bool:
      return "bool";
  }
  return "invalid";
}

const char* dtypeDescr(DType dtype) {
  switch (dtype) {
    case DType::Float32:
      return "<f4";
    case DType::Float64:
      return "<f8";
    case DType::Int32:
      return "<i4";
    case DType::Int64:
      return "<i8";
    case DType::UInt8:
      return "|u1";
    case DType::Bool:
      return "|b1";
  }
  throw std::invalid_argument("dtypeDescr: invalid DType");
}

std::string shapeToString(const std::vector<std::size_t>& shape) {
  std::string s = "(";
  for (std::size_t i = 0; i < shape.size(); ++i) s += (i ? "," : "") + std::to_string(shape[i]);
  return s + (shape.size() == 1 ? ",)" : ")");
}

NpyArray parseNpy(const unsigned char* bytes, std::size_t size, const std::string& context) {
  const NpyHeader h = parseNpyHeader(bytes, size, context);
  if (size - h.data_offset != h.data_bytes)
    throw InputError(context + ": declared shape " + shapeToString(h.shape) + " of " +
                     dtypeName(h.dtype) + " needs " + std::to_string(h.data_bytes) +
                     " data bytes, but " + std::to_string(size - h.data_offset) + " are present");
  NpyArray a;
  a.dtype = h.dtype;
  a.shape = h.shape;
  a.data.assign(bytes + h.data_offset, bytes + size);
  return a;
}

NpyArray readNpyStream(std::uint64_t available, const ByteReader& read,
                       const std::string& context) {
  // Reads n bytes into dst; `before` and `total` give the bytes of the part (`what`) read before
  // this call and its whole size, for the message.
  auto readExact = [&](unsigned char* dst, std::size_t n, const char* what, std::size_t before = 0,
                       std::size_t total = 0) {
    for (std::size_t got = 0; got < n;) {
      const std::size_t r = read(dst + got, n - got);
      if (r == 0)
        throw InputError(context + ": truncated .npy " + what + " (" +
                         std::to_string(before + got) + " of " + std::to_string(total ? total : n) +
                         " bytes)");
      got += r;
    }
  };
  std::vector<unsigned char> head(8);
  if (available < head.size())
    throw InputError(context + ": truncated .npy data (" + std::to_string(available) + " bytes)");
  readExact(head.data(), head.size(), "preamble");
  const std::size_t pre = npyPreambleSize(head.data(), head.size(), context);
  if (available < pre) throw InputError(context + ": truncated .npy preamble");
  head.resize(pre);
  readExact(head.data() + 8, pre - 8, "preamble");
  const std::size_t total = npyHeaderSize(head.data(), head.size(), context);
  if (available < total)
    throw InputError(context + ": truncated .npy header (" + std::to_string(available) +
                     " bytes, the header needs " + std::to_string(total) + ")");
  head.resize(total);
  readExact(head.data() + pre, total - pre, "header");
  const NpyHeader h = parseNpyHeader(head.data(), head.size(), context);
  // Compare the declared size with what is there BEFORE allocating the data buffer.
  if (available - h.data_offset != h.data_bytes)
    throw InputError(context + ": declared shape " + shapeToString(h.shape) + " of " +
                     dtypeName(h.dtype) + " needs " + std::to_string(h.data_bytes) +
                     " data bytes, but " + std::to_string(available - h.data_offset) +
                     " are present");
  NpyArray a;
  a.dtype = h.dtype;
  a.shape = h.shape;
  // `available` is what the container claims (a zip member's recorded size), not bytes in hand: a
  // damaged deflate stream may claim far more than it delivers. Grow the buffer with the data that
  // really arrives, so memory stays proportional to it.
  constexpr std::size_t kStep = std::size_t{16} << 20;
  while (a.data.size() < h.data_bytes) {
    const std::size_t done = a.data.size();
    const std::size_t step = std::min(h.data_bytes - done, std::max(kStep, done));
    a.data.resize(done + step);
    readExact(a.data.data() + done, step, "data", done, h.data_bytes);
  }
  unsigned char extra = 0;
  if (read(&extra, 1) != 0) throw InputError(context + ": more data than the header declares");
  return a;
}

NpyArray parseNpyBuffer(ByteVector bytes, std::uint64_t available, const std::string& context) {
  if (bytes.size() != available) {  // cut short: let the stream reader name what is missing
    std::size_t at = 0;
    return readNpyStream(
        available,
        [&](unsigned char* dst, std::size_t n) -> std::size_t {
          n = std::min(n, bytes.size() - at);
          std::copy_n(bytes.data() + at, n, dst);
          at += n;
          return n;
        },
        context);
  }
  // The same checks as readNpyStream, in the same order, on bytes in hand.
  if (bytes.size() < 8)
    throw InputError(context + ": truncated .npy data (" + std::to_string(bytes.size()) +
                     " bytes)");
  const std::size_t pre = npyPreambleSize(bytes.data(), 8, context);
  if (bytes.size() < pre) throw InputError(context + ": truncated .npy preamble");
  const std::size_t total = npyHeaderSize(bytes.data(), pre, context);
  if (bytes.size() < total)
    throw InputError(context + ": truncated .npy header (" + std::to_string(bytes.size()) +
                     " bytes, the header needs " + std::to_string(total) + ")");
  const NpyHeader h = parseNpyHeader(bytes.data(), total, context);
  if (bytes.size() - h.data_offset != h.data_bytes)
    throw InputError(context + ": declared shape " + shapeToString(h.shape) + " of " +
                     dtypeName(h.dtype) + " needs " + std::to_string(h.data_bytes) +
                     " data bytes, but " + std::to_string(bytes.size() - h.data_offset) +
                     " are present");
  NpyArray a;
  a.dtype = h.dtype;
  a.shape = h.shape;
  bytes.erase(bytes.begin(), bytes.begin() + static_cast<std::ptrdiff_t>(h.data_offset));
  a.data = std::move(bytes);
  return a;
}

std::vector<unsigned char> serializeNpy(const NpyArray& array) {
  checkedByteSize(array);
  if (array.shape.size() > kMaxNpyDims)
    throw std::invalid_argument("serializeNpy: more than " + std::to_string(kMaxNpyDims) +
                                " dimensions");
  const std::string header = npyHeaderText(array);
  static constexpr unsigned char kPreamble[8] = {0x93, 'N', 'U', 'M', 'P', 'Y', 1, 0};
  std::vector<unsigned char> out(10 + header.size() + array.data.size());
  std::copy(std::begin(kPreamble), std::end(kPreamble), out.begin());
  storeLE<std::uint16_t>(&out[8], static_cast<std::uint16_t>(header.size()));
  std::copy(header.begin(), header.end(), out.begin() + 10);
  std::copy(array.data.begin(), array.data.end(),
            out.begin() + 10 + static_cast<long>(header.size()));
  return out;
}

NpyArray makeNpy(const std::vector<float>& v, std::vector<std::size_t> shape) {
  return makeTyped<float, std::uint32_t>(v, std::move(shape), DType::Float32);
}
NpyArray makeNpy(const std::vector<double>& v, std::vector<std::size_t> shape) {
  return makeTyped<double, std::uint64_t>(v, std::move(shape), DType::Float64);
}
NpyArray makeNpy(const std::vector<std::int32_t>& v, std::vector<std::size_t> shape) {
  return makeTyped<std::int32_t, std::uint32_t>(v, std::move(shape), DType::Int32);
}
NpyArray makeNpy(const std::vector<std::int64_t>& v, std::vector<std::size_t> shape) {
  return makeTyped<std::int64_t, std::uint64_t>(v, std::move(shape), DType::Int64);
}
NpyArray makeNpy(const std::vector<std::uint8_t>& v, std::vector<std::size_t> shape) {
  return makeTyped<std::uint8_t, std::uint8_t>(v, std::move(shape), DType::UInt8);
}

std::vector<double> npyToDoubles(const NpyArray& a, const std::string& context) {
  const std::size_t n = checkedByteSize(a);
  if (a.dtype == DType::Float32) return decodeAll<double, float, std::uint32_t>(a, n);
  if (a.dtype == DType::Float64) return decodeAll<double, double, std::uint64_t>(a, n);
  wrongDtype(a, context, "float32 or float64");
}

std::vector<float> npyToFloats(const NpyArray& a, const std::string& context) {
  const std::size_t n = checkedByteSize(a);
  if (a.dtype == DType::Float32) return decodeAll<float, float, std::uint32_t>(a, n);
  if (a.dtype != DType::Float64) wrongDtype(a, context, "float32 or float64");
  const std::vector<double> d = decodeAll<double, double, std::uint64_t>(a, n);
  for (std::size_t i = 0; i < n; ++i)
    if (std::isfinite(d[i]) && std::fabs(d[i]) > std::numeric_limits<float>::max())
      throw InputError(context + ": value " + std::to_string(d[i]) + " at flat index " +
                       std::to_string(i) + " is outside the float32 range");
  return std::vector<float>(d.begin(), d.end());
}

std::vector<std::int64_t> npyToInt64s(const NpyArray& a, const std::string& context) {
  const std::size_t n = checkedByteSize(a);
  if (a.dtype == DType::Int32) return decodeAll<std::int64_t, std::int32_t, std::uint32_t>(a, n);
  if (a.dtype == DType::Int64) return decodeAll<std::int64_t, std::int64_t, std::uint64_t>(a, n);
  wrongDtype(a, context, "int32 or int64");
}

NpyArray readNpyFile(const std::string& path) {
  std::error_code ec;
  if (!std::filesystem::is_regular_file(path, ec))
    throw InputError(path + ": not a readable regular file" + (ec ? ": " + ec.message() : ""));
  std::ifstream in(path, std::ios::binary);
  if (!in) throw InputError(path + ": cannot open: " + std::strerror(errno));
  const std::uintmax_t size = std::filesystem::file_size(path, ec);
  if (ec) throw InputError(path + ": cannot get the file size: " + ec.message());
  return readNpyStream(
      size,
      [&](unsigned char* dst, std::size_t n) -> std::size_t {
        in.read(reinterpret_cast<char*>(dst), static_cast<std::streamsize>(n));
        if (in.bad()) throw InputError(path + ": read error");
        return static_cast<std::size_t>(in.gcount());
      },
      path);
}

void writeNpyFileAtomically(const std::string& path, const NpyArray& array) {
  const std::vector<unsigned char> bytes = serializeNpy(array);
  AtomicOutputFile out(path);
  out.write(bytes.data(), bytes.size());
  out.commit();
}

}  // namespace dbacov::io
