// DROID-like edge selection: temporal neighbours plus pairs whose views overlap.
#pragma once

#include <utility>
#include <vector>

#include <Eigen/Geometry>

#include "dbacov/core/dba_factor.h"
#include "dbacov/sim/scene.h"

namespace dbacov::sim {

struct CovisibilityConfig {
  int edge_radius = 2;              ///< link keyframes with |i − j| <= edge_radius
  double overlap_threshold = 0.0;   ///< > 0: also link farther pairs whose views overlap this much
  int max_overlap_edges = 2;        ///< per keyframe, the best-overlapping farther partners
  double candidate_distance = 1.0;  ///< metres between centres for a farther pair to be tested
};

/// Fraction of a coarse pixel grid of view i (true depths from the scene) that lands inside
/// view j, in front of it.
double viewOverlap(const RoomScene& scene, const PinholeIntrinsics& K, int H, int W,
                   const Eigen::Isometry3d& T_wc_i, const Eigen::Isometry3d& T_wc_j);

/// Directed edges (i, j), both directions for every linked pair, among keyframes
/// first..poses.size()−1, sorted by (i, j).
std::vector<std::pair<int, int>> selectEdges(const std::vector<Eigen::Isometry3d>& T_wc, int first,
                                             const RoomScene& scene, const PinholeIntrinsics& K,
                                             int H, int W, const CovisibilityConfig& config);

}  // namespace dbacov::sim
