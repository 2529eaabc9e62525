// Small synthetic DBA snapshots with ground truth: the demo and the test fixtures.
//
// A pinhole camera (looking along its +z, x right, y down) moves through a box-shaped room along
// one of the trajectories of trajectory.h; the inverse depth of every pixel is found by ray casting
// against the room's six walls. Edges link temporal neighbours and, optionally, keyframes whose
// views overlap, in both directions, like DROID's proximity edges (covisibility.h).
// Targets are the true projections plus Gaussian noise whose variance is 1/(weight_scale·w) per
// axis, so that a covariance computed with the same weight_scale is consistent by construction.
#pragma once

#include <cstdint>
#include <vector>

#include <Eigen/Geometry>

#include "dbacov/core/snapshot.h"
#include "dbacov/sim/covisibility.h"
#include "dbacov/sim/scene.h"
#include "dbacov/sim/trajectory.h"

namespace dbacov::sim {

struct SyntheticSnapshotConfig {
  int num_keyframes = 8;
  int H = 24, W = 32;
  double fx = 28.0, fy = 28.0, cx = 15.5, cy = 11.5;
  double frame_interval = 3.0;  ///< `tstamp` of keyframe k is k·frame_interval (image index)
  TrajectoryConfig trajectory;  ///< its num_keyframes is the whole trajectory's (for turnarounds)
  CovisibilityConfig covisibility;
  int first_keyframe = 0;  ///< keyframes before it exist in `poses` but take part in no edge
  double weight_min = 0.2, weight_max = 1.0;  ///< per-pixel, per-axis confidences ~ U[min, max]
  double zero_weight_fraction = 0.1;          ///< fraction of pixels whose confidences are 0
  double weight_scale = 4.0;  ///< information of a target = weight_scale · w (px⁻²)
  bool noise = true;          ///< add target noise N(0, 1/(weight_scale·w)); false = exact
  std::uint64_t seed = 1;
  std::int64_t id = 0;
};

struct SyntheticSnapshot {
  Snapshot snapshot;                         ///< state = ground truth; targets noisy
  std::vector<Eigen::Isometry3d> T_wc_true;  ///< per keyframe
};

/// Generates a valid snapshot (Snapshot::validate passes). Deterministic for a given config.
SyntheticSnapshot generateSyntheticSnapshot(const SyntheticSnapshotConfig& config);

}  // namespace dbacov::sim
