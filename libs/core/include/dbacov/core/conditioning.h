// Numerical singularity of a marginal covariance, told apart from a gauge-fixed keyframe
// (both show log10_det = -inf). A gauge keyframe has fewer than 6 free DoF (DbaCovariance::freeDof)
// and exact zeros in its covariance; a free keyframe whose covariance spans more than
// kMaxConditionNumber between its largest and smallest eigenvalue is not determined in double
// precision (e.g. inverse depths around 1e-6 or focal lengths scaled by 1e-5): its criteria would
// read log10 det = -inf and d_opt = 0, as if the gauge fixed it. DbaCovariance refuses such a
// snapshot (NumericalError naming the keyframes and the condition number).
#pragma once

#include "dbacov/core/se3.h"

namespace dbacov {

/// Above this ratio λmax/λmin the covariance is numerically singular (the same threshold below
/// which criteria.cpp counts an eigenvalue as zero).
constexpr double kMaxConditionNumber = 1e14;

/// λmax / λmin over the `free_dof` largest eigenvalues of the symmetric `Sigma` (its free
/// subspace); 1 when free_dof <= 0, +inf when one of them is not positive or not finite.
double freeConditionNumber(const Matrix6d& Sigma, int free_dof);

}  // namespace dbacov
