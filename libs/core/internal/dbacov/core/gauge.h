// The gauge of monocular DBA as a parameterization of the pose tangents (conventions §4).
//
// Monocular DBA is invariant to a similarity transform of the world (6 pose DoF + scale), so S is
// singular. Both gauges are expressed the same way: slot a keeps the coordinates x_a of
//     ξ_a = basis[a] · x_a,          basis[a] ∈ R^{6×m_a}, orthonormal columns, 0 <= m_a <= 6,
// and prior[a] (m_a×m_a, possibly empty) is added to its reduced information. The reduced system is
//     S_r[a,b] = basis[a]ᵀ S[a,b] basis[b] (+ prior[a] on the diagonal),
// and the covariance of ξ_a is basis[a] Σ_r[a,a] basis[a]ᵀ (exactly zero along removed directions).
//
// two-pose: the two lowest-indexed keyframes in `ii` get a prior diag(σ_t⁻², σ_t⁻², σ_t⁻²,
// σ_r⁻²...)
//           in [ρ; φ]; a component with σ = 0 is removed instead (hard fix).
// droid:    every graph keyframe below the snapshot's t0 (DROID's fixed poses) is removed.
// minimal:  the first keyframe is removed (m = 0); for the second, only the direction that changes
//           the distance between the two centres is removed. With c_a, c_b the centres and
//           u = (c_b − c_a)/|c_b − c_a|, the centre moves by δc_b = R_b ρ_b, so the distance
//           changes by uᵀ R_b ρ_b: the removed direction is [R_bᵀ u; 0] and m_b = 5.
#pragma once

#include <algorithm>
#include <cstdint>
#include <functional>
#include <optional>
#include <string>
#include <vector>

#include <Eigen/Core>
#include <Eigen/SparseCore>

#include "dbacov/core/block_matrix.h"
#include "dbacov/core/options.h"
#include "dbacov/core/patch_graph.h"
#include "dbacov/core/snapshot.h"

namespace dbacov {

struct GaugeParameterization {
  std::vector<Eigen::MatrixXd> basis;  ///< per slot, 6×m_a
  std::vector<Eigen::MatrixXd> prior;  ///< per slot, m_a×m_a or empty
  std::vector<int> offset;             ///< reduced offset of each slot; offset.back() = dim
  std::vector<int> gauge_slots;        ///< the slots that carry the gauge
  /// droid: a graph part is reached by any held slot (two-pose/minimal: by both gauge slots).
  bool any_slot_reaches = false;

  int dim() const { return offset.back(); }
  int dimOf(int slot) const { return offset[slot + 1] - offset[slot]; }
  /// The slot whose reduced coordinates hold column `col` (0 <= col < dim()).
  int slotOfColumn(int col) const {
    return static_cast<int>(std::upper_bound(offset.begin(), offset.end(), col) - offset.begin()) -
           1;
  }
};

/// What a gauge needs to know of a graph (a dense snapshot or a patch graph).
struct GaugeGraph {
  std::string source;                 ///< names the input in messages
  std::optional<std::int64_t> t0;     ///< the frames below it were held (gauge droid)
  std::vector<std::int64_t> sources;  ///< the source frame of every edge that carries information
  std::function<Eigen::Isometry3d(int)> T_wc;  ///< camera-to-world pose of a frame
};
GaugeGraph gaugeGraph(const Snapshot& s);
GaugeGraph gaugeGraph(const PatchGraph& g);

/// Builds the gauge for the graph keyframes `keyframes` (slot → keyframe) of `graph`.
GaugeParameterization makeGauge(const GaugeOptions& options, const GaugeGraph& graph,
                                const std::vector<int>& keyframes);
/// makeGauge(options, gaugeGraph(s), keyframes).
/// Builds the gauge for the graph keyframes `keyframes` (slot → keyframe) of snapshot `s`.
/// Throws NumericalError when `ii` names fewer than two keyframes, or (minimal) when the first two
/// keyframe centres coincide, so that scale cannot be fixed by their distance.
GaugeParameterization makeGauge(const GaugeOptions& options, const Snapshot& s,
                                const std::vector<int>& keyframes);

/// The reduced system S_r (upper triangle, column-major) of the block matrix S under the gauge.
Eigen::SparseMatrix<double> reduceSystem(const BlockSymmetricMatrix& S,
                                         const GaugeParameterization& gauge);

/// Checks that every connected part of the information graph (non-zero off-diagonal blocks of S)
/// contains both gauge keyframes. Throws NumericalError naming the keyframes of the first part
/// that no gauge reaches.
void checkGaugeReachesAll(const BlockSymmetricMatrix& S, const GaugeParameterization& gauge,
                          const std::vector<int>& keyframes);

}  // namespace dbacov
