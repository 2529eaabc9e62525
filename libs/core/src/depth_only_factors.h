// Private to dbacov_core: the factors of DROID's DBA that act on the depths alone.
//
// RGB-D: the depth-sensor factor α·(d − d_sens)² on every source pixel with d_sens > 0
// (droid_kernels.cu: C += α, w −= α·(d − d_sens), α = 0.05); residual r = d_sens − d, ∂r/∂d = −1.
// Stereo: an edge with ii == jj reprojects the pixel into the second camera of the rig by the fixed
// transform Y = T_rig·X. Its pose Jacobians cancel (T_rig does not depend on any pose; DROID
// zeroes them), so it adds only J_dᵀΛJ_d and J_dᵀΛr to the pixel's depth; it constrains the depths
// and, through them, the metric scale.
//
// Both add to the depth diagonal h_k and gradient g_k before the Schur complement. The pixel kernel
// (dba_kernel.h) eliminates the depths itself, so they are applied afterwards as a correction of
// its kept depth terms: with h' = h + δh, g' = g + δg,
//     S  += Σ_k b_k b_kᵀ (1/h_k − 1/h'_k),      g_S += Σ_k b_k (g_k/h_k − g'_k/h'_k).
// A depth the kernel left uneliminated (h <= depth_info_eps) has b_k = O(h): it enters with b = 0.
#pragma once

#include <cstddef>
#include <vector>

#include <Eigen/Core>

#include "dbacov/core/options.h"
#include "dbacov/core/snapshot.h"

namespace dbacov::detail {

struct DepthOnlyTerms {
  std::vector<double> h, g;  ///< per pixel of the source keyframe (H·W), zero where none
  std::size_t factors_used = 0, factors_filtered = 0;
  std::size_t rows = 0;  ///< used residual axes (a stereo factor has up to two, a reading one)
  double chi2 = 0.0;
  double sum_r2 = 0.0;  ///< Σ r² over the used axes (unweighted)
  bool any = false;     ///< some pixel has δh > 0
};

/// The depth-only terms of source keyframe `src`: its sensor factor (with snapshot.disps_sens and
/// options.sensor_depth_weight > 0) and its stereo edges `stereo_edges` (indices with ii == jj).
DepthOnlyTerms depthOnlyTerms(const Snapshot& snapshot, const DbaOptions& options, int src,
                              const std::vector<int>& stereo_edges);

/// Applies `terms` to one source's eliminated depths: pixel/h/g/B as the kernel kept them
/// (B: 6T values per kept depth, appended). Adds the correction to Sloc (6T×6T) and gS_loc,
/// updates h, g in place and appends the depths that only the terms make observable (b = 0).
/// Returns how many depths were added.
std::size_t applyDepthOnlyTerms(const DepthOnlyTerms& terms, double depth_info_eps, int T6,
                                std::vector<int>& pixel, std::vector<double>& h,
                                std::vector<double>& g, std::vector<double>& B,
                                Eigen::MatrixXd& Sloc, Eigen::VectorXd& gS_loc);

}  // namespace dbacov::detail
