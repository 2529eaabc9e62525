// Time per snapshot: the real DROID snapshot ../shared/data/droid_window_0055.npz
// (11 keyframes, 58 edges, 49×61) through the whole engine, one core.
//   Load          .npz → validated Snapshot (libzip inflate + NPY parse + checks)
//   LoadStored    the same snapshot saved with stored (not deflated) members, as np.savez or
//                 dbacov_dump.py's compressed=False write it: parse + checks, no inflate
//   Linearize     pixel factors + depth Schur complement, args (problem, threads): problem 0 =
//                 the shared snapshot, 1 = a simulated DROID-sized window; vs the FLOP floor
//   Covariances   linearize + gauge + factorize + every keyframe marginal (what --csv needs)
//   PatchGraph    the same for a DPVO-sized patch graph (10 frames, 96 patches per frame, every
//                 patch seen by every frame: 9 600 edges; the preset dpvo, droid gauge at t0 = 2):
//                 what running after every DPVO update costs
//
//   build/bin/bench_snapshot --benchmark_repetitions=5 --benchmark_report_aggregates_only=true
#include <filesystem>

#include <benchmark/benchmark.h>

#include "bench_problems.h"
#include "dbacov/core/covariance.h"
#include "dbacov/core/linearization.h"
#include "dbacov/core/threads.h"
#include "flop_count.h"
#include "patch_graph_fixture.h"

namespace dbacov::bench {
namespace {

void BM_Load(benchmark::State& state) {
  if (skipWithoutSharedSnapshot(state)) return;
  for (auto _ : state) benchmark::DoNotOptimize(io::loadSnapshotNpz(kSharedSnapshot, 0));
}

void BM_LoadStored(benchmark::State& state) {
  if (skipWithoutSharedSnapshot(state)) return;
  const std::filesystem::path path =
      std::filesystem::temp_directory_path() / "dbacov_bench_stored.npz";
  io::saveSnapshotNpz(path.string(), sharedSnapshot(), /*compressed=*/false);
  for (auto _ : state) benchmark::DoNotOptimize(io::loadSnapshotNpz(path.string(), 0));
  state.counters["MB"] = static_cast<double>(std::filesystem::file_size(path)) / 1e6;
  std::filesystem::remove(path);
}

/// 0: the shared DROID snapshot; 1: a simulated DROID-sized window (25 keyframes, 48×64).
const Snapshot& snapshot(int which) {
  static const Snapshot window = sim::generateSyntheticSnapshot(droidSizedWindowConfig()).snapshot;
  return which == 0 ? sharedSnapshot() : window;
}

/// Linearization + depth Schur complement on `threads` threads, against the FLOP floor.
void BM_Linearize(benchmark::State& state) {
  if (state.range(0) == 0 && skipWithoutSharedSnapshot(state)) return;
  const ThreadLimit limit(static_cast<std::size_t>(state.range(1)));
  const Snapshot& s = snapshot(static_cast<int>(state.range(0)));
  DbaOptions o = DbaOptions::droid();
  for (auto _ : state) benchmark::DoNotOptimize(linearizeDba(s, o));
  const double flops = linearizationFlops(s);
  state.counters["factors"] = static_cast<double>(linearizeDba(s, o).stats.factors_used);
  state.counters["MFLOP"] = flops / 1e6;
  state.counters["floor_ms"] = 1e3 * flops / kPeakFlopsPerSecond;
  state.counters["GFLOP/s"] =
      benchmark::Counter(flops / 1e9, benchmark::Counter::kIsIterationInvariantRate);
}

void BM_Covariances(benchmark::State& state) {
  if (skipWithoutSharedSnapshot(state)) return;
  const ThreadLimit one(1);
  CovarianceOptions so;
  so.kind = state.range(0) ? SolverKind::Sparse : SolverKind::Dense;
  const DbaOptions o = DbaOptions::droid();
  for (auto _ : state) {
    const DbaCovariance cov(sharedSnapshot(), o, so);
    double sum = 0;
    for (int k : cov.keyframes()) sum += cov.marginal(k).trace();
    benchmark::DoNotOptimize(sum);
  }
  state.SetLabel(so.kind == SolverKind::Sparse ? "sparse" : "dense");
}

void BM_PatchGraph(benchmark::State& state) {
  const ThreadLimit one(1);
  PatchGraph g = testing::makePatchGraph(13, 10, 96, 9);
  g.t0 = 2;
  const DbaOptions o = DbaOptions::dpvo();
  for (auto _ : state) {
    const DbaCovariance cov(g, o);
    double sum = 0;
    for (int k : cov.keyframes()) sum += cov.marginal(k).trace();
    benchmark::DoNotOptimize(sum);
  }
  state.SetLabel(std::to_string(g.numEdges()) + " edges");
}

BENCHMARK(BM_Load)->Unit(benchmark::kMillisecond);
BENCHMARK(BM_LoadStored)->Unit(benchmark::kMillisecond);
BENCHMARK(BM_Linearize)
    ->Args({0, 1})
    ->Args({0, 2})
    ->Args({1, 1})
    ->Args({1, 2})
    ->Unit(benchmark::kMillisecond)
    ->UseRealTime();
BENCHMARK(BM_Covariances)->Arg(1)->Arg(0)->Unit(benchmark::kMillisecond);
BENCHMARK(BM_PatchGraph)->Unit(benchmark::kMillisecond);

}  // namespace
}  // namespace dbacov::bench

BENCHMARK_MAIN();
