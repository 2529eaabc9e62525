// .npy preamble and header dict: parsing (strict, size-safe) and NumPy-identical serialization.
#include <cstring>
#include <limits>
#include <string>
#include <string_view>
#include <utility>

#include "dbacov/io/npy.h"
#include "npy_internal.h"

namespace dbacov::io {
namespace {

constexpr unsigned char kMagic[6] = {0x93, 'N', 'U', 'M', 'P', 'Y'};
constexpr std::size_t kArrayAlign = 64;           // NumPy's ARRAY_ALIGN
constexpr std::size_t kGrowthAxisMaxDigits = 21;  // NumPy's GROWTH_AXIS_MAX_DIGITS

/// Recursive-descent parser for the Python dict literal of an .npy header.
class HeaderDictParser {
 public:
  HeaderDictParser(std::string_view text, const std::string& context)
      : text_(text), context_(context) {}

  NpyHeader parse() {
    bool have_descr = false, have_fortran = false, have_shape = false, fortran = false;
    std::string descr;
    NpyHeader h;
    skipSpace();
    expect('{');
    for (;;) {
      skipSpace();
      if (consume('}')) break;
      const std::string key = parseString();
      skipSpace();
      expect(':');
      skipSpace();
      if (key == "descr") {
        if (have_descr) fail("duplicate key 'descr'");
        if (peek() == '[' || peek() == '{') failPlain("structured dtypes are not supported");
        descr = parseString();
        have_descr = true;
      } else if (key == "fortran_order") {
        if (have_fortran) fail("duplicate key 'fortran_order'");
        fortran = parseBool();
        have_fortran = true;
      } else if (key == "shape") {
        if (have_shape) fail("duplicate key 'shape'");
        h.shape = parseShape();
        have_shape = true;
      } else {
        fail("unexpected key '" + key + "'");
      }
      skipSpace();
      if (consume(',')) continue;
      if (consume('}')) break;
      fail("expected ',' or '}'");
    }
    skipSpace();
    if (pos_ != text_.size()) fail("unexpected text after the closing '}'");
    if (!have_descr || !have_fortran || !have_shape)
      failPlain("the .npy header must contain the keys 'descr', 'fortran_order' and 'shape'");
    h.dtype = dtypeFromDescr(descr, context_);
    if (fortran)
      failPlain(
          "Fortran-order arrays are not supported (save a C-contiguous array, e.g. "
          "np.ascontiguousarray)");
    return h;
  }

 private:
  [[noreturn]] void failPlain(const std::string& what) const {
    throw InputError(context_ + ": " + what);
  }
  [[noreturn]] void fail(const std::string& what) const {
    std::string shown;
    for (char c : text_.substr(0, 120)) shown += (c >= 32 && c < 127) ? c : '?';
    throw InputError(context_ + ": malformed .npy header at character " + std::to_string(pos_) +
                     ": " + what + " (header: \"" + shown + "\")");
  }
  char peek() const { return pos_ < text_.size() ? text_[pos_] : '\0'; }
  bool consume(char c) {
    if (peek() != c || pos_ >= text_.size()) return false;
    ++pos_;
    return true;
  }
  void expect(char c) {
    if (!consume(c)) fail(std::string("expected '") + c + "'");
  }
  void skipSpace() {
    while (pos_ < text_.size() && std::strchr(" \t\r\n", text_[pos_]) != nullptr) ++pos_;
  }

  std::string parseString() {
    const char quote = peek();
    if (quote != '\'' && quote != '"') fail("expected a quoted string");
    ++pos_;
    const std::size_t end = text_.find(quote, pos_);
    if (end == std::string_view::npos) fail("unterminated string");
    std::string s(text_.substr(pos_, end - pos_));
    if (s.find('\\') != std::string::npos) fail("escape sequences are not supported");
    pos_ = end + 1;
    return s;
  }

  bool parseBool() {
    if (text_.substr(pos_, 4) == "True") return pos_ += 4, true;
    if (text_.substr(pos_, 5) == "False") return pos_ += 5, false;
    fail("expected True or False");
  }

  std::size_t parseDim() {
    if (peek() == '-') failPlain("the .npy header declares a negative dimension");
    if (peek() < '0' || peek() > '9') fail("expected a non-negative integer");
    std::size_t v = 0;
    while (peek() >= '0' && peek() <= '9') {
      const std::size_t digit = static_cast<std::size_t>(peek() - '0');
      if (v > (std::numeric_limits<std::size_t>::max() - digit) / 10)
        failPlain("the .npy header declares a dimension that overflows 64 bits");
      v = v * 10 + digit;
      ++pos_;
    }
    if (peek() == 'L' || peek() == 'l') ++pos_;  // Python 2 long literal
    return v;
  }

  std::vector<std::size_t> parseShape() {
    std::vector<std::size_t> shape;
    expect('(');
    for (;;) {
      skipSpace();
      if (consume(')')) break;
      if (shape.size() == kMaxNpyDims)
        failPlain("the .npy header declares more than " + std::to_string(kMaxNpyDims) +
                  " dimensions");
      shape.push_back(parseDim());
      skipSpace();
      if (consume(',')) continue;
      expect(')');
      break;
    }
    return shape;
  }

  std::string_view text_;
  const std::string& context_;
  std::size_t pos_ = 0;
};

std::string pythonTupleRepr(const std::vector<std::size_t>& shape) {
  std::string s = "(";
  for (std::size_t i = 0; i < shape.size(); ++i) s += (i ? ", " : "") + std::to_string(shape[i]);
  return s + (shape.size() == 1 ? ",)" : ")");
}

}  // namespace

NpyArray::DType dtypeFromDescr(const std::string& descr, const std::string& context) {
  using T = NpyArray::DType;  // (npy.cpp's file-level DType would be shadowed in a unity batch)
  static const std::pair<const char*, T> kCodes[] = {{"f4", T::Float32}, {"f8", T::Float64},
                                                     {"i4", T::Int32},   {"i8", T::Int64},
                                                     {"u1", T::UInt8},   {"b1", T::Bool}};
  const char order = descr.empty() ? '\0' : descr[0];
  const std::string code = descr.empty() ? "" : descr.substr(1);
  const std::string quoted = "dtype '" + descr + "'";
  if (!code.empty() && code[0] == 'O')
    throw InputError(context + ": object arrays (" + quoted + ") are not supported");
  if (order == '>')
    throw InputError(context + ": big-endian " + quoted + " is not supported (little-endian only)");
  if (!code.empty() && code[0] == 'V')
    throw InputError(context + ": structured/void " + quoted + " is not supported");
  for (const auto& [c, type] : kCodes) {
    if (code != c) continue;
    if (order == '<' || (order == '|' && itemSize(type) == 1)) return type;
    throw InputError(context + ": unsupported byte order in " + quoted +
                     " (expected '<', or '|' for 1-byte types)");
  }
  throw InputError(context + ": unsupported " + quoted +
                   " (supported: float32, float64, int32, int64, uint8, bool)");
}

std::size_t npyPreambleSize(const unsigned char* bytes, std::size_t size,
                            const std::string& context) {
  if (size < 8 || std::memcmp(bytes, kMagic, sizeof(kMagic)) != 0)
    throw InputError(context + ": not a .npy array (missing the \\x93NUMPY magic)");
  const int major = bytes[6], minor = bytes[7];
  if (minor == 0 && major == 1) return 10;
  if (minor == 0 && (major == 2 || major == 3)) return 12;
  throw InputError(context + ": unsupported .npy format version " + std::to_string(major) + "." +
                   std::to_string(minor) + " (supported: 1.0, 2.0, 3.0)");
}

std::size_t npyHeaderSize(const unsigned char* bytes, std::size_t size,
                          const std::string& context) {
  const std::size_t pre = npyPreambleSize(bytes, size, context);
  if (size < pre) throw InputError(context + ": truncated .npy preamble");
  const std::size_t len = pre == 10 ? loadLE<std::uint16_t>(bytes + 8)
                                    : static_cast<std::size_t>(loadLE<std::uint32_t>(bytes + 8));
  if (len > kMaxNpyHeaderBytes)
    throw InputError(context + ": .npy header of " + std::to_string(len) +
                     " bytes is longer than the accepted " + std::to_string(kMaxNpyHeaderBytes));
  return pre + len;
}

NpyHeader parseNpyHeader(const unsigned char* bytes, std::size_t size, const std::string& context) {
  const std::size_t total = npyHeaderSize(bytes, size, context);
  if (size < total)
    throw InputError(context + ": truncated .npy header (" + std::to_string(size) +
                     " bytes, the header needs " + std::to_string(total) + ")");
  const std::size_t pre = npyPreambleSize(bytes, size, context);
  const std::string_view text(reinterpret_cast<const char*>(bytes) + pre, total - pre);
  NpyHeader h = HeaderDictParser(text, context).parse();
  h.data_offset = total;
  std::size_t n = 0;
  if (!checkedNumElements(h.shape, &n) ||
      n > std::numeric_limits<std::size_t>::max() / itemSize(h.dtype))
    throw InputError(context + ": declared shape " + shapeToString(h.shape) + " of " +
                     dtypeName(h.dtype) + " overflows the addressable size");
  h.data_bytes = n * itemSize(h.dtype);
  return h;
}

std::string npyHeaderText(const NpyArray& array) {
  std::string dict = std::string("{'descr': '") + dtypeDescr(array.dtype) +
                     "', 'fortran_order': False, 'shape': " + pythonTupleRepr(array.shape) + ", }";
  if (!array.shape.empty()) {
    const std::size_t digits = std::to_string(array.shape[0]).size();
    if (digits < kGrowthAxisMaxDigits) dict.append(kGrowthAxisMaxDigits - digits, ' ');
  }
  const std::size_t hlen = dict.size() + 1;  // + the final '\n'
  const std::size_t pad = kArrayAlign - (10 + hlen) % kArrayAlign;
  return dict + std::string(pad, ' ') + '\n';
}

}  // namespace dbacov::io
