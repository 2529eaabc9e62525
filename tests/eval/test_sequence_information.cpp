// Issue 15: information counted once. Monte Carlo on the sliding-window line: the old per-snapshot
// marginal graph is over-confident; the whole-sequence information and its conservative export
// are not.
#include <gtest/gtest.h>

#include <cstdlib>
#include <iostream>

#include "dbacov/app/sequence_information.h"
#include "dbacov/core/consistency.h"
#include "dbacov/core/covariance.h"
#include "dbacov/core/marginal_solver.h"
#include "dbacov/core/pose_graph.h"
#include "dbacov/sim/scenario.h"
#include "dbacov/sim/scenario_json.h"

using namespace dbacov;
using namespace dbacov::app;

namespace {

sim::ScenarioConfig lineConfig(int keyframes) {
  sim::ScenarioConfig c = sim::loadScenarioConfig(std::string(DBACOV_SOURCE_DIR) +
                                                  "/share/sim/sliding_window_line.json");
  c.camera.H = 24;
  c.camera.W = 32;
  c.weight_scale = 256;
  c.trajectory.num_keyframes = keyframes;
  return c;
}

double nees(const Eigen::Isometry3d& T, const Eigen::Isometry3d& T_true, const Matrix6d& S) {
  const Vector6d e = poseError(T, T_true);
  return e.dot(S.ldlt().solve(e));
}

struct RunNees {
  double old_graph = 0, dense = 0, chain = 0, covis = 0, decomp = 0;
  int nodes = 0;
};

/// NEES summed over the nodes >= 2 (0 and 1 are the gauge, held at the truth).
RunNees runOnce(const sim::Scenario& sc, int run) {
  const DbaOptions o = sc.config().engineOptions();
  PoseGraphBuilder builder;
  SequenceProblem problem;
  for (int s = 0; s < sc.numSnapshots(); ++s) {
    const sim::SimulatedSnapshot sn = sc.simulate(s, run);
    const DbaCovariance cov(sn.snapshot, o);
    builder.add(sn.snapshot, cov);
    problem.add(sn.snapshot);
  }
  const auto& truth = sc.groundTruth();
  RunNees r;
  PoseGraph g = builder.graph();
  fuseParallelEdges(g);
  optimizePoseGraph(g, {0});
  const auto cov = poseGraphCovariances(g, {0});
  for (const auto& [id, T] : g.nodes)
    if (id >= 2) r.old_graph += nees(T, truth[id], cov.at(id)), ++r.nodes;

  const SequenceInformation si = sequenceInformation(problem, o);
  auto solver = makeCholmodMarginalSolver();
  solver->factorize(si.info.Lambda);
  for (std::size_t a = 2; a < si.info.keyframes.size(); ++a) {
    std::vector<int> idx(6);
    for (int i = 0; i < 6; ++i) idx[i] = 6 * (a - 1) + i;
    r.dense += nees(si.info.T_wc[a], truth[si.info.keyframes[a]], solver->covariance(idx, idx));
  }
  for (GraphTopology t :
       {GraphTopology::Chain, GraphTopology::Covisibility, GraphTopology::Decomposition}) {
    SparsifiedGraph sg = sparsifyInformation(si.info, si.problem, t);
    optimizePoseGraph(sg.graph, {0});
    const auto c = poseGraphCovariances(sg.graph, {0});
    double sum = 0;
    for (const auto& [id, T] : sg.graph.nodes)
      if (id >= 2) sum += nees(T, truth[id], c.at(id));
    (t == GraphTopology::Chain          ? r.chain
     : t == GraphTopology::Covisibility ? r.covis
                                        : r.decomp) = sum;
    std::cout << toString(t) << " scale " << sg.scale << " kl " << sg.kl << " steps "
              << sg.barrier_iterations << "\n";
  }
  return r;
}

}  // namespace

TEST(SequenceInformation, DiagnosticMonteCarlo) {
  const int keyframes = std::getenv("SEQ_KF") ? std::atoi(std::getenv("SEQ_KF")) : 14;
  const int runs = std::getenv("SEQ_RUNS") ? std::atoi(std::getenv("SEQ_RUNS")) : 4;
  const sim::Scenario sc(lineConfig(keyframes));
  RunNees total;
  for (int run = 0; run < runs; ++run) {
    const RunNees r = runOnce(sc, run);
    std::cout << "run " << run << ": old " << r.old_graph / r.nodes << " dense "
              << r.dense / r.nodes << " chain " << r.chain / r.nodes << " covis "
              << r.covis / r.nodes << " decomp " << r.decomp / r.nodes << "\n";
    total.old_graph += r.old_graph;
    total.dense += r.dense;
    total.chain += r.chain;
    total.covis += r.covis;
    total.decomp += r.decomp;
    total.nodes += r.nodes;
  }
  const ChiSquareRegion region = aneesRegion(6, runs);
  std::cout << "ANEES old " << total.old_graph / total.nodes << " dense "
            << total.dense / total.nodes << " chain " << total.chain / total.nodes << " covis "
            << total.covis / total.nodes << " decomp " << total.decomp / total.nodes << " region ["
            << region.lower << ", " << region.upper << "]\n";
}
