// Self-calibration in the apps (self_calibration.h): the options, one covariance per snapshot,
// the per-edge CSV and the summary line. Shared by dba-covariance and dba-evaluate.
#pragma once

#include <map>
#include <memory>
#include <mutex>
#include <optional>
#include <ostream>
#include <string>
#include <vector>

#include <CLI/CLI.hpp>

#include "dbacov/app/self_calibration_options.h"
#include "dbacov/core/covariance.h"
#include "dbacov/core/options.h"
#include "dbacov/core/self_calibration.h"
#include "dbacov/core/snapshot.h"

namespace dbacov::app::detail {

using SelfCalibrationCli = SelfCalibrationAppOptions;

/// Adds --stated-model, --self-calibrate-nodes, --self-calibrate-depth-noise and, with `outputs`,
/// --edge-csv, --converge and --converge-iterations.
void addSelfCalibrationOptions(CLI::App& cli, SelfCalibrationCli& o, bool outputs);

/// One run's self-calibration: computes each snapshot's covariance (thread-safe), collects the
/// per-edge rows and the numbers of the summary line.
class SelfCalibrationRun {
 public:
  explicit SelfCalibrationRun(const SelfCalibrationCli& cli);

  /// The covariance of one snapshot (computeCovariance): with --converge the snapshot's DBA is
  /// solved first (its state is overwritten); self-calibrated unless --stated-model. A warning
  /// is recorded when the state is far from its optimum or the solve did not converge.
  std::unique_ptr<DbaCovariance> covariance(Snapshot& s, const DbaOptions& o,
                                            const CovarianceOptions& solver);
  /// The warnings so far, in input order.
  std::vector<std::string> warnings() const;
  /// Writes --edge-csv (snapshots in input order) atomically. No-op without --edge-csv.
  void commit() const;
  /// "noise model: self-calibrated from the residuals (...): 12 snapshots, edge inflation median
  /// 3.1 (0.9 to 40), ..." or "noise model: stated (...)", after --converge's counts.
  std::string summaryLine() const;

 private:
  SelfCalibrationCli cli_;
  SelfCalibrationOptions options_;
  mutable std::mutex mutex_;
  std::map<std::int64_t, std::string> rows_;  ///< per snapshot index, CSV rows
  std::vector<double> inflations_, scales_, steps_, gradients_;
  std::vector<double> field_sigmas_, fine_sigmas_;  ///< nuisance: σ_a, σ_f per snapshot
  std::vector<double> depth_shares_;    ///< what the depths' term adds to the trace, per snapshot
  std::vector<double> kurtoses_;        ///< the residuals' excess kurtosis it used, per snapshot
  std::vector<double> cross_kurtoses_;  ///< the flow axes' joint fourth cumulant, per snapshot
  std::vector<double> sensor_scales_;   ///< RGB-D: the readings' variance factor, per snapshot
  std::map<std::int64_t, std::string> warnings_;
  /// --converge at the calibrated weights: snapshots re-solved, their solves and factors.
  int reweighted_ = 0;
  std::vector<double> solves_, sensor_factors_, stereo_factors_;
  int snapshots_ = 0, unreliable_ = 0, converged_ = 0;
  int poor_fits_ = 0;                  ///< snapshots whose noise-model fit check failed
  std::vector<double> scale_spreads_;  ///< the edges' white-scale spread, per snapshot
  double seconds_ = 0;
};

}  // namespace dbacov::app::detail
