// Cost and loss of the whole-sequence information and its conservative export.
//   bench_sequence_information [SNAPSHOTS]   (default 500; the smoke test runs 3)
// Prints, for the shared DROID snapshot and for a simulated sliding-window sequence (48×64,
// window 8, loop, state = truth: no per-snapshot solve), the time of each step and the KL
// divergence of the chain and co-visibility exports to the dense information.
#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <fstream>
#include <string>

#include "dbacov/core/sequence_information.h"
#include "dbacov/io/snapshot_npz.h"
#include "dbacov/sim/scenario.h"

using namespace dbacov;
using Clock = std::chrono::steady_clock;

static double since(Clock::time_point t0) {
  return std::chrono::duration<double>(Clock::now() - t0).count();
}

static const char* refineName(LogDetRefinement r) {
  return r == LogDetRefinement::None              ? "uniform"
         : r == LogDetRefinement::NaturalGradient ? "nat-grad"
                                                  : "block";
}

static void exportBoth(const GaugedInformation& info, const Snapshot& s, const char* what) {
  for (GraphTopology t : {GraphTopology::Chain, GraphTopology::Covisibility}) {
    for (LogDetRefinement refine : {LogDetRefinement::None, LogDetRefinement::NaturalGradient,
                                    LogDetRefinement::BlockCoordinate}) {
      if (refine == LogDetRefinement::BlockCoordinate && info.dim() > kDenseBarrierDof) continue;
      const auto t0 = Clock::now();
      const SparsifiedGraph g = sparsifyInformation(info, s, t, refine);
      std::printf("%s: %-12s %-8s %4zu edges, dim %5d, KL %10.3f nats (%.4f per DoF), %8.3f s\n",
                  what, toString(t), refineName(refine), g.edges, g.dof, g.kl, g.kl / g.dof,
                  since(t0));
    }
  }
}

int main(int argc, char** argv) {
  const int snapshots = argc > 1 ? std::atoi(argv[1]) : 500;
  {
    const char* dir = std::getenv("DBACOV_SHARED_DATA_DIR");
    const std::string path =
        std::string(dir ? dir : DBACOV_SHARED_DATA_DIR) + "/droid_window_0055.npz";
    if (!std::ifstream(path)) {
      std::printf("%s: not found, snapshot part skipped\n", path.c_str());
    } else {
      const Snapshot s = io::loadSnapshotNpz(path, 0);
      DbaOptions o = DbaOptions::droid();
      o.gauge.type = GaugeOptions::Type::Minimal;  // the hard two-pose gauge leaves 8 free nodes
      const auto t0 = Clock::now();
      const GaugedInformation info = gaugedInformation(s, o);
      std::printf("shared DROID snapshot: information %.3f s\n", since(t0));
      exportBoth(info, s, "snapshot");
    }
  }
  sim::ScenarioConfig c;
  c.trajectory.num_keyframes = snapshots + c.window - 1;
  c.trajectory.type = sim::TrajectoryType::Loop;  // laps of the room: any length fits
  c.solve = false;
  const sim::Scenario sc(c);
  SequenceProblem problem;
  double simulate = 0, add = 0;
  for (int s = 0; s < sc.numSnapshots(); ++s) {
    auto t0 = Clock::now();
    const Snapshot sn = sc.simulate(s, 0).snapshot;
    simulate += since(t0);
    t0 = Clock::now();
    problem.add(sn);
    add += since(t0);
  }
  std::printf(
      "sequence of %d snapshots (%zu keyframes, %zu edges): simulate %.2f s, keep final "
      "flows %.4f s per snapshot\n",
      snapshots, problem.numKeyframes(), problem.numEdges(), simulate, add / snapshots);
  const auto t0 = Clock::now();
  const SequenceInformation si = sequenceInformation(problem, c.engineOptions());
  std::printf("sequence: assemble + re-solve (%s) + information %.2f s\n", si.solve.brief().c_str(),
              since(t0));
  exportBoth(si.info, si.problem, "sequence");
  return 0;
}
