// The one path from a snapshot to its covariance that dba-covariance, dba-evaluate's Monte Carlo
// and `import dbacov` all take: optionally solve the DBA to the optimum of the snapshot's own
// factors, then the covariance of the self-calibrated noise model (the default) or of the noise
// model the snapshot states (its confidences times the weight scale).
//
// Why self-calibrated by default: the network's confidences are relative weights at a solver
// scale (DROID's 0.001), not variances; the residuals at DBA's optimum say how large and how
// smooth the flow errors really are (self_calibration.h). The calibration assumes that the state
// is at (or near) the optimum of the snapshot's own factors, that errors are independent across
// edges, and that the linearization holds; it cannot see an error field that looks like motion
// (the poses absorb it) or targets that co-adapt with the estimate.
#pragma once

#include <memory>
#include <optional>

#include "dbacov/core/calibrated_solve.h"
#include "dbacov/core/covariance.h"
#include "dbacov/core/dba_solver.h"
#include "dbacov/core/options.h"
#include "dbacov/core/self_calibration.h"
#include "dbacov/core/snapshot.h"

namespace dbacov {

struct PipelineOptions {
  DbaOptions engine;         ///< preset, weight scale, gauge, filters
  CovarianceOptions solver;  ///< sparse or dense, ordering, depth variances
  /// The covariance of the stated noise model instead of the self-calibrated one.
  bool stated_model = false;
  SelfCalibrationOptions calibration;  ///< the self-calibration (unless stated_model)
  /// Solve the snapshot's DBA first (its state is overwritten). Self-calibrated, the factors on
  /// the depths alone (stereo edges, RGB-D readings) are re-weighted at their calibrated variance
  /// ratio to the flow and the DBA re-solved until it settles (calibrated_solve.h).
  bool converge = false;
  DbaSolverOptions converge_solver{kOptimumSolveIterations};
  /// Throws std::invalid_argument naming the bad field.
  void validate() const;
};

struct PipelineResult {
  std::unique_ptr<DbaCovariance> cov;
  DbaOptions options;  ///< the engine options of `cov` (α divided after a calibrated solve)
  std::optional<SelfCalibration> calibration;  ///< unless stated_model
  std::optional<DbaSolverSummary> solve;       ///< with converge: the (last) solve
  std::optional<CalibratedSolve> reweighted;   ///< with converge, self-calibrated
};

/// Runs the pipeline on `snapshot` (solved in place with converge). Throws InputError for an
/// invalid snapshot, std::invalid_argument for invalid options and NumericalError (naming no
/// snapshot: callers prefix Snapshot::name()) when the reduced system is not positive definite.
PipelineResult computeCovariance(Snapshot& snapshot, const PipelineOptions& options);
/// The same without converge (std::invalid_argument otherwise): the snapshot is not changed.
PipelineResult computeCovariance(const Snapshot& snapshot, const PipelineOptions& options);

}  // namespace dbacov
