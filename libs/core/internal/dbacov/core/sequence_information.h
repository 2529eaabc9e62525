// The stages of the sequence graph (sequence_graph.h): the gauged information of one DBA problem,
// its export onto a topology, and the whole sequence re-solved. Internal.
#pragma once

#include <string>
#include <vector>

#include <Eigen/Geometry>
#include <Eigen/SparseCore>

#include "dbacov/core/dba_solver.h"
#include "dbacov/core/linearization.h"
#include "dbacov/core/options.h"
#include "dbacov/core/pose_graph.h"
#include "dbacov/core/sequence_graph.h"
#include "dbacov/core/snapshot.h"

namespace dbacov {

/// A stiff prior stands for a hard gauge component: this many times the node's largest entry.
constexpr double kStiffGauge = 1e6;

/// The depth-reduced pose information of one DBA problem under its gauge, over every graph
/// keyframe but the root.
struct GaugedInformation {
  std::vector<int> keyframes;           ///< slot → keyframe index (slot 0 = root, fixed)
  std::vector<Eigen::Isometry3d> T_wc;  ///< per slot
  Eigen::SparseMatrix<double> Lambda;   ///< upper triangle, 6·(slots − 1); slot s at 6(s − 1)
  BlockSymmetricMatrix S;               ///< the depth-reduced system over every slot (root too)
  Matrix6d gauge_prior = Matrix6d::Zero();  ///< added to slot 1's block of Λ
  int dim() const { return static_cast<int>(Lambda.rows()); }
};

/// Λ of a snapshot (any snapshot: one of the stream or an assembled sequence) at its state. The
/// root is the first gauge keyframe; the gauge's second keyframe gets the gauge prior (two-pose:
/// σ⁻² per component, stiff where σ = 0; minimal: stiff along the distance direction). The root's
/// own soft prior (two-pose with σ > 0) is replaced by the hard fix. Requires the gauge keyframes
/// to be the two lowest graph keyframes (true for DROID's and the simulator's snapshots).
GaugedInformation gaugedInformation(const Snapshot& s, const DbaOptions& options);

/// How the conservative log-det objective is maximized after the common scale (see the .cpp):
/// None keeps c·(marginal relative informations); NaturalGradient takes whole-graph steps
/// Ω_e ← Ω_e + η Ω_e (Σ̂_e − μ Ŝ_e) Ω_e (sparse algebra, any size, but it stalls: on the
/// 27-keyframe line 32.2 nats and 72 % of the dense NEES); BlockCoordinate maximizes one edge's
/// 6×6 block exactly at a time (closed form, dense inverses: O(n²|E|) per sweep; 29.1 nats,
/// 85 %); Auto = BlockCoordinate up to kDenseBarrierDof, NaturalGradient beyond.
enum class LogDetRefinement { None, NaturalGradient, BlockCoordinate, Auto };
/// Largest dim Λ for which Auto uses the dense block-coordinate ascent (≈ 100 keyframes: ≈ 12 s).
constexpr int kDenseBarrierDof = 600;

struct SparsifiedGraph {
  PoseGraph graph;             ///< node id = keyframe index; edges from lower to higher id
  double scale = 0;            ///< c: exported information = c · marginal-relative information
  double kl = 0;               ///< KL(dense ‖ exported), nats
  int dof = 0;                 ///< n = dim Λ
  int barrier_iterations = 0;  ///< accepted log-det steps or block updates (0 with None)
  LogDetRefinement refinement = LogDetRefinement::None;  ///< the method used (never Auto)
  std::size_t edges = 0;
};

/// Exports Λ onto the edges of `topology` of snapshot `s` (its pairs, keyframe indices) as
/// described above. Throws NumericalError when Λ is not positive definite.
SparsifiedGraph sparsifyInformation(const GaugedInformation& info, const Snapshot& s,
                                    GraphTopology topology,
                                    LogDetRefinement refine = LogDetRefinement::Auto);

/// The whole-sequence result of SequenceProblem: the assembled (re-solved) problem, its
/// information and the solver's summary.
struct SequenceInformation {
  Snapshot problem;
  DbaSolverSummary solve;
  GaugedInformation info;
};
/// Assembles, re-solves (gauge keyframes held at their final poses) and linearizes. `solver`
/// max_iterations 0 skips the solve (the relative poses then mix the snapshots' states).
SequenceInformation sequenceInformation(const SequenceProblem& problem, const DbaOptions& options,
                                        const DbaSolverOptions& solver = {});

}  // namespace dbacov
