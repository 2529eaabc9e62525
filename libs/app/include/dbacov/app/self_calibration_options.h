// The noise-model settings of the apps, shared by dba-covariance and dba-evaluate: the
// self-calibrated covariance by default (self_calibration.h: the per-edge flow-error field and
// the depths' second-order term, estimated from the snapshot's own residuals), or with
// --stated-model the noise the snapshot claims (confidences × weight scale);
// --self-calibrate-nodes,
// --self-calibrate-depth-noise, --edge-csv, --converge, --converge-iterations.
#pragma once

#include <string>

#include "dbacov/core/pipeline.h"

namespace dbacov::app {

struct SelfCalibrationAppOptions {
  /// --stated-model: the covariance of the noise model as the snapshot states it (the network's
  /// confidences times the weight scale) instead of the self-calibrated one.
  bool stated_model = false;
  int nodes = -1;  ///< --self-calibrate-nodes (the field's spline; -1 = the core's default)
  std::string depth_noise;  ///< --self-calibrate-depth-noise on|off (empty = the core's default)
  std::string edge_csv;     ///< --edge-csv (dba-covariance only)
  bool converge = false;    ///< --converge (dba-covariance only)
  /// --converge-iterations: the solve's iteration cap (0 = kOptimumSolveIterations, dba_solver.h)
  int converge_iterations = 0;
  /// Whether covariances are self-calibrated (the default).
  bool calibrated() const { return !stated_model; }
  /// The core options; throws std::invalid_argument for a calibration option given with
  /// --stated-model (it would be ignored) or out of its domain.
  SelfCalibrationOptions options() const;
  /// The pipeline's options (computeCovariance) for these settings.
  PipelineOptions pipeline(const DbaOptions& engine, const CovarianceOptions& solver) const;
  /// The solver of --converge: DbaSolverOptions with converge_iterations (or the default cap).
  DbaSolverOptions convergeSolver() const;
};

/// "self-calibrated" or "stated": the name of the noise model an output holds (the CSV tables'
/// noise_model column).
inline const char* noiseModelName(bool calibrated) {
  return calibrated ? "self-calibrated" : "stated";
}

}  // namespace dbacov::app
