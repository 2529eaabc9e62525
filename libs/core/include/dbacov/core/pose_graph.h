// Pose graphs of DROID-SLAM keyframes whose constraints carry the DBA information.
//
// Nodes are keyframes (id = keyframe index into the snapshots' `poses`), with camera-to-world
// poses. An edge (from < to) is a relative-pose constraint Z ≈ T_from⁻¹ T_to with the information
// (inverse covariance) of the tangent of Z in the conventions §3 convention, which is also MRPT's
// CNetworkOfPoses3DInf / optimize_graph_spa_levmarq convention (conventions §6).
#pragma once

#include <cstddef>
#include <map>
#include <set>
#include <utility>
#include <vector>

#include "dbacov/core/covariance.h"
#include "dbacov/core/se3.h"
#include "dbacov/core/snapshot.h"

namespace dbacov {

struct PoseGraphEdge {
  int from = 0, to = 0;
  Eigen::Isometry3d Z = Eigen::Isometry3d::Identity();  ///< measured T_from⁻¹ T_to
  Matrix6d information = Matrix6d::Identity();          ///< of the tangent of Z
};

struct PoseGraph {
  std::map<int, Eigen::Isometry3d> nodes;  ///< node id → T_wc
  std::vector<PoseGraphEdge> edges;        ///< sorted by (from, to)
  std::map<int, double> node_time;         ///< node id → seconds, when known
  std::map<int, double> node_tstamp;       ///< node id → DROID tstamp, when known
};

/// Builds the pose graph of a processed sequence, snapshot by snapshot: every node takes its
/// latest T_wc; every co-visible and every consecutive pair (Snapshot::relativePairs) takes the
/// relative pose and information from the last snapshot that contains both keyframes *and* gives
/// their relative pose a full-rank covariance. A pair that a hard gauge fixes in every snapshot
/// (e.g. the two gauge keyframes of the `droid` preset) carries no information and gets no edge;
/// numUninformativePairs() counts them.
class PoseGraphBuilder {
 public:
  void add(const Snapshot& snapshot, const DbaCovariance& cov);
  PoseGraph graph() const;
  std::size_t numUninformativePairs() const;

 private:
  PoseGraph partial_;  // nodes and times
  std::map<std::pair<int, int>, PoseGraphEdge> edges_;
  std::set<std::pair<int, int>> seen_;
};

/// Information of a relative-pose covariance: Σ⁻¹ (exactly symmetric) when Σ is positive definite
/// (smallest eigenvalue > 1e-12 × largest); false otherwise.
bool informationOf(const Matrix6d& Sigma, Matrix6d* information);

/// Edge residual r = Log(Z⁻¹ T_from⁻¹ T_to) and its Jacobians with respect to the right
/// perturbations T_from·Exp(δ_from), T_to·Exp(δ_to):
///   ∂r/∂δ_to = Jr(r)⁻¹,   ∂r/∂δ_from = −Jr(r)⁻¹ Ad(T_to⁻¹ T_from).
void poseGraphEdgeResidual(const Eigen::Isometry3d& T_from, const Eigen::Isometry3d& T_to,
                           const Eigen::Isometry3d& Z, Vector6d* r, Matrix6d* J_from,
                           Matrix6d* J_to);

/// Merges edges that join the same two nodes (in either direction) into one edge from the lower to
/// the higher id that imposes the same constraint to first order: an edge b → a is first turned
/// around exactly (Z ← Z⁻¹, Λ ← Ad(Z⁻¹)ᵀ Λ Ad(Z⁻¹), since r_ab = −Ad(Z_ab) r_ba), then the
/// measurement is the information-weighted mean on SE(3) (Gauss-Newton to convergence) and the
/// information the sum of the edges' informations at it. MRPT 2.5.8's optimize_graph_spa_levmarq
/// mishandles parallel edges (its LM step sees a non-positive-definite system and never moves),
/// and its text loader keeps only the first one, so graphs are fused before they reach MRPT.
/// Returns the number of edges removed.
std::size_t fuseParallelEdges(PoseGraph& graph);

struct PoseGraphOptimizerOptions {
  int max_iterations = 100;
  /// Converged when the largest entry of the gradient Σ Jᵀ Λ r is below this (absolute).
  double gradient_tolerance = 1e-9;
  /// ... or when the relative decrease of the cost in an accepted step is below this.
  double cost_tolerance = 1e-14;
};

struct PoseGraphOptimizerSummary {
  int iterations = 0;
  double initial_cost = 0, final_cost = 0;  ///< Σ_e r_eᵀ Λ_e r_e
  double final_gradient = 0;                ///< max |Σ Jᵀ Λ r| at the end
  bool converged = false;
};

/// Weighted cost Σ_e r_eᵀ Λ_e r_e and the largest gradient entry over the non-fixed nodes.
std::pair<double, double> poseGraphCostAndGradient(const PoseGraph& graph,
                                                   const std::set<int>& fixed);

/// Levenberg-Marquardt on the graph's weighted cost with the residuals of poseGraphEdgeResidual
/// (the convention of MRPT's optimizer), sparse Cholesky steps, `fixed` nodes held. Updates the
/// node poses in place. dba-posegraph uses it to finish what MRPT 2.5.8's
/// optimize_graph_spa_levmarq leaves unconverged: that optimizer accepts a step only if the
/// *unweighted* squared error decreases, and after the first rejected step it retries with an
/// empty Hessian (non positive definite) until it gives up, so on graphs with real information
/// matrices it usually stops far from the optimum.
PoseGraphOptimizerSummary optimizePoseGraph(PoseGraph& graph, const std::set<int>& fixed,
                                            const PoseGraphOptimizerOptions& options = {});

/// Marginal covariances (conventions §3 tangent) of the nodes of `graph` at its current poses: the
/// inverse of H = Σ_e Jᵀ Λ_e J with the `fixed` nodes removed (their covariance is zero), from the
/// sparse solver. Throws NumericalError naming nodes when H is singular (a part of the graph that
/// no fixed node reaches).
std::map<int, Matrix6d> poseGraphCovariances(const PoseGraph& graph, const std::set<int>& fixed,
                                             SolverKind solver = SolverKind::Sparse);

}  // namespace dbacov
