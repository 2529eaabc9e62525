// Small synthetic snapshots shared by the app and MRPT tests.
#pragma once

#include <cstdint>
#include <string>

#include "dbacov/io/snapshot_npz.h"
#include "dbacov/sim/synthetic_snapshot.h"

namespace dbacov::testing {

/// 6 keyframes on the line trajectory, 8×10 grid, radius-2 edges, keyframe times at 20 Hz from
/// t = 1000 s.
inline sim::SyntheticSnapshot tinySnapshot(std::uint64_t seed, std::int64_t id, int keyframes = 6) {
  sim::SyntheticSnapshotConfig c;
  c.num_keyframes = keyframes;
  c.H = 8;
  c.W = 10;
  c.fx = c.fy = 9;
  c.cx = 4.5;
  c.cy = 3.5;
  c.seed = seed;
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
