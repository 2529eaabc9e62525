// Marginal pose covariances of one DBA snapshot (conventions §4–§5). The query API is deliberately
// small: build once, then ask for one keyframe's covariance, a joint block or a relative-pose
// covariance.
//
// Statistical model: every pixel factor r ~ N(0, Λ⁻¹) with Λ = weight_scale · diag(w_x, w_y),
// independent across pixels and edges, linearized at the snapshot's state (which DBA made a local
// optimum). The covariances are the inverse of the Gauss-Newton information with the depths
// marginalized and the gauge of conventions §4; they are as good as this model. Raw DROID weights
// treat correlated pixels as independent, so calibrate `weight_scale` against ground truth
// (conventions §7).
//
// Construction fails with
//   - InputError      when the snapshot is invalid,
//   - NumericalError  naming keyframes when no gauge reaches part of the graph, or when the reduced
//                     system is not positive definite (degenerate geometry, all weights zero).
#pragma once

#include <memory>
#include <vector>

#include <Eigen/Geometry>

#include "dbacov/core/options.h"
#include "dbacov/core/patch_graph.h"
#include "dbacov/core/se3.h"
#include "dbacov/core/snapshot.h"
#include "dbacov/core/summary.h"

namespace dbacov {

struct GaugeGraph;  // what the gauge needs of a graph (internal)

namespace detail {
struct GivenModel;  // a covariance computed outside the engine (self-calibration; internal)
}

class DbaCovariance {
 public:
  /// Validates the options (std::invalid_argument), linearizes,
  /// fixes the gauge and factorizes; throws NumericalError as described above.
  DbaCovariance(const Snapshot& snapshot, const DbaOptions& options,
                const CovarianceOptions& covariance = {});
  /// The same for DPVO's patch graph (linearizePatchGraph; use DbaOptions::dpvo() for DPVO's own
  /// model): keyframes are the graph frames, and inverseDepthSigma(frame) answers M values, one
  /// per patch of the frame (NaN where a patch carries no information).
  DbaCovariance(const PatchGraph& graph, const DbaOptions& options,
                const CovarianceOptions& covariance = {});
  ~DbaCovariance();
  DbaCovariance(DbaCovariance&&) noexcept;
  DbaCovariance& operator=(DbaCovariance&&) noexcept;

  /// Graph keyframes (indices into the snapshot's poses), ascending.
  const std::vector<int>& keyframes() const;
  bool contains(int keyframe) const;
  /// The keyframes that carry the gauge (two-pose: both priors; minimal: fixed, then scale).
  std::vector<int> gaugeKeyframes() const;
  /// Number of free tangent DoF of a keyframe after the gauge (6, or fewer for gauge keyframes).
  int freeDof(int keyframe) const;

  /// 6×6 covariance of ξ_k (conventions §3). Zero for hard-fixed keyframes.
  Matrix6d marginal(int keyframe) const;
  /// 12×12 joint covariance of (ξ_a, ξ_b), a first.
  Matrix12d joint(int a, int b) const;
  /// Covariance of the tangent of Z = T_wc_a⁻¹ T_wc_b (conventions §5).
  Matrix6d relative(int a, int b) const;

  /// Standard deviation of the inverse depth of every pixel of source keyframe `keyframe`
  /// (H×W, C order): var(d_k) = 1/h_k + b_kᵀ Σ b_k / h_k² (conventions §5), using only the blocks
  /// of Σ between the keyframe and its edge targets. NaN where a pixel carries no information (no
  /// weighted factor, filtered, d <= 0, or unobservable). Requires depth_variances in the
  /// covariance options (std::logic_error otherwise); keyframes that are no edge source get all
  /// NaN.
  std::vector<float> inverseDepthSigma(int keyframe) const;
  /// Keyframes that are the source of at least one edge.
  std::vector<int> sourceKeyframes() const;

  /// Camera-to-world pose of a keyframe at the linearization point.
  const Eigen::Isometry3d& T_wc(int keyframe) const;
  const LinearizationStats& stats() const;
  /// What the computation did: solver, ordering, nnz(L), pixels, time per stage.
  const CovarianceSummary& summary() const;

 private:
  friend struct detail::GivenModel;
  DbaCovariance(const Snapshot& snapshot, const DbaOptions& options,
                const CovarianceOptions& covariance, const detail::GivenModel* given);
  /// Everything after the linearization (impl_->ne): gauge, factorization, summary, checks.
  void finish(const GaugeGraph& graph, int num_frames, int num_edges, const DbaOptions& options,
              const CovarianceOptions& covariance, const detail::GivenModel* given,
              double seconds_linearize);
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

}  // namespace dbacov
