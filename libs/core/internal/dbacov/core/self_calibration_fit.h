// The self-calibration's fitted model (self_calibration.h) as the engine hands it to
// DbaCovariance, and the white-noise variance components alone. Internal: the engine, the study
// (which rescales the fit) and the stage tests.
#pragma once

#include <memory>

#include <Eigen/Core>

#include "dbacov/core/linearization.h"
#include "dbacov/core/self_calibration.h"

namespace dbacov {

struct SelfCalibrationFit {
  /// The covariance of the fitted noise model in the gauge's reduced coordinates (K × K), without
  /// the depths' term (selfCalibratedCovariance adds it).
  std::shared_ptr<const Eigen::MatrixXd> reduced_covariance;
  /// The linearization it was computed with (the snapshot's own, at its weights), so that
  /// selfCalibratedCovariance of the same snapshot does not linearize again.
  std::shared_ptr<const DbaNormalEquations> linearization;
};

/// White-noise variance components only (no field, no covariance, no clamping): per edge q / ρ
/// (vce_scale) and ρ (redundancy) at the snapshot's weights, the sensor readings' pooled scale
/// and redundancy. The calibrated solve's ratios (calibrated_solve.h).
SelfCalibration varianceComponents(const Snapshot& snapshot, const DbaOptions& options);

}  // namespace dbacov
