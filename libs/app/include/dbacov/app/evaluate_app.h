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

#include <ostream>

namespace dbacov::app {

/// Runs the app; returns 0 on success, 1 when an input or output failed (or nothing could be
/// evaluated), 2 on bad usage.
int runEvaluateApp(int argc, const char* const* argv, std::ostream& out, std::ostream& err);

}  // namespace dbacov::app
