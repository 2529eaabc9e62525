// Small synthetic snapshots shared by the app and MRPT tests.
#pragma once

#include <cstdint>
#include <string>

#include "dbacov/io/snapshot_npz.h"
#include "dbacov/sim/synthetic_snapshot.h"

namespace dbacov::testing {

/// `keyframes` on the line trajectory over an H×W grid with f = W − 1 (≈ 53° horizontal field of
/// view) and the principal point at the centre: the small snapshots of the tests.
inline sim::SyntheticSnapshotConfig gridConfig(std::uint64_t seed, int keyframes, int H, int W) {
  sim::SyntheticSnapshotConfig c;
  c.num_keyframes = keyframes;
  c.H = H;
  c.W = W;
  c.fx = c.fy = W - 1;
  c.cx = 0.5 * (W - 1);
  c.cy = 0.5 * (H - 1);
  c.seed = seed;
  return c;
}

/// 6 keyframes on the line trajectory, 8×10 grid, radius-2 edges, keyframe times at 20 Hz from
/// t = 1000 s.
inline sim::SyntheticSnapshot tinySnapshot(std::uint64_t seed, std::int64_t id, int keyframes = 6) {
  sim::SyntheticSnapshotConfig c = gridConfig(seed, keyframes, 8, 10);
  c.id = id;
  auto syn = sim::generateSyntheticSnapshot(c);
  deriveKeyframeTimes(syn.snapshot, 20.0);
  for (double& t : *syn.snapshot.timestamps_s) t += 1000.0;
  return syn;
}

inline sim::SyntheticSnapshot writeTinySnapshot(const std::string& path, std::uint64_t seed,
                                                std::int64_t id, int keyframes = 6) {
  auto syn = tinySnapshot(seed, id, keyframes);
  io::saveSnapshotNpz(path, syn.snapshot);
  return syn;
}

}  // namespace dbacov::testing
