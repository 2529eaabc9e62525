// Private to dbacov_app: values of dba-evaluate's inputs that would be scored silently wrong
// (each refused naming file and line): ground truth with two different poses at one time (the first
// used to win), covariances with negative variances (scored with fewer DoF and called "inside") or
// entries so large that the NEES collapses (1e300: DoF 1, ANEES 0).
#pragma once

#include <string>
#include <utility>
#include <vector>

#include <Eigen/Geometry>

#include "dbacov/core/se3.h"

namespace dbacov::app::detail {

/// Largest covariance entry accepted (|v|): far beyond any σ a pose can have.
constexpr double kMaxCovarianceEntry = 1e100;

/// InputError "<where>: ..." for a negative variance, an entry beyond kMaxCovarianceEntry, or a
/// matrix that is not positive semidefinite (smallest eigenvalue below -1e-9 of the largest).
void checkCovarianceValues(const Matrix6d& S, const std::string& where);

/// `rows` sorted by time: InputError naming `path` and the time when two rows share a time with
/// different poses (more than 1e-9 apart in any entry of the 4x4 matrix).
void checkGroundTruthTimes(const std::string& path,
                           const std::vector<std::pair<double, Eigen::Isometry3d>>& rows);

}  // namespace dbacov::app::detail
