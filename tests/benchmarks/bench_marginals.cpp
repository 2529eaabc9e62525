// Scale of the marginal solver: whole-trajectory DBA graphs from the simulator, loop
// trajectory (band of temporal neighbours plus revisits), 48×64 grid, 100 / 1 000 / 3 000
// keyframes. Arguments: (keyframes, keyframes per lap). 200 per lap is the DROID-like case (a
// revisit every 200 keyframes); 60 per lap is a stress case where every keyframe sees the same
// place again every 60 keyframes, which makes the graph a 2-D mesh with much more fill.
// Measured per size:
//   Linearize      linearization + depth Schur complement (for context)
//   Sparse         CHOLMOD factorization + selected inverse + every keyframe marginal and every
//                  edge joint block (what dba-covariance needs)
//   Dense          dense Cholesky + full inverse of the same reduced system (<= 1 000 keyframes)
// Counters: peak_MB = resident memory added during the phase; nnz_L = stored factor entries.
//
//   build/bin/bench_marginals --benchmark_repetitions=3 --benchmark_report_aggregates_only=true
#include <map>
#include <memory>

#include <benchmark/benchmark.h>

#include "dbacov/core/gauge.h"
#include "dbacov/core/linearization.h"
#include "dbacov/core/marginal_solver.h"
#include "dbacov/sim/synthetic_snapshot.h"
#include "peak_memory.h"

namespace dbacov::bench {
namespace {

struct Problem {
  Snapshot snapshot;
  DbaNormalEquations ne;
  GaugeParameterization gauge;
  Eigen::SparseMatrix<double> S;
};

sim::SyntheticSnapshotConfig trajectoryConfig(int n, int per_lap) {
  sim::SyntheticSnapshotConfig c;
  c.num_keyframes = n;
  c.H = 48;
  c.W = 64;
  c.fx = c.fy = 0.87 * c.W;
  c.cx = 0.5 * (c.W - 1);
  c.cy = 0.5 * (c.H - 1);
  c.trajectory.type = sim::TrajectoryType::Loop;
  c.trajectory.num_keyframes = n;
  c.trajectory.keyframes_per_lap = per_lap;
  c.covisibility.edge_radius = 3;
  c.covisibility.overlap_threshold = 0.5;
  c.covisibility.max_overlap_edges = 2;
  c.covisibility.candidate_distance = 0.5;
  c.weight_scale = 4.0;
  return c;
}

/// The linearized problem for (keyframes, per lap) of the benchmark's arguments. Only one is kept
/// resident at a time: the 3 000-keyframe snapshots hold ~1 GB of pixels.
Problem& prepared(const benchmark::State& state) {
  static std::map<std::pair<int, int>, std::unique_ptr<Problem>> cache;
  const std::pair<int, int> key{static_cast<int>(state.range(0)), static_cast<int>(state.range(1))};
  auto it = cache.find(key);
  if (it == cache.end()) {
    cache.clear();
    auto p = std::make_unique<Problem>();
    p->snapshot = sim::generateSyntheticSnapshot(trajectoryConfig(key.first, key.second)).snapshot;
    DbaOptions o;
    o.weight_scale = 4.0;
    p->ne = linearizeDba(p->snapshot, o);
    p->gauge = makeGauge(o.gauge, p->snapshot, p->ne.keyframes);
    p->S = reduceSystem(p->ne.S, p->gauge);
    it = cache.emplace(key, std::move(p)).first;
  }
  return *it->second;
}

/// Reduced indices of a slot (empty for hard-fixed gauge keyframes).
std::vector<int> indices(const GaugeParameterization& g, int slot) {
  std::vector<int> idx;
  for (int i = g.offset[slot]; i < g.offset[slot + 1]; ++i) idx.push_back(i);
  return idx;
}

void BM_Linearize(benchmark::State& state) {
  Problem& p = prepared(state);
  DbaOptions o;
  o.weight_scale = 4.0;
  for (auto _ : state) benchmark::DoNotOptimize(linearizeDba(p.snapshot, o));
  state.counters["edges"] = p.snapshot.numEdges();
  state.counters["factors"] = static_cast<double>(p.ne.stats.factors_used);
}

void BM_Sparse(benchmark::State& state) {
  Problem& p = prepared(state);
  const int n = static_cast<int>(p.ne.keyframes.size());
  double peak = 0, nnz = 0;
  for (auto _ : state) {
    const double base = resetPeakRss();
    auto solver = makeCholmodMarginalSolver();
    solver->factorize(p.S);
    double sum = 0;
    for (int a = 0; a < n; ++a)
      sum += solver->covariance(indices(p.gauge, a), indices(p.gauge, a)).sum();
    for (std::size_t e = 0; e < p.snapshot.ii.size(); ++e) {
      const int a = p.ne.slot_of[p.snapshot.ii[e]], b = p.ne.slot_of[p.snapshot.jj[e]];
      sum += solver->covariance(indices(p.gauge, a), indices(p.gauge, b)).sum();
    }
    benchmark::DoNotOptimize(sum);
    peak = peakRss() - base;
    nnz = static_cast<double>(solver->factorEntries());
  }
  state.counters["peak_MB"] = peak / 1e6;
  state.counters["nnz_L"] = nnz;
  state.counters["dim_S"] = p.S.rows();
}

void BM_Dense(benchmark::State& state) {
  Problem& p = prepared(state);
  double peak = 0;
  for (auto _ : state) {
    const double base = resetPeakRss();
    auto solver = makeDenseMarginalSolver();
    solver->factorize(p.S);
    benchmark::DoNotOptimize(solver->covariance({0}, {0}));
    peak = peakRss() - base;
  }
  state.counters["peak_MB"] = peak / 1e6;
  state.counters["dim_S"] = p.S.rows();
}

// Grouped by problem so that each is generated once.
BENCHMARK(BM_Linearize)->Args({100, 200})->Unit(benchmark::kMillisecond)->Iterations(1);
BENCHMARK(BM_Sparse)->Args({100, 200})->Unit(benchmark::kMillisecond);
BENCHMARK(BM_Dense)->Args({100, 200})->Unit(benchmark::kMillisecond);
BENCHMARK(BM_Linearize)->Args({1000, 200})->Unit(benchmark::kMillisecond)->Iterations(1);
BENCHMARK(BM_Sparse)->Args({1000, 200})->Unit(benchmark::kMillisecond);
BENCHMARK(BM_Dense)->Args({1000, 200})->Unit(benchmark::kMillisecond)->Iterations(1);
BENCHMARK(BM_Linearize)->Args({3000, 200})->Unit(benchmark::kMillisecond)->Iterations(1);
BENCHMARK(BM_Sparse)->Args({3000, 200})->Unit(benchmark::kMillisecond);
BENCHMARK(BM_Sparse)->Args({1000, 60})->Unit(benchmark::kMillisecond);
BENCHMARK(BM_Sparse)->Args({3000, 60})->Unit(benchmark::kMillisecond)->Iterations(1);

}  // namespace
}  // namespace dbacov::bench

BENCHMARK_MAIN();
