// Time per snapshot (issue 2): the real DROID snapshot ../shared/data/droid_window_0055.npz
// (11 keyframes, 58 edges, 49×61) through the whole engine, one core.
//   Load          .npz → validated Snapshot (libzip inflate + NPY parse + checks)
//   Linearize     pixel factors + depth Schur complement
//   Covariances   linearize + gauge + factorize + every keyframe marginal (what --csv needs)
//
//   build/bin/bench_snapshot --benchmark_repetitions=5 --benchmark_report_aggregates_only=true
#include <filesystem>

#include <benchmark/benchmark.h>

#include "dbacov/core/covariance.h"
#include "dbacov/io/snapshot_npz.h"

namespace dbacov::bench {
namespace {

const std::string kShared = std::string(DBACOV_SHARED_DATA_DIR) + "/droid_window_0055.npz";

const Snapshot& shared() {
  static const Snapshot s = io::loadSnapshotNpz(kShared, 0);
  return s;
}

bool skipWithoutData(benchmark::State& state) {
  if (std::filesystem::exists(kShared)) return false;
  state.SkipWithError(("missing " + kShared).c_str());
  return true;
}

void BM_Load(benchmark::State& state) {
  if (skipWithoutData(state)) return;
  for (auto _ : state) benchmark::DoNotOptimize(io::loadSnapshotNpz(kShared, 0));
}

void BM_Linearize(benchmark::State& state) {
  if (skipWithoutData(state)) return;
  const DbaOptions o = DbaOptions::droid();
  for (auto _ : state) benchmark::DoNotOptimize(linearizeDba(shared(), o));
  state.counters["factors"] = static_cast<double>(linearizeDba(shared(), o).stats.factors_used);
}

void BM_Covariances(benchmark::State& state) {
  if (skipWithoutData(state)) return;
  SolverOptions so;
  so.kind = state.range(0) ? SolverKind::Sparse : SolverKind::Dense;
  const DbaOptions o = DbaOptions::droid();
  for (auto _ : state) {
    const DbaCovariance cov(shared(), o, so);
    double sum = 0;
    for (int k : cov.keyframes()) sum += cov.marginal(k).trace();
    benchmark::DoNotOptimize(sum);
  }
  state.SetLabel(so.kind == SolverKind::Sparse ? "sparse" : "dense");
}

BENCHMARK(BM_Load)->Unit(benchmark::kMillisecond);
BENCHMARK(BM_Linearize)->Unit(benchmark::kMillisecond);
BENCHMARK(BM_Covariances)->Arg(1)->Arg(0)->Unit(benchmark::kMillisecond);

}  // namespace
}  // namespace dbacov::bench

BENCHMARK_MAIN();
