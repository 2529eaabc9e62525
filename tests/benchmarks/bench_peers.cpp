// dbacov against what a user would pick instead, on the same problems in one run:
//   Dbacov          linearize + Schur + CHOLMOD + selected inverse, every keyframe marginal
//   DenseReduced    the same reduced system inverted densely with Eigen
//   CeresFull       ceres::Covariance (SPARSE_QR) on the full problem: pose and inverse-depth
//                   parameter blocks, one residual block per pixel factor
//   CeresReduced    ceres::Covariance on the reduced pose system (r = U x, UᵀU = S)
// Problems: 0 = the real DROID snapshot (../shared/data), 1 = a simulated DROID-sized window
// (25 keyframes, 48×64, edges to the 3 nearest keyframes each way). Counters: max_rel_diff =
// largest ‖Σ_peer − Σ_dbacov‖/‖Σ_dbacov‖ over keyframes; factors; setup_s = time to build the
// peer's problem (not in the timing). One thread everywhere.
//
//   build/bin/bench_peers --benchmark_repetitions=3 --benchmark_report_aggregates_only=true
#include <chrono>
#include <filesystem>

#include <benchmark/benchmark.h>

#include "bench_problems.h"
#include "ceres_problems.h"
#include "dbacov/core/covariance.h"
#include "dbacov/core/linearization.h"
#include "dbacov/core/threads.h"

namespace dbacov::bench {
namespace {

/// Problem 1: a DROID-sized window from the simulator.
Snapshot droidSizedWindow() {
  sim::SyntheticSnapshotConfig c = droidSizedWindowConfig();
  c.weight_scale = 4.0;
  return sim::generateSyntheticSnapshot(c).snapshot;
}

struct Case {
  Snapshot snapshot;
  DbaOptions options;
  std::map<int, Matrix6d> reference;  // dbacov's marginals
};

const Case& problem(int which) {
  static std::map<int, Case> cache;
  auto it = cache.find(which);
  if (it != cache.end()) return it->second;
  Case c;
  if (which == 0) {
    c.snapshot = sharedSnapshot();
    c.options = DbaOptions::droid();
  } else {
    c.snapshot = droidSizedWindow();
    c.options = DbaOptions::droid();
    c.options.weight_scale = 4.0;
  }
  const DbaCovariance cov(c.snapshot, c.options);
  for (int k : cov.keyframes()) c.reference[k] = cov.marginal(k);
  return cache.emplace(which, std::move(c)).first->second;
}

bool unavailable(benchmark::State& state) {
  return state.range(0) == 0 && skipWithoutSharedSnapshot(state);
}

double relDiff(const Case& c, int k, const Matrix6d& got) {
  const Matrix6d& ref = c.reference.at(k);
  return ref.norm() > 0 ? (got - ref).norm() / ref.norm() : got.norm();
}

void BM_Dbacov(benchmark::State& state) {
  if (unavailable(state)) return;
  const ThreadLimit one(1);
  const Case& c = problem(static_cast<int>(state.range(0)));
  for (auto _ : state) {
    const DbaCovariance cov(c.snapshot, c.options);
    double sum = 0;
    for (int k : cov.keyframes()) sum += cov.marginal(k).trace();
    benchmark::DoNotOptimize(sum);
    state.counters["factors"] = static_cast<double>(cov.stats().factors_used);
  }
}

void BM_DenseReduced(benchmark::State& state) {
  if (unavailable(state)) return;
  const ThreadLimit one(1);
  const Case& c = problem(static_cast<int>(state.range(0)));
  CovarianceOptions so;
  so.kind = SolverKind::Dense;
  double worst = 0;
  for (auto _ : state) {
    const DbaCovariance cov(c.snapshot, c.options, so);
    for (int k : cov.keyframes()) worst = std::max(worst, relDiff(c, k, cov.marginal(k)));
  }
  state.counters["max_rel_diff"] = worst;
}

/// Times ceres::Covariance (SPARSE_QR, one thread) on `problem` for the 6×6 diagonal blocks of
/// `blocks` (the parameter blocks of keyframes `keyframes`) and records the largest difference
/// from dbacov's marginals as the counter max_rel_diff.
void timeCeresCovariance(benchmark::State& state, const Case& c, ceres::Problem& problem,
                         const std::vector<double*>& blocks, const std::vector<int>& keyframes) {
  ceres::Covariance::Options opt;
  opt.algorithm_type = ceres::SPARSE_QR;
  opt.num_threads = 1;
  double worst = 0;
  for (auto _ : state) {
    ceres::Covariance cov(opt);
    std::vector<std::pair<const double*, const double*>> pairs;
    for (double* b : blocks) pairs.emplace_back(b, b);
    if (!cov.Compute(pairs, &problem)) {
      state.SkipWithError("ceres::Covariance::Compute failed");
      return;
    }
    for (std::size_t a = 0; a < blocks.size(); ++a) {
      Eigen::Matrix<double, 6, 6, Eigen::RowMajor> b;
      cov.GetCovarianceBlock(blocks[a], blocks[a], b.data());
      worst = std::max(worst, relDiff(c, keyframes[a], b));
    }
  }
  state.counters["max_rel_diff"] = worst;
}

void BM_CeresFull(benchmark::State& state) {
  if (unavailable(state)) return;
  const Case& c = problem(static_cast<int>(state.range(0)));
  const auto t0 = std::chrono::steady_clock::now();
  CeresFullProblem cp = buildCeresFullProblem(c.snapshot, c.options);
  state.counters["setup_s"] =
      std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  std::vector<double*> blocks;
  for (int k : cp.free_keyframes) blocks.push_back(cp.xi[k].get());
  timeCeresCovariance(state, c, *cp.problem, blocks, cp.free_keyframes);
  state.counters["residual_blocks"] = cp.problem->NumResidualBlocks();
}

void BM_CeresReduced(benchmark::State& state) {
  if (unavailable(state)) return;
  const Case& c = problem(static_cast<int>(state.range(0)));
  const DbaNormalEquations ne = linearizeDba(c.snapshot, c.options);
  const GaugeParameterization g = makeGauge(c.options.gauge, c.snapshot, ne.keyframes);
  const Eigen::MatrixXd Su = Eigen::MatrixXd(reduceSystem(ne.S, g));
  const Eigen::MatrixXd S = Su.selfadjointView<Eigen::Upper>();
  const Eigen::MatrixXd U = S.llt().matrixU();
  ceres::Problem problem;
  std::vector<std::vector<double>> x;
  std::vector<double*> blocks;
  std::vector<int> kf;
  for (std::size_t a = 0; a < ne.keyframes.size(); ++a)
    if (g.dimOf(static_cast<int>(a)) == 6) {
      x.emplace_back(6, 0.0);
      kf.push_back(ne.keyframes[a]);
    }
  for (auto& v : x) blocks.push_back(v.data());
  problem.AddResidualBlock(new ReducedCost(U), nullptr, blocks);
  timeCeresCovariance(state, c, problem, blocks, kf);
}

BENCHMARK(BM_Dbacov)->Arg(0)->Arg(1)->Unit(benchmark::kMillisecond);
BENCHMARK(BM_DenseReduced)->Arg(0)->Arg(1)->Unit(benchmark::kMillisecond);
BENCHMARK(BM_CeresReduced)->Arg(0)->Arg(1)->Unit(benchmark::kMillisecond);
BENCHMARK(BM_CeresFull)->Arg(0)->Arg(1)->Unit(benchmark::kMillisecond)->Iterations(1);

}  // namespace
}  // namespace dbacov::bench

BENCHMARK_MAIN();
