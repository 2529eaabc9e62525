// Small synthetic snapshots and options shared by the test suites.
#pragma once

#include <cstdint>
#include <random>
#include <string>

#include "dbacov/core/options.h"
#include "dbacov/core/se3.h"
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

/// The tests' engine options: weight scale 4 and the given gauge.
inline DbaOptions gaugeOptions(GaugeOptions::Type type, double sigma_rot, double sigma_trans) {
  DbaOptions o;
  o.weight_scale = 4.0;
  o.gauge.type = type;
  o.gauge.sigma_rot = sigma_rot;
  o.gauge.sigma_trans = sigma_trans;
  return o;
}

/// A tangent vector [rho; phi] with independent N(0, scale^2) entries.
inline Vector6d randomTangent(std::mt19937& rng, double scale) {
  std::normal_distribution<double> n(0.0, scale);
  Vector6d xi;
  for (int i = 0; i < 6; ++i) xi[i] = n(rng);
  return xi;
}

}  // namespace dbacov::testing
