// The C++ entry of the Python `Snapshot(...)` constructor: the arrays as the binding receives them
// (NumPy dtype, shape, C-contiguous data in native byte order) into a validated Snapshot, with the
// same messages as the `.npz` loader. No Python object is involved: the binding takes these views
// with the GIL held and calls snapshotFromArrays without it (threads may build snapshots at
// once); the fuzz target (tests/fuzz/fuzz_python_snapshot.cpp) feeds it views decoded from bytes.
//
// What is refused, naming the key (InputError): masked arrays (their mask would be ignored),
// complex dtypes (the imaginary part would be dropped), booleans, objects, strings and any other
// non-numeric dtype, and `ii`/`jj` values that are not integers (a float 1.7 would become keyframe
// 1). Integral floats (2.0) are accepted as indices: DROID and NumPy code often carry indices as
// floats, and their value is exact. Then the shapes, and Snapshot::validate().
#pragma once

#include <cstdint>
#include <optional>
#include <string>
#include <vector>

#include "dbacov/core/snapshot.h"

namespace dbacov::python {

/// One array argument: NumPy's dtype kind ('f', 'i', 'u', 'b', 'c', 'O', ...) and item size, its
/// shape and its C-contiguous data, which must hold the product of `shape` items.
struct ArrayView {
  char kind = 'f';
  int itemsize = 8;
  std::string dtype;  ///< NumPy's name of the dtype, for messages (derived when empty)
  std::vector<std::int64_t> shape;
  const void* data = nullptr;
  bool masked = false;  ///< a numpy.ma.MaskedArray: refused

  /// The number of items (the product of `shape`).
  std::int64_t size() const;
};

/// The arguments of Snapshot(...) (conventions §1).
struct SnapshotArrays {
  ArrayView poses, disps, intrinsics, ii, jj, target, weight, tstamp;
  std::optional<ArrayView> timestamps_s, disps_sens, stereo_rig;
  std::optional<std::int64_t> id, t0;
  std::string source = "<python>";
};

/// Builds and validates the snapshot; InputError naming the key and what was expected.
Snapshot snapshotFromArrays(const SnapshotArrays& arrays);

/// A path argument as the operating system will see it: InputError when it holds a NUL byte
/// (the system would cut it there and use another file), naming the argument.
void checkPath(const std::string& path, const char* argument);

}  // namespace dbacov::python
