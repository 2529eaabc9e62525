#include "dbacov/sim/monte_carlo.h"

#include "dbacov/core/covariance.h"
#include "dbacov/core/errors.h"
#include "dbacov/core/pipeline.h"
#include "dbacov/sim/bootstrap.h"

namespace dbacov::sim {

void EvaluationSamples::append(const EvaluationSamples& o) {
  absolute.insert(absolute.end(), o.absolute.begin(), o.absolute.end());
  relative.insert(relative.end(), o.relative.begin(), o.relative.end());
}

EvaluationSamples evaluateSnapshot(const SimulatedSnapshot& sim, const DbaOptions& options,
                                   std::int64_t run, PairSelection pairs,
                                   const SelfCalibrationOptions* self_calibration) {
  const Snapshot& s = sim.snapshot;
  // The covariances' numerical errors do not name their snapshot (the callers do): name the run's.
  // The product's pipeline (computeCovariance) for its own method; a study method (bootstrap,
  // vce, ...) through runSelfCalibration.
  const auto covariance = [&]() {
    try {
      if (!self_calibration || self_calibration->method == SelfCalibrationMethod::Nuisance) {
        PipelineOptions p;
        p.engine = options;
        p.stated_model = !self_calibration;
        if (self_calibration) p.calibration = *self_calibration;
        return std::move(*computeCovariance(s, p).cov);
      }
      return selfCalibratedCovariance(s, options, {},
                                      runSelfCalibration(s, options, *self_calibration));
    } catch (const NumericalError& e) {
      throw NumericalError(s.name() + ": " + e.what(), e.keyframes());
    }
  };
  const DbaCovariance cov = covariance();
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
                                        self_calibration));
      if (progress) progress(++done, total);
    }
  return r;
}

}  // namespace dbacov::sim
