// DPVO's patch-graph snapshots as `.npz` files (docs/reference/formats.md, "Patch-graph snapshots
// (DPVO)"): detection and loading with full shape checks.
//
// loadPatchGraphNpz accepts:
//   poses        (N,7)          float32/float64   T_cw as [tx ty tz qx qy qz qw]
//   patches      (N,M,3,P,P)    float32/float64   x, y, inverse depth; the centre (P/2, P/2) is
//   used intrinsics   (4,)           float32/float64   fx fy cx cy ii, jj, kk   (E,) int32/int64
//   target       (E,2)          float32/float64
//   weight       (E,2)          float32/float64
//   t0           () or (1,)     int32/int64
//   tstamp       (N,)           float32/float64
//   timestamps_s (N,)           float32/float64   optional
//   id           () or (1,)     int32/int64       optional
//   is_global    () or (1,)     uint8/bool/int    optional
// Other keys are ignored. As the dense reader (snapshot_npz.h): the members' declared sizes must
// fit the memory budget together; missing keys, wrong dtypes and shapes throw InputError naming
// the file, the key, the shape found and the one expected; PatchGraph::validate() then checks the
// values.
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include "dbacov/core/patch_graph.h"

namespace dbacov::io {

/// True when the archive in `path` holds the keys 'kk' and 'patches' (a patch graph, not a dense
/// DROID snapshot). InputError when it cannot be opened as a .npz archive.
bool isPatchGraphNpz(const std::string& path);

/// Loads and validates the patch graph in `path`; sets `source` = path and `index` = index.
PatchGraph loadPatchGraphNpz(const std::string& path, std::int64_t index);
/// The same for the bytes of a `.npz` file held in memory; `name` stands for the path.
PatchGraph loadPatchGraphNpzFromMemory(const std::string& name, std::vector<unsigned char> bytes,
                                       std::int64_t index);

}  // namespace dbacov::io
