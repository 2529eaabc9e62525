// `dba-evaluate`: consistency of pose covariances against ground truth (conventions §7): NEES of
// keyframe poses and of consecutive relative poses, ANEES with the two-sided 95 % chi-square
// region, per-axis 1/2/3-sigma coverage, Spearman correlation between predicted uncertainty and
// actual error, and the calibration of the covariance scale (variance inflation factor and the
// `--weight-scale` that applies it).
//
// Two modes:
//   files        covariance outputs of `dba-covariance` (--csv [--relative-csv], or a pose rawlog
//                from -o) against a ground-truth trajectory (TUM, or EuRoC's ground-truth CSV);
//   Monte Carlo  --monte-carlo N: N noise draws of one simulated scenario (simul-dba's options and
//                --config), each solved and evaluated in-process.
#pragma once

#include <optional>
#include <ostream>
#include <string>
#include <vector>

#include "dbacov/app/scenario_options.h"
#include "dbacov/app/self_calibration_options.h"

namespace dbacov::app {

/// The options of dba-evaluate (its --help says what each does).
struct EvaluateOptions {
  std::string csv, relative_csv, rawlog, rawlog_label, gt,
      gt_format = "auto", image_times, align = "none", pairs = "consecutive", json, samples_csv;
  std::vector<double> body_to_camera;
  double time_tolerance = 1e-3, max_gap = 0.1;
  int monte_carlo = 0, first_run = 0, calibration_runs = 0;
  bool calibrate = false, quiet = false;
  std::optional<double> inflation;
  ScenarioOptions scenario;
  SelfCalibrationAppOptions self_calibration;  ///< Monte Carlo: self-calibrated covariances
};

/// Runs the app on parsed options (the report to `out`, messages to `err`). Returns 0 on success,
/// 1 when an input or output failed (or nothing could be evaluated), 2 on invalid options.
int runEvaluate(const EvaluateOptions& options, std::ostream& out, std::ostream& err);

/// Runs the app; returns 0 on success, 1 when an input or output failed (or nothing could be
/// evaluated), 2 on bad usage.
int runEvaluateApp(int argc, const char* const* argv, std::ostream& out, std::ostream& err);

}  // namespace dbacov::app
