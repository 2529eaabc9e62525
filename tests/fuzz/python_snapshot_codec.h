// The byte layout of the fuzz target fuzz_python_snapshot: the array arguments of Python's
// Snapshot(...) — dtype, shape, data — as the binding hands them to the C++ entry
// (python/src/snapshot_arrays.h), so that the fuzzer varies dtypes, shapes and values together.
//
//   byte 0        which optional arguments follow: bit 0 timestamps_s, 1 disps_sens, 2 stereo_rig,
//                 3 id, 4 t0
//   byte 1        the index of the array passed as a masked array (>= 11: none)
//   [8 bytes id] [8 bytes t0]   little-endian int64, when present
//   per array, in the order poses disps intrinsics ii jj target weight tstamp [timestamps_s]
//   [disps_sens] [stereo_rig]: 1 byte dtype code (kDtypes, modulo), 1 byte ndim (modulo 6),
//   ndim little-endian uint16 sizes, then the items (native byte order); missing bytes are zeros.
#pragma once

#include <cstdint>
#include <cstring>
#include <optional>
#include <string>
#include <vector>

#include "../../python/src/snapshot_arrays.h"
#include "dbacov/core/snapshot.h"

namespace dbacov::fuzz {

struct Dtype {
  char kind;
  int itemsize;
};
inline constexpr Dtype kDtypes[] = {{'f', 8}, {'f', 4}, {'f', 2},  {'i', 8}, {'i', 4},
                                    {'i', 2}, {'i', 1}, {'u', 8},  {'u', 4}, {'u', 1},
                                    {'b', 1}, {'c', 8}, {'c', 16}, {'O', 8}};
inline constexpr int kNumDtypes = sizeof(kDtypes) / sizeof(kDtypes[0]);
inline constexpr int kNumArrays = 11;

/// Decoded arguments; the views point into `storage`.
struct DecodedArrays {
  python::SnapshotArrays arrays;
  std::vector<std::vector<unsigned char>> storage;
};

/// The arguments in `bytes`, or nothing when they declare more than `max_items` items in all.
inline std::optional<DecodedArrays> decodeSnapshotArrays(const std::uint8_t* data, std::size_t size,
                                                         std::int64_t max_items = 1 << 20) {
  std::size_t pos = 0;
  auto byte = [&]() -> std::uint8_t { return pos < size ? data[pos++] : 0; };
  auto take = [&](void* out, std::size_t n) {
    std::memset(out, 0, n);
    const std::size_t k = pos < size ? std::min(n, size - pos) : 0;
    if (k) std::memcpy(out, data + pos, k);
    pos += k;
  };
  DecodedArrays d;
  d.storage.reserve(kNumArrays);
  const std::uint8_t flags = byte();
  const std::uint8_t masked = byte();
  if (flags & 8) {
    std::int64_t v;
    take(&v, 8);
    d.arrays.id = v;
  }
  if (flags & 16) {
    std::int64_t v;
    take(&v, 8);
    d.arrays.t0 = v;
  }
  std::int64_t items = 0;
  auto next = [&](int index) -> std::optional<python::ArrayView> {
    python::ArrayView v;
    const Dtype t = kDtypes[byte() % kNumDtypes];
    v.kind = t.kind;
    v.itemsize = t.itemsize;
    const int ndim = byte() % 6;
    std::int64_t n = 1;
    for (int k = 0; k < ndim; ++k) {
      std::uint16_t dim;
      take(&dim, 2);
      v.shape.push_back(dim);
      n *= dim;
      if (n > max_items) return std::nullopt;
    }
    items += n;
    if (items > max_items) return std::nullopt;
    d.storage.emplace_back(static_cast<std::size_t>(n * v.itemsize));
    if (n) take(d.storage.back().data(), d.storage.back().size());
    v.data = d.storage.back().data();
    v.masked = index == masked;
    return v;
  };
  python::SnapshotArrays& a = d.arrays;
  python::ArrayView* required[] = {&a.poses, &a.disps,  &a.intrinsics, &a.ii,
                                   &a.jj,    &a.target, &a.weight,     &a.tstamp};
  int index = 0;
  for (python::ArrayView* r : required) {
    auto v = next(index++);
    if (!v) return std::nullopt;
    *r = std::move(*v);
  }
  std::optional<python::ArrayView>* optional[] = {&a.timestamps_s, &a.disps_sens, &a.stereo_rig};
  for (int k = 0; k < 3; ++k, ++index)
    if (flags & (1 << k)) {
      auto v = next(index);
      if (!v) return std::nullopt;
      *optional[k] = std::move(*v);
    }
  return d;
}

/// The encoding of a snapshot's arrays in the dtypes NumPy code usually has (float64 poses,
/// float32 planes, int64 indices), `ii_code` choosing the indices' dtype (kDtypes).
inline std::vector<unsigned char> encodeSnapshotArrays(const Snapshot& s, int ii_code = 3) {
  std::vector<unsigned char> out;
  auto raw = [&](const void* p, std::size_t n) {
    out.insert(out.end(), static_cast<const unsigned char*>(p),
               static_cast<const unsigned char*>(p) + n);
  };
  out.push_back(static_cast<unsigned char>((s.timestamps_s ? 1 : 0) | (s.disps_sens ? 2 : 0) |
                                           (s.stereo_rig ? 4 : 0) | (s.id ? 8 : 0) |
                                           (s.t0 ? 16 : 0)));
  out.push_back(255);
  if (s.id) raw(&*s.id, 8);
  if (s.t0) raw(&*s.t0, 8);
  auto header = [&](int code, std::vector<std::uint16_t> shape) {
    out.push_back(static_cast<unsigned char>(code));
    out.push_back(static_cast<unsigned char>(shape.size()));
    for (std::uint16_t d : shape) raw(&d, 2);
  };
  const auto N = static_cast<std::uint16_t>(s.numKeyframes());
  const auto E = static_cast<std::uint16_t>(s.numEdges());
  const auto H = static_cast<std::uint16_t>(s.H), W = static_cast<std::uint16_t>(s.W);
  header(0, {N, 7});
  raw(s.poses_cw.data(), sizeof(double) * s.poses_cw.size());
  header(1, {N, H, W});
  raw(s.disps.data(), sizeof(float) * s.disps.size());
  header(0, {4});
  raw(s.intrinsics.data(), sizeof(double) * 4);
  for (const auto* idx : {&s.ii, &s.jj}) {
    header(ii_code, {E});
    for (std::int64_t v : *idx) {
      const Dtype t = kDtypes[ii_code];
      if (t.kind == 'f' && t.itemsize == 8) {
        const double d = static_cast<double>(v);
        raw(&d, 8);
      } else if (t.kind == 'i' && t.itemsize == 4) {
        const auto i = static_cast<std::int32_t>(v);
        raw(&i, 4);
      } else {
        raw(&v, 8);
      }
    }
  }
  header(1, {E, 2, H, W});
  raw(s.target.data(), sizeof(float) * s.target.size());
  header(1, {E, 2, H, W});
  raw(s.weight.data(), sizeof(float) * s.weight.size());
  header(0, {N});
  raw(s.tstamp.data(), sizeof(double) * s.tstamp.size());
  if (s.timestamps_s) {
    header(0, {N});
    raw(s.timestamps_s->data(), sizeof(double) * N);
  }
  if (s.disps_sens) {
    header(1, {N, H, W});
    raw(s.disps_sens->data(), sizeof(float) * s.disps_sens->size());
  }
  if (s.stereo_rig) {
    header(0, {7});
    raw(s.stereo_rig->data(), sizeof(double) * 7);
  }
  return out;
}

}  // namespace dbacov::fuzz
