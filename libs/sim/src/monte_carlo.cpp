#include "dbacov/sim/monte_carlo.h"

#include <optional>

#include "dbacov/core/covariance.h"
#include "dbacov/core/errors.h"
#include "dbacov/core/pipeline.h"

namespace dbacov::sim {

void EvaluationSamples::append(const EvaluationSamples& o) {
  absolute.insert(absolute.end(), o.absolute.begin(), o.absolute.end());
  relative.insert(relative.end(), o.relative.begin(), o.relative.end());
}

CovarianceFunction pipelineCovariance(const SelfCalibrationOptions* self_calibration) {
  std::optional<SelfCalibrationOptions> c;
  if (self_calibration) c = *self_calibration;
  return [c](const Snapshot& s, const DbaOptions& options) {
    PipelineOptions p;
    p.engine = options;
    p.stated_model = !c;
    if (c) p.calibration = *c;
    return std::move(*computeCovariance(s, p).cov);
  };
}

EvaluationSamples evaluateSnapshot(const SimulatedSnapshot& sim, const DbaOptions& options,
                                   std::int64_t run, PairSelection pairs,
                                   const SelfCalibrationOptions* self_calibration) {
  return evaluateSnapshot(sim, options, run, pairs, pipelineCovariance(self_calibration));
}

EvaluationSamples evaluateSnapshot(const SimulatedSnapshot& sim, const DbaOptions& options,
                                   std::int64_t run, PairSelection pairs,
                                   const CovarianceFunction& covariance) {
  const Snapshot& s = sim.snapshot;
  // The covariances' numerical errors do not name their snapshot (the callers do): name the run's.
  const DbaCovariance cov = [&]() {
    try {
      return covariance(s, options);
    } catch (const NumericalError& e) {
      throw NumericalError(s.name() + ": " + e.what(), e.keyframes());
    }
  }();
  const std::string prefix = "s" + std::to_string(s.label()) + "/";
  EvaluationSamples out;
  for (int k : cov.keyframes()) {
    NeesSample x = makeSample(run, prefix + "kf" + std::to_string(k),
                              poseError(s.T_wc(k), sim.T_wc_true[k]), cov.marginal(k));
    if (x.nees.dof > 0) out.absolute.push_back(std::move(x));
  }
  std::vector<std::pair<int, int>> list;
  if (pairs == PairSelection::CoVisible) {
    list = s.relativePairs();
  } else {
    const std::vector<int>& kf = cov.keyframes();
    for (std::size_t i = 0; i + 1 < kf.size(); ++i) list.emplace_back(kf[i], kf[i + 1]);
  }
  for (const auto& [a, b] : list) {
    const Eigen::Isometry3d Z_est = s.T_wc(a).inverse() * s.T_wc(b);
    const Eigen::Isometry3d Z_true = sim.T_wc_true[a].inverse() * sim.T_wc_true[b];
    NeesSample x = makeSample(run, prefix + std::to_string(a) + "-" + std::to_string(b),
                              poseError(Z_est, Z_true), cov.relative(a, b));
    if (x.nees.dof > 0) out.relative.push_back(std::move(x));
  }
  return out;
}

MonteCarloResult runMonteCarlo(const Scenario& scenario, int first_run, int runs,
                               const DbaOptions& options, PairSelection pairs,
                               const std::function<void(int, int)>& progress,
                               const SelfCalibrationOptions* self_calibration) {
  return runMonteCarlo(scenario, first_run, runs, options, pairs, progress,
                       pipelineCovariance(self_calibration));
}

MonteCarloResult runMonteCarlo(const Scenario& scenario, int first_run, int runs,
                               const DbaOptions& options, PairSelection pairs,
                               const std::function<void(int, int)>& progress,
                               const CovarianceFunction& covariance) {
  if (scenario.config().gauge_hold == GaugeHold::Estimate)
    throw std::invalid_argument(kMonteCarloNeedsTruthGauge);
  MonteCarloResult r;
  const int S = scenario.numSnapshots(), total = runs * S;
  int done = 0;
  for (int run = first_run; run < first_run + runs; ++run)
    for (int s = 0; s < S; ++s) {
      const SimulatedSnapshot sim = scenario.simulate(s, static_cast<std::uint64_t>(run));
      r.solver.push_back(sim.solver);
      if (scenario.config().solve && !sim.solver.converged()) ++r.not_converged;
      r.samples.append(evaluateSnapshot(sim, options, static_cast<std::int64_t>(run) * S + s, pairs,
                                        covariance));
      if (progress) progress(++done, total);
    }
  return r;
}

}  // namespace dbacov::sim
