// A covariance computed outside the engine's factorization (the self-calibration's noise model)
// in DbaCovariance's query API. Internal: the engine's own stages and the study hand it over.
#pragma once

#include <memory>

#include <Eigen/Core>

#include "dbacov/core/covariance.h"
#include "dbacov/core/linearization.h"
#include "dbacov/core/summary.h"

namespace dbacov::detail {

struct GivenModel {
  /// When set, Σ in the gauge's reduced coordinates (K×K, K = free pose DoF) replaces S⁻¹.
  /// Linearization and gauge are still those of the snapshot.
  std::shared_ptr<const Eigen::MatrixXd> reduced_covariance;
  /// When set, the linearization of this snapshot under these DbaOptions (without depth terms),
  /// which the constructor then does not repeat. Ignored with depth_variances (those need the
  /// depth terms).
  std::shared_ptr<const DbaNormalEquations> linearization;
  /// What summary().self_calibration reports.
  SelfCalibrationSummary calibration;

  DbaCovariance build(const Snapshot& snapshot, const DbaOptions& options,
                      const CovarianceOptions& covariance) const {
    return DbaCovariance(snapshot, options, covariance, this);
  }
};

}  // namespace dbacov::detail
