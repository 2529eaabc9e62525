// Information counted once over a whole sequence of DBA snapshots, and its export as a pose graph
// that can be fused as it is (the stages: sequence_information.h, internal).
//
// Why: the pairs of one snapshot are computed from the same pixels, and overlapping windows share
// flows, so edges that each carry the inverse of a snapshot's *marginal* relative covariance count
// the same measurements many times (dba-posegraph's covariances were 2× over-confident).
//
// 1. SequenceProblem keeps, over the stream of snapshots, each edge's final flows and weights (from
//    the last snapshot that holds the edge, identified by the keyframes' tstamps) and each
//    keyframe's final pose and inverse depths (from the last snapshot that holds it as a graph
//    keyframe), and assembles them into one Snapshot over all keyframes (tstamp order). Every
//    pixel factor of the sequence appears exactly once.
// 2. sequenceInformation() re-solves that problem (dba_solver.h, the two-pose gauge held where it
//    is) so that the relative poses are its optimum, linearizes it and eliminates the depths: the
//    exact depth-reduced pose information Λ of the sequence (docs/conventions.md §4),
//    expressed over every node but the root (the first gauge keyframe, held fixed as dba-posegraph
//    holds its lowest node). The second gauge keyframe carries the gauge's prior; a hard gauge
//    component is a stiff prior (kStiffGauge × the node's largest information entry), so that the
//    monocular scale is fixed by the distance of the two gauge keyframes as in the snapshots.
// 3. sparsifyInformation() exports Λ onto binary relative-pose edges of a given topology (the
//    chain of consecutive keyframes, or the co-visibility graph): each edge first gets the
//    information of its marginal relative covariance Ω_e = Σ_rel,e⁻¹ (from the selected inverse of
//    Λ), then all of them one common scale c = 1 / λ_max(Λ⁻¹ H₁) (H₁ = Σ_e J_eᵀ Ω_e J_e at the
//    linearization point), found by power iteration and certified by a Cholesky factorization of
//    Λ − c H₁: the exported information c H₁ never exceeds the true one (Loewner order), so fusing
//    the graph with independent loop closures or priors stays conservative. Its loss is the
//    Kullback-Leibler divergence KL(N(0, Λ⁻¹) ‖ N(0, (cH₁)⁻¹))
//      = ½ [tr(c H₁ Λ⁻¹) − n − ln det(c H₁) + ln det Λ],   tr(H₁ Λ⁻¹) = Σ_e tr(Ω_e Σ_rel,e) = 6|E|.
#pragma once

#include <array>
#include <cstddef>
#include <map>
#include <optional>
#include <utility>
#include <vector>

#include <Eigen/Core>

#include "dbacov/core/dba_solver.h"
#include "dbacov/core/enum_names.h"
#include "dbacov/core/options.h"
#include "dbacov/core/pose_graph.h"
#include "dbacov/core/snapshot.h"

namespace dbacov {

/// Each edge's final flows and each keyframe's final state over a stream of snapshots.
class SequenceProblem {
 public:
  /// Takes a valid snapshot's graph keyframes and edges (newer snapshots replace older values).
  /// Throws InputError naming the snapshot when its grid or intrinsics differ from the first.
  void add(const Snapshot& s);
  /// One snapshot over every keyframe seen, with the final state of every keyframe and the final
  /// targets/weights of every edge. `id` unset, `source` = "sequence". Keyframe numbering: the
  /// snapshots' own keyframe indices when they are consistent over the stream (one index per
  /// tstamp and one tstamp per index, as in simul-dba; indices that no graph names get a filler
  /// row that takes part in no edge), else the rank in ascending tstamp (DROID renumbers its
  /// keyframes when it drops one). Throws InputError when nothing was added.
  Snapshot assemble() const;
  std::size_t numKeyframes() const { return keyframes_.size(); }
  std::size_t numEdges() const { return edges_.size(); }
  std::size_t numSnapshots() const { return snapshots_; }

 private:
  struct Keyframe {
    Eigen::Matrix<double, 1, 7> pose_cw;
    std::vector<float> disp;
    std::vector<float> disp_sens;  ///< RGB-D readings (empty: none)
    std::optional<double> time_s;
  };
  struct Edge {
    std::vector<float> target, weight;  ///< 2·H·W each
  };
  int H_ = -1, W_ = -1;
  Eigen::Vector4d intrinsics_ = Eigen::Vector4d::Zero();
  std::optional<Eigen::Matrix<double, 7, 1>> stereo_rig_;  ///< the first snapshot's that has one
  std::map<double, Keyframe> keyframes_;
  std::map<std::pair<double, double>, Edge> edges_;
  std::map<double, int> index_of_;  ///< tstamp → keyframe index in the snapshots
  std::map<int, double> tstamp_of_;
  bool consistent_indices_ = true;
  std::size_t snapshots_ = 0;
};

enum class GraphTopology {
  Chain,         ///< consecutive graph keyframes
  Covisibility,  ///< Snapshot::relativePairs: co-visible and consecutive pairs
  /// Every non-zero block of S: the edge information that reproduces the block exactly when S is
  /// a sum of relative-pose factors, Ω_ab = sym(−Ad(T_b⁻¹ T_a)⁻ᵀ S_ab), projected onto the
  /// positive definite cone.
  Decomposition,
};
}  // namespace dbacov

template <>
struct dbacov::EnumNames<dbacov::GraphTopology> {
  static constexpr const char* what = "graph topology";
  static constexpr std::array<std::pair<GraphTopology, const char*>, 3> entries{
      {{GraphTopology::Chain, "chain"},
       {GraphTopology::Covisibility, "covisibility"},
       {GraphTopology::Decomposition, "decomposition"}}};
};

namespace dbacov {

/// The exported graph of a sequence and what it cost.
struct SequenceGraph {
  PoseGraph graph;         ///< node id = keyframe index; edges from lower to higher id
  DbaSolverSummary solve;  ///< the re-solve of the assembled problem
  std::size_t edges = 0;   ///< exported pose-graph edges
  double scale = 0;        ///< c: exported information = c · marginal-relative information
  double kl = 0;           ///< KL(dense ‖ exported), nats
  int dof = 0;             ///< n = dim Λ
};

/// Steps 2 and 3 above: assembles `problem`, re-solves it (gauge keyframes held at their final
/// poses; `solver` max_iterations 0 skips the solve), linearizes it and exports its information
/// onto the edges of `topology`. Throws InputError when nothing was added, NumericalError when
/// the information is not positive definite.
SequenceGraph sequenceGraph(const SequenceProblem& problem, const DbaOptions& options,
                            GraphTopology topology, const DbaSolverOptions& solver = {});

}  // namespace dbacov
