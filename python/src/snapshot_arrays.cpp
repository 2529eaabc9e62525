// Arrays of Python's Snapshot(...) into a Snapshot. See snapshot_arrays.h.
#include "snapshot_arrays.h"

#include <charconv>
#include <cmath>
#include <cstring>

#include "dbacov/core/errors.h"

namespace dbacov::python {
namespace {

std::string dtypeName(const ArrayView& a) {
  if (!a.dtype.empty()) return a.dtype;
  const std::string bits = std::to_string(8 * a.itemsize);
  switch (a.kind) {
    case 'f':
      return "float" + bits;
    case 'i':
      return "int" + bits;
    case 'u':
      return "uint" + bits;
    case 'c':
      return "complex" + bits;
    case 'b':
      return "bool";
    default:
      return std::string("kind '") + a.kind + "'";
  }
}

std::string shapeOf(const ArrayView& a) {
  std::string s = "(";
  for (std::size_t k = 0; k < a.shape.size(); ++k) s += (k ? "," : "") + std::to_string(a.shape[k]);
  return s + (a.shape.size() == 1 ? ",)" : ")");
}

/// The shortest text that reads back as v (2.7, not 2.7000000000000002).
std::string number(double v) {
  char buf[64];
  const auto r = std::to_chars(buf, buf + sizeof buf, v);
  return std::string(buf, r.ptr);
}

/// IEEE half precision (NumPy's float16) to float.
float halfToFloat(std::uint16_t h) {
  const int sign = h >> 15, exponent = (h >> 10) & 0x1f, mantissa = h & 0x3ff;
  float v;
  if (exponent == 0)
    v = std::ldexp(static_cast<float>(mantissa), -24);
  else if (exponent == 31)
    v = mantissa ? std::nanf("") : INFINITY;
  else
    v = std::ldexp(static_cast<float>(mantissa + 1024), exponent - 25);
  return sign ? -v : v;
}

template <typename T>
T load(const ArrayView& a, std::int64_t i) {
  T v;
  std::memcpy(&v, static_cast<const char*>(a.data) + i * a.itemsize, sizeof v);
  return v;
}

/// Item i of a numeric view as double (checked by checkNumeric first).
double itemAsDouble(const ArrayView& a, std::int64_t i) {
  switch (a.kind) {
    case 'f':
      if (a.itemsize == 2) return halfToFloat(load<std::uint16_t>(a, i));
      if (a.itemsize == 4) return load<float>(a, i);
      return load<double>(a, i);
    case 'i':
      if (a.itemsize == 1) return load<std::int8_t>(a, i);
      if (a.itemsize == 2) return load<std::int16_t>(a, i);
      if (a.itemsize == 4) return load<std::int32_t>(a, i);
      return static_cast<double>(load<std::int64_t>(a, i));
    default:  // 'u'
      if (a.itemsize == 1) return load<std::uint8_t>(a, i);
      if (a.itemsize == 2) return load<std::uint16_t>(a, i);
      if (a.itemsize == 4) return load<std::uint32_t>(a, i);
      return static_cast<double>(load<std::uint64_t>(a, i));
  }
}

/// Refuses what cannot be read as real numbers without losing something, naming the key.
void checkNumeric(const ArrayView& a, const char* key, const std::string& source) {
  const std::string k = source + ": key '" + key + "'";
  if (a.masked)
    throw InputError(k +
                     " is a NumPy masked array: its mask would be ignored; pass a plain array "
                     "(e.g. " +
                     key + ".filled(0), or a weight of 0 where the data are masked)");
  if (a.kind == 'c')
    throw InputError(k + " has the complex dtype " + dtypeName(a) +
                     ": its imaginary part would be dropped; expected real numbers");
  const bool sized = (a.kind == 'f' && (a.itemsize == 2 || a.itemsize == 4 || a.itemsize == 8)) ||
                     ((a.kind == 'i' || a.kind == 'u') &&
                      (a.itemsize == 1 || a.itemsize == 2 || a.itemsize == 4 || a.itemsize == 8));
  if (!sized)
    throw InputError(k + " has the dtype " + dtypeName(a) +
                     ", expected real numbers (a float or integer dtype)");
  for (std::int64_t d : a.shape)
    if (d < 0) throw InputError(k + " has the shape " + shapeOf(a) + ", expected sizes >= 0");
  if (a.size() > 0 && !a.data) throw std::invalid_argument(k + ": no data");
}

template <typename T>
std::vector<T> values(const ArrayView& a, const char* key, const std::string& source) {
  checkNumeric(a, key, source);
  const std::int64_t n = a.size();
  std::vector<T> v(static_cast<std::size_t>(n));
  if constexpr (std::is_same_v<T, double>) {
    if (a.kind == 'f' && a.itemsize == 8) {
      if (n) std::memcpy(v.data(), a.data, static_cast<std::size_t>(n) * sizeof(double));
      return v;
    }
  }
  if constexpr (std::is_same_v<T, float>) {
    if (a.kind == 'f' && a.itemsize == 4) {
      if (n) std::memcpy(v.data(), a.data, static_cast<std::size_t>(n) * sizeof(float));
      return v;
    }
  }
  // float64 beyond float32's range becomes ±inf here, which validate() refuses by position.
  for (std::int64_t i = 0; i < n; ++i) v[i] = static_cast<T>(itemAsDouble(a, i));
  return v;
}

/// Keyframe indices: integers, or floats of integral value (2.0); anything else is refused.
std::vector<std::int64_t> indices(const ArrayView& a, const char* key, const std::string& source) {
  checkNumeric(a, key, source);
  const std::int64_t n = a.size();
  std::vector<std::int64_t> v(static_cast<std::size_t>(n));
  const std::string k = source + ": key '" + key + "'";
  for (std::int64_t e = 0; e < n; ++e) {
    if (a.kind == 'i' && a.itemsize == 8) {
      v[e] = load<std::int64_t>(a, e);
    } else if (a.kind == 'u' && a.itemsize == 8) {
      const std::uint64_t u = load<std::uint64_t>(a, e);
      if (u > static_cast<std::uint64_t>(INT64_MAX))
        throw InputError(k + " edge " + std::to_string(e) + " names keyframe " + std::to_string(u) +
                         ", beyond any keyframe index");
      v[e] = static_cast<std::int64_t>(u);
    } else if (a.kind == 'f') {
      const double d = itemAsDouble(a, e);
      if (!std::isfinite(d) || d != std::floor(d))
        throw InputError(k + " edge " + std::to_string(e) + " is " + number(d) + " (dtype " +
                         dtypeName(a) +
                         "), not a keyframe index: expected integers (integral floats such as "
                         "2.0 are accepted; a fraction is never rounded)");
      if (!(std::fabs(d) < 9.2e18))
        throw InputError(k + " edge " + std::to_string(e) + " names keyframe " + number(d) +
                         ", beyond any keyframe index");
      v[e] = static_cast<std::int64_t>(d);
    } else {
      v[e] = static_cast<std::int64_t>(itemAsDouble(a, e));  // integers of <= 32 bits: exact
    }
  }
  return v;
}

void expectNdim(const ArrayView& a, std::size_t ndim, const char* key, const char* expected,
                const std::string& source) {
  if (a.shape.size() != ndim)
    throw InputError(source + ": key '" + key + "' has shape " + shapeOf(a) + ", expected " +
                     expected);
}

}  // namespace

std::int64_t ArrayView::size() const {
  std::int64_t n = 1;
  for (std::int64_t d : shape) n *= d;
  return n;
}

void checkPath(const std::string& path, const char* argument) {
  const std::size_t nul = path.find('\0');
  if (nul == std::string::npos) return;
  throw InputError(std::string(argument) + ": the path holds a NUL byte at byte " +
                   std::to_string(nul) + " (after '" + path.substr(0, nul) +
                   "'): the system would cut the path there and use another file; a path "
                   "cannot hold NUL");
}

Snapshot snapshotFromArrays(const SnapshotArrays& a) {
  const std::string& source = a.source;
  // Every array's dtype first (a complex or masked array is refused whatever its shape).
  for (const auto& [key, v] : {std::pair<const char*, const ArrayView*>{"poses", &a.poses},
                               {"disps", &a.disps},
                               {"intrinsics", &a.intrinsics},
                               {"ii", &a.ii},
                               {"jj", &a.jj},
                               {"target", &a.target},
                               {"weight", &a.weight},
                               {"tstamp", &a.tstamp},
                               {"timestamps_s", a.timestamps_s ? &*a.timestamps_s : nullptr},
                               {"disps_sens", a.disps_sens ? &*a.disps_sens : nullptr},
                               {"stereo_rig", a.stereo_rig ? &*a.stereo_rig : nullptr}})
    if (v) checkNumeric(*v, key, source);
  expectNdim(a.poses, 2, "poses", "(N,7)", source);
  expectNdim(a.disps, 3, "disps", "(N,H,W)", source);
  if (a.poses.shape[1] != 7)
    throw InputError(source + ": key 'poses' has shape " + shapeOf(a.poses) + ", expected (N,7)");
  if (a.intrinsics.size() != 4)
    throw InputError(source + ": key 'intrinsics' has shape " + shapeOf(a.intrinsics) +
                     ", expected (4,)");
  if (a.stereo_rig && a.stereo_rig->size() != 7)
    throw InputError(source + ": key 'stereo_rig' has shape " + shapeOf(*a.stereo_rig) +
                     ", expected (7,)");
  if (a.disps.shape[1] > INT32_MAX || a.disps.shape[2] > INT32_MAX)
    throw InputError(source + ": key 'disps' has shape " + shapeOf(a.disps) +
                     ", expected an H×W grid of fewer than 2^31 rows and columns");
  Snapshot s;
  s.source = source;
  s.id = a.id;
  s.H = static_cast<int>(a.disps.shape[1]);
  s.W = static_cast<int>(a.disps.shape[2]);
  s.ii = indices(a.ii, "ii", source);
  s.jj = indices(a.jj, "jj", source);
  // The plane shapes, with the key's name (validate() checks the flat sizes).
  const auto E = static_cast<std::int64_t>(s.ii.size());
  for (const auto& [key, v] :
       {std::pair<const char*, const ArrayView*>{"target", &a.target}, {"weight", &a.weight}})
    if (v->shape.size() != 4 || v->shape[0] != E || v->shape[1] != 2 || v->shape[2] != s.H ||
        v->shape[3] != s.W)
      throw InputError(source + ": key '" + key + "' has shape " + shapeOf(*v) + ", expected (" +
                       std::to_string(E) + ",2," + std::to_string(s.H) + "," + std::to_string(s.W) +
                       ") (E,2,H,W)");
  const std::vector<double> poses = values<double>(a.poses, "poses", source);
  s.poses_cw.resize(a.poses.shape[0], 7);
  std::copy(poses.begin(), poses.end(), s.poses_cw.data());
  s.disps = values<float>(a.disps, "disps", source);
  const std::vector<double> intrinsics = values<double>(a.intrinsics, "intrinsics", source);
  s.intrinsics = Eigen::Map<const Eigen::Vector4d>(intrinsics.data());
  s.target = values<float>(a.target, "target", source);
  s.weight = values<float>(a.weight, "weight", source);
  s.tstamp = values<double>(a.tstamp, "tstamp", source);
  if (a.timestamps_s) s.timestamps_s = values<double>(*a.timestamps_s, "timestamps_s", source);
  if (a.disps_sens) s.disps_sens = values<float>(*a.disps_sens, "disps_sens", source);
  if (a.stereo_rig) {
    const std::vector<double> rig = values<double>(*a.stereo_rig, "stereo_rig", source);
    s.stereo_rig = Eigen::Map<const Eigen::Matrix<double, 7, 1>>(rig.data());
  }
  s.t0 = a.t0;
  s.validate();
  return s;
}

}  // namespace dbacov::python
