// DBA snapshots as `.npz` files (conventions §1): loading with full shape checks, saving, listing.
//
// loadSnapshotNpz accepts:
//   poses        (N,7)       float32/float64   T_cw as [tx ty tz qx qy qz qw]
//   disps        (N,H,W)     float32/float64
//   intrinsics   (4,)        float32/float64   fx fy cx cy
//   ii, jj       (E,)        int32/int64       the same E for both
//   target       (E,2,H,W)   float32/float64   H, W as in 'disps'
//   weight       (E,2,H,W)   float32/float64
//   tstamp       (N,)        float32/float64
//   timestamps_s (N,)        float32/float64   optional
//   id           () or (1,)  int32/int64       optional
// Other keys are ignored. Missing required keys, wrong dtypes and every shape mismatch throw
// dbacov::InputError naming the file, the key, the shape found and the shape expected, e.g.
//   "droid.npz: key 'target' has shape (58,2,49,60), expected (58,2,49,61) (E,2,H,W from 'ii' and
//    'disps')".
// Afterwards Snapshot::validate() checks the values (index ranges, finiteness, weights >= 0, ...)
// and throws InputError naming the file. float64 per-pixel arrays are narrowed to float32.
#pragma once

#include <cstdint>
#include <optional>
#include <string>
#include <vector>

#include "dbacov/core/snapshot.h"

namespace dbacov::io {

/// Loads and validates the snapshot in `path`; sets `source` = path and `index` = index.
Snapshot loadSnapshotNpz(const std::string& path, std::int64_t index);

/// The `id` key of the snapshot in `path` alone (a few bytes of the archive), without reading or
/// checking the other keys; nullopt when the archive has no `id`. InputError when the archive
/// cannot be read or its `id` is not one integer.
std::optional<std::int64_t> readSnapshotId(const std::string& path);
/// The same for the bytes of a `.npz` file held in memory; `name` stands for the path (in
/// messages and as `source`).
Snapshot loadSnapshotNpzFromMemory(const std::string& name, std::vector<unsigned char> bytes,
                                   std::int64_t index);

/// Writes `snapshot` to `path` atomically with the keys of conventions §1: poses float64 (N,7);
/// disps, intrinsics, target, weight float32; ii, jj int64 (E,); tstamp and (if present)
/// timestamps_s float64 (N,); id (if present) int64 scalar (). Deflated when `compressed`
/// (np.savez_compressed), else stored (np.savez). Note that the double-precision intrinsics are
/// stored as float32. Calls snapshot.validate() first, so an invalid snapshot is never written
/// (InputError); write failures throw InputError naming the path and leave any previous file
/// untouched.
void saveSnapshotNpz(const std::string& path, const Snapshot& snapshot, bool compressed = true);

/// Paths ("<dir>/<name>") of the regular files (or links to them) in `dir` whose name ends in
/// ".npz", sorted by name (byte order: number files with zero padding, as "window_0055.npz").
/// Throws InputError naming `dir` if it does not exist, is not a directory or cannot be read.
std::vector<std::string> listNpzFiles(const std::string& dir);

}  // namespace dbacov::io
