// Small synthetic DBA snapshots with ground truth: the README demo and the test fixtures.
//
// A pinhole camera (looking along its +z, x right, y down) moves through a box-shaped room; the
// inverse depth of every pixel is found by ray casting against the room's six walls. Edges link
// keyframes at most `edge_radius` apart, in both directions, like DROID's proximity edges.
// Targets are the true projections plus Gaussian noise whose variance is 1/(weight_scale·w) per
// axis, so that a covariance computed with the same weight_scale is consistent by construction.
#pragma once

#include <cstdint>
#include <vector>

#include <Eigen/Geometry>

#include "dbacov/core/snapshot.h"

namespace dbacov::sim {

struct RoomScene {
  Eigen::Vector3d min_corner{-3.0, -1.5, -2.0};  ///< world frame, metres
  Eigen::Vector3d max_corner{6.0, 1.5, 5.0};
  /// Inverse depth along the optical axis of the pixel ray from T_wc (ray = R [xn, yn, 1]), or 0
  /// when the ray leaves the room (never for a camera inside it).
  double inverseDepth(const Eigen::Isometry3d& T_wc, double xn, double yn) const;
};

struct SyntheticSnapshotConfig {
  int num_keyframes = 8;
  int H = 24, W = 32;
  double fx = 28.0, fy = 28.0, cx = 15.5, cy = 11.5;
  double frame_interval = 3.0;  ///< `tstamp` of keyframe k is k·frame_interval (image index)
  double step = 0.12;           ///< metres between consecutive keyframes (along world +x)
  double yaw_amplitude = 0.15;  ///< radians of the slow yaw oscillation
  int edge_radius = 2;          ///< link keyframes with |i − j| <= edge_radius (both directions)
  int first_keyframe = 0;       ///< keyframes before it exist in `poses` but take part in no edge
  double weight_min = 0.2, weight_max = 1.0;  ///< per-pixel, per-axis confidences ~ U[min, max]
  double zero_weight_fraction = 0.1;          ///< fraction of pixels whose confidences are 0
  double weight_scale = 4.0;    ///< information of a target = weight_scale · w (px⁻²)
  bool noise = true;            ///< add target noise N(0, 1/(weight_scale·w)); false = exact
  std::uint64_t seed = 1;
  std::int64_t id = 0;
};

struct SyntheticSnapshot {
  Snapshot snapshot;                        ///< state = ground truth; targets noisy
  std::vector<Eigen::Isometry3d> T_wc_true; ///< per keyframe
};

/// Camera-to-world pose of keyframe k of the default trajectory (x forward in steps, slow yaw).
Eigen::Isometry3d syntheticTrajectoryPose(const SyntheticSnapshotConfig& config, int k);

/// Generates a valid snapshot (Snapshot::validate passes). Deterministic for a given config.
SyntheticSnapshot generateSyntheticSnapshot(const SyntheticSnapshotConfig& config);

}  // namespace dbacov::sim
