// Monte Carlo consistency runs of a simulated scenario (conventions §7): N noise draws of one
// scenario, each snapshot solved and its covariances computed in-process, NEES against the truth.
//
// Samples of one solved snapshot:
//   absolute  every graph keyframe with a non-singular marginal: e = Log(T_est⁻¹ T_true) and the
//             6×6 tangent marginal. Meaningful because the scenario holds the gauge at the truth
//             (scenario.h); hard-fixed keyframes have no sample (DoF 0), the minimal gauge's scale
//             keyframe has 5 DoF.
//   relative  every pair (a, b) of consecutive graph keyframes (PairSelection::Consecutive) or
//             every co-visible pair (CoVisible, Snapshot::relativePairs): Z = T_a⁻¹ T_b,
//             e = Log(Z_est⁻¹ Z_true) and the covariance of conventions §5 from the 12×12 joint
//             marginal. A pair of two hard-fixed keyframes has no sample.
// Labels: NeesSample::run = run · numSnapshots + snapshot (noise is independent across both),
// group = "s<snapshot>/kf<k>" or "s<snapshot>/<a>-<b>" (the same quantity across runs).
#pragma once

#include <cstdint>
#include <functional>
#include <string>
#include <vector>

#include "dbacov/core/covariance.h"
#include "dbacov/core/dba_solver.h"
#include "dbacov/core/options.h"
#include "dbacov/core/self_calibration.h"
#include "dbacov/sim/consistency.h"
#include "dbacov/sim/scenario.h"

namespace dbacov::sim {

/// Why runMonteCarlo refuses GaugeHold::Estimate (also dba-evaluate's usage error).
inline constexpr const char* kMonteCarloNeedsTruthGauge =
    "--gauge-hold estimate (gauge.hold): the Monte Carlo compares every snapshot with the ground "
    "truth, which needs each snapshot's gauge held at the truth; for whole-sequence studies with "
    "the gauge held at the previous estimates run simul-dba and compare the sequence's result "
    "(scripts/fusion_study.py --gauge-hold estimate)";

enum class PairSelection { Consecutive, CoVisible };

struct EvaluationSamples {
  std::vector<NeesSample> absolute, relative;
  void append(const EvaluationSamples& other);
};

/// How a snapshot's covariance is computed for the evaluation.
using CovarianceFunction = std::function<DbaCovariance(const Snapshot&, const DbaOptions&)>;

/// The product's pipeline (computeCovariance): without `self_calibration` the stated model,
/// with it the self-calibrated one with these options (the study's bootstrap passes its own
/// CovarianceFunction). The options are copied.
CovarianceFunction pipelineCovariance(const SelfCalibrationOptions* self_calibration);

/// The samples of one solved snapshot, covariances computed with `options` (normally the
/// scenario's engineOptions(); the weight scale may differ to study mis-scaled covariances).
/// With `self_calibration`, the covariances are self-calibrated from the residuals
/// (self_calibration.h) instead.
EvaluationSamples evaluateSnapshot(const SimulatedSnapshot& snapshot, const DbaOptions& options,
                                   std::int64_t run,
                                   PairSelection pairs = PairSelection::Consecutive,
                                   const SelfCalibrationOptions* self_calibration = nullptr);
/// The same with covariances from `covariance`.
EvaluationSamples evaluateSnapshot(const SimulatedSnapshot& snapshot, const DbaOptions& options,
                                   std::int64_t run, PairSelection pairs,
                                   const CovarianceFunction& covariance);

struct MonteCarloResult {
  EvaluationSamples samples;
  std::vector<DbaSolverSummary> solver;  ///< one per (run, snapshot)
  int not_converged = 0;                 ///< solves that ended without convergence
};

/// Runs [first_run, first_run + runs) of every snapshot of the scenario. `progress(done, total)`
/// is called after each (run, snapshot) when given. Throws NumericalError from a failed solve or
/// covariance.
MonteCarloResult runMonteCarlo(const Scenario& scenario, int first_run, int runs,
                               const DbaOptions& options,
                               PairSelection pairs = PairSelection::Consecutive,
                               const std::function<void(int, int)>& progress = {},
                               const SelfCalibrationOptions* self_calibration = nullptr);
/// The same with covariances from `covariance`.
MonteCarloResult runMonteCarlo(const Scenario& scenario, int first_run, int runs,
                               const DbaOptions& options, PairSelection pairs,
                               const std::function<void(int, int)>& progress,
                               const CovarianceFunction& covariance);

}  // namespace dbacov::sim
