// The self-calibration settings of the apps (--self-calibrate, --self-calibrate-method,
// --self-calibrate-iterations, --self-calibrate-nodes, --self-calibrate-replicates,
// --self-calibrate-resampling, --edge-csv, --converge, --converge-iterations), shared by
// dba-covariance and dba-evaluate.
#pragma once

#include <string>

#include "dbacov/core/self_calibration.h"
#include "dbacov/sim/dba_solver.h"

namespace dbacov::app {

struct SelfCalibrationAppOptions {
  bool enabled = false;     ///< --self-calibrate (or implied by --self-calibrate-method)
  std::string method;       ///< --self-calibrate-method (default: the core's default)
  int iterations = 0;       ///< --self-calibrate-iterations (0 = the core's default)
  int nodes = -1;           ///< --self-calibrate-nodes (nuisance's field; -1 = the core's default)
  int replicates = -1;      ///< --self-calibrate-replicates (bootstrap; -1 = the core's default)
  std::string resampling;   ///< --self-calibrate-resampling (bootstrap; empty = the core's default)
  std::string depth_noise;  ///< --self-calibrate-depth-noise on|off (empty = the core's default)
  std::string edge_csv;     ///< --edge-csv (dba-covariance only)
  bool converge = false;    ///< --converge (dba-covariance only)
  /// --converge-iterations: the solve's iteration cap (0 = kOptimumSolveIterations, dba_solver.h)
  int converge_iterations = 0;
  /// The core options; throws std::invalid_argument for an unknown method, or nodes given for
  /// another method than nuisance or bootstrap, or replicates for another than bootstrap, or
  /// resampling for another than bootstrap, or depth noise "on" for the bootstrap (which
  /// re-solves instead).
  SelfCalibrationOptions options() const;
  /// The solver of --converge: DbaSolverOptions with converge_iterations (or the default cap).
  DbaSolverOptions convergeSolver() const;
};

}  // namespace dbacov::app
