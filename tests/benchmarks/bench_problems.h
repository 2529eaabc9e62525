// The problems the snapshot benchmarks share: the real DROID snapshot of ../shared/data (11
// keyframes, 58 edges, 49×61) and a simulated DROID-sized window.
#pragma once

#include <filesystem>
#include <string>

#include <benchmark/benchmark.h>

#include "dbacov/io/snapshot_npz.h"
#include "dbacov/sim/synthetic_snapshot.h"

namespace dbacov::bench {

inline const std::string kSharedSnapshot =
    std::string(DBACOV_SHARED_DATA_DIR) + "/droid_window_0055.npz";

/// True, with the benchmark marked as skipped, when the shared snapshot is missing.
inline bool skipWithoutSharedSnapshot(benchmark::State& state) {
  if (std::filesystem::exists(kSharedSnapshot)) return false;
  state.SkipWithError(("missing " + kSharedSnapshot).c_str());
  return true;
}

/// The shared snapshot, loaded once.
inline const Snapshot& sharedSnapshot() {
  static const Snapshot s = io::loadSnapshotNpz(kSharedSnapshot, 0);
  return s;
}

/// A DROID-sized window: 25 keyframes of 48×64 pixels (f = 0.87 W, ≈ 70° horizontal field of
/// view), edges to the 3 nearest keyframes each way.
inline sim::SyntheticSnapshotConfig droidSizedWindowConfig() {
  sim::SyntheticSnapshotConfig c;
  c.num_keyframes = 25;
  c.H = 48;
  c.W = 64;
  c.fx = c.fy = 0.87 * c.W;
  c.cx = 0.5 * (c.W - 1);
  c.cy = 0.5 * (c.H - 1);
  c.trajectory.num_keyframes = 25;
  c.covisibility.edge_radius = 3;
  return c;
}

}  // namespace dbacov::bench
