// `dba-covariance`: marginal pose covariances of DBA snapshots (conventions §2–§5).
//
// The run is four stages: parse (flags → CovarianceAppOptions), sinks (one per requested output),
// pipeline (snapshots read in order, computed in parallel, handed to the sinks in order) and
// commit (every output appears at the end, or none). runCovariance() takes the options as a struct
// (what tests and the Python module call); runCovarianceApp() parses a command line into it.
#pragma once

#include <optional>
#include <ostream>
#include <string>
#include <vector>

#include "dbacov/app/outputs.h"
#include "dbacov/app/run_summary.h"
#include "dbacov/app/self_calibration_options.h"
#include "dbacov/app/visual_outputs.h"
#include "dbacov/core/options.h"

namespace dbacov::app {

struct CovarianceAppOptions {
  std::vector<std::string> inputs;  ///< .npz files, directories of them, snapshot rawlogs
  std::string csv_path, relative_csv_path, depth_sigma_dir, rawlog_path, graph_prefix;
  EmitMode emit = EmitMode::Latest;
  std::string label;  ///< --label; empty: the noise model's default (rawlogLabel)
  GraphEdges graph_edges = GraphEdges::Covisibility;  ///< --graph-edges (sequence_graph.h)
  std::optional<double> fps;     ///< keyframe times = start + tstamp / fps without 'timestamps_s'
  double start_time = 0;         ///< --start-time: time of tstamp 0 with --fps
  DbaOptionOverrides engine;     ///< --preset, --weight-scale, --gauge, ... (core/options.h)
  CovarianceOptions covariance;  ///< --solver, --ordering; depth variances set by the outputs
  SceneOutputOptions scene;      ///< --scene, --snapshot, ...
  std::string plots_dir;         ///< --plots
  SelfCalibrationAppOptions self_calibration;  ///< --stated-model, --edge-csv, --converge, ...
  std::size_t threads = 0;                     ///< 0 = all cores
  FailurePolicy policy = FailurePolicy::KeepGoing;
  bool quiet = false;

  /// True when any output is requested.
  bool anyOutput() const;
  /// The rawlog observations' sensorLabel: --label, or DBA_COVARIANCE_CALIBRATED for the
  /// self-calibrated covariances and DBA_COVARIANCE for --stated-model.
  std::string rawlogLabel() const {
    if (!label.empty()) return label;
    return self_calibration.calibrated() ? "DBA_COVARIANCE_CALIBRATED" : "DBA_COVARIANCE";
  }
};

/// Runs the app on parsed options: messages and the summary line go to `err`. Returns 0 on
/// success, 1 when any input or output failed (after processing the rest; none written under
/// FailFast), 2 when the options are invalid.
int runCovariance(const CovarianceAppOptions& options, std::ostream& err);

/// Runs the app with command-line arguments (argv[0] is the program name). Returns the exit code:
/// 0 success, 1 when any input or output failed (after processing the rest), 2 on bad usage.
/// Messages go to `err`, `--help` to `out`.
int runCovarianceApp(int argc, const char* const* argv, std::ostream& out, std::ostream& err);

}  // namespace dbacov::app
