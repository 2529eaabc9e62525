// Linearization of a snapshot's DBA at its stored state and elimination of the depths (conventions
// §4).
//
// Variables: the tangent ξ_a (conventions §3) of every graph keyframe ("slot" a, ascending keyframe
// index) and one inverse depth d_k per (source keyframe, pixel), shared by every edge leaving that
// keyframe. With whitened residuals the normal equations are
//     [Hpp  Hpd] [δp]     [g_p]
//     [Hdp  Hdd] [δd] = − [g_d],     g = Jᵀ Λ r,   H = Jᵀ Λ J,
// Hdd diagonal (h_k). Eliminating the depths gives the reduced pose system
//     S = Hpp − Hpd Hdd⁻¹ Hdp,   g_S = g_p − Hpd Hdd⁻¹ g_d.
// Column k of Hpd is b_k, non-zero only on the source keyframe of d_k and on the targets of the
// edges leaving it ("touched" slots), so depth k adds −b_k b_kᵀ / h_k to the blocks of all pairs of
// touched slots: every source keyframe's touched set becomes a clique of S.
#pragma once

#include <cstddef>
#include <vector>

#include <Eigen/Core>

#include "dbacov/core/block_matrix.h"
#include "dbacov/core/options.h"
#include "dbacov/core/patch_graph.h"
#include "dbacov/core/snapshot.h"
#include "dbacov/core/summary.h"

namespace dbacov {

/// The depth variables of one source keyframe (kept only on request).
struct DepthTerms {
  int source_slot = -1;
  std::vector<int> touched;  ///< slots: touched[0] = source, then the distinct edge targets
  std::vector<int> pixel;    ///< pixel index y·W + x (patch graphs: patch m) of each kept depth
  std::vector<double> h;     ///< Hdd entry of each kept depth (> depth_info_eps)
  std::vector<double> g;     ///< g_d entry of each kept depth
  Eigen::MatrixXd B;         ///< 6·|touched| × pixel.size(): column k is b_k on the touched slots
};

struct DbaNormalEquations {
  std::vector<int> keyframes;      ///< slot → keyframe index (the graph keyframes, ascending)
  std::vector<int> slot_of;        ///< keyframe index → slot, or −1 when not in the graph
  BlockSymmetricMatrix Hpp;        ///< pose block before elimination
  BlockSymmetricMatrix S;          ///< reduced pose system
  Eigen::VectorXd g_p;             ///< pose gradient before elimination (6 per slot)
  Eigen::VectorXd g_S;             ///< reduced gradient
  std::vector<DepthTerms> depths;  ///< per source keyframe, only with keep_depth_terms
  LinearizationStats stats;
};

/// Decides whether a pixel factor carries information under the options' filters (conventions §2):
/// Y2 = z_j·d must be positive, >= min_depth_ratio when set; with near: d < 1/near and
/// Y2/d > near; with far: d > 1/far.
bool keepPixelFactor(const DbaOptions& options, double d, double Y2);

/// Linearizes every pixel factor at the snapshot's state and eliminates the depths. The snapshot
/// must be valid (Snapshot::validate). Pixels with d <= 0 or both weights zero carry nothing.
/// std::invalid_argument for options that apply to patch graphs only (max_residual,
/// image_margin).
DbaNormalEquations linearizeDba(const Snapshot& snapshot, const DbaOptions& options,
                                bool keep_depth_terms = false);

/// The same for DPVO's patch graph (patch_graph.h): slots are the graph frames, one factor per
/// edge at its patch centre, one depth variable per patch (shared by the patch's edges) eliminated
/// as above. Self-edges (ii == jj) are skipped; an edge is dropped by keepPixelFactor and, when
/// set, by options.max_residual (|r| >= max) and options.image_margin (projection outside the
/// widened image), as DPVO's BA does. DepthTerms::pixel holds the patch index m within its frame.
/// The graph must be valid (PatchGraph::validate).
DbaNormalEquations linearizePatchGraph(const PatchGraph& graph, const DbaOptions& options,
                                       bool keep_depth_terms = false);

}  // namespace dbacov
