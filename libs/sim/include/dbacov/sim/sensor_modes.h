// Stereo and RGB-D versions of a synthetic snapshot (the DROID-SLAM modes beyond monocular).
//
// Stereo: every source keyframe of the graph gets an edge ii == jj to the second camera of a rig
// with the fixed transform T_rig (DROID: a translation (−0.1, 0, 0)); its targets are the true
// projections through T_rig plus N(0, 1/(weight_scale·w)) per axis, as for the other edges.
// RGB-D: every source keyframe gets a sensor inverse depth d_sens = d_true + N(0, 1/α) on a
// fraction of its pixels (0 elsewhere: no reading), α the engine's sensor_depth_weight. Both
// factors carry metric information, so the scale of the snapshot is that of the rig / sensor.
// The snapshot's state must be the truth (as generateSyntheticSnapshot leaves it).
#pragma once

#include <cstdint>

#include <Eigen/Geometry>

#include "dbacov/core/snapshot.h"

namespace dbacov::sim {

struct StereoConfig {
  Eigen::Isometry3d T_rig = Eigen::Translation3d(-0.1, 0.0, 0.0) * Eigen::Isometry3d::Identity();
  double weight_min = 0.2, weight_max = 1.0;  ///< confidences ~ U[min, max] per pixel and axis
  double weight_scale = 4.0;                  ///< information of a target = weight_scale · w
  bool noise = true;
  std::uint64_t seed = 1;
};

struct RgbdConfig {
  double alpha = 400.0;         ///< information of a reading, (inverse depth)^-2
  double valid_fraction = 0.8;  ///< pixels with a reading
  bool noise = true;
  std::uint64_t seed = 1;
};

/// Adds one ii == jj edge per source keyframe of `s` and sets stereo_rig. Deterministic.
void addStereoEdges(Snapshot& s, const StereoConfig& config);

/// Sets disps_sens (N×H×W) for the source keyframes of `s` (other keyframes: 0). A reading that
/// the noise would make non-positive is dropped (0). Deterministic.
void addSensorDepth(Snapshot& s, const RgbdConfig& config);

}  // namespace dbacov::sim
