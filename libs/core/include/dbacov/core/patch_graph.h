// One patch-graph snapshot of DPVO: its sparse bundle adjustment at one BA call (the layout of
// docs/reference/formats.md, "Patch-graph snapshots (DPVO)").
//
// Every frame has M patches; only the centre of each patch enters the factor, so a patch is kept
// here as its centre pixel (x, y) and its inverse depth d. Edge e: patch kk[e] (index into the
// N·M patches) of frame ii[e] = kk[e] / M, observed at target[e] in frame jj[e], with the
// confidences weight[e] (information weight_scale · diag(weight[e]); DPVO's is weight scale 1).
// Edges with ii == jj (DPVO links a new frame's patches to the frame itself) carry no information.
#pragma once

#include <cstdint>
#include <optional>
#include <string>
#include <vector>

#include <Eigen/Core>
#include <Eigen/Geometry>

#include "dbacov/core/errors.h"

namespace dbacov {

struct PatchGraph {
  std::string source;              ///< where it came from (file path)
  std::optional<std::int64_t> id;  ///< the `id` key, when present
  std::int64_t index = 0;          ///< position in the input sequence (label when `id` is absent)

  int M = 0;                                                           ///< patches per frame
  Eigen::Matrix<double, Eigen::Dynamic, 7, Eigen::RowMajor> poses_cw;  ///< N×7, T_cw as stored
  /// Per patch (N·M, patch p = frame·M + m): centre pixel coordinates and inverse depth.
  std::vector<double> patch_x, patch_y, patch_d;
  Eigen::Vector4d intrinsics = Eigen::Vector4d::Zero();  ///< fx fy cx cy (1/4 resolution)
  std::vector<std::int64_t> ii, jj, kk;
  std::vector<double> target;  ///< E×2: predicted (x, y) of the patch centre in frame jj[e]
  std::vector<double> weight;  ///< E×2: confidences per axis
  std::int64_t t0 = 0;         ///< frames below t0 are held by DPVO's BA
  std::vector<double> tstamp;
  std::optional<std::vector<double>> timestamps_s;
  bool is_global = false;  ///< DPV-SLAM's global BA (loop-closure edges)

  int numFrames() const { return static_cast<int>(poses_cw.rows()); }
  int numEdges() const { return static_cast<int>(ii.size()); }
  int numPatches() const { return static_cast<int>(patch_d.size()); }

  std::int64_t label() const { return id ? *id : index; }
  /// "SOURCE (snapshot LABEL)", as Snapshot::name.
  std::string name() const { return source + " (snapshot " + std::to_string(label()) + ")"; }

  /// World-to-camera pose of frame k as stored (quaternion normalized), and its inverse.
  Eigen::Isometry3d T_cw(int k) const;
  Eigen::Isometry3d T_wc(int k) const;

  /// Frames named by an edge between two different frames, ascending (the "graph frames": the
  /// ones that get covariances; self-edges carry no information).
  std::vector<int> graphFrames() const;
  /// Every co-visible pair of graph frames and every pair of consecutive ones, (lower, higher),
  /// sorted, without duplicates (as Snapshot::relativePairs).
  std::vector<std::pair<int, int>> relativePairs() const;

  /// Checks sizes, index ranges and values. Throws InputError naming `source`, the key, the edge
  /// or patch and what was expected: sizes that disagree, ii/jj/kk out of range, ii != kk / M,
  /// non-finite values, zero quaternions, non-positive focal lengths, negative weights, an
  /// inverse depth <= 0 at a patch that an edge names, t0 outside [0, N], repeated tstamp values,
  /// no edge between two frames, or weights that are zero on every such edge.
  void validate() const;
};

}  // namespace dbacov
