// Scalar uncertainty criteria of a 6×6 tangent covariance (conventions §5). Computed on the tangent
// Σ of conventions §3, never on MRPT's yaw/pitch/roll covariance (whose determinant depends on the
// pitch).
#pragma once

#include "dbacov/core/se3.h"

namespace dbacov {

struct UncertaintyCriteria {
  double log10_det = 0;        ///< log10 det Σ (−inf when Σ is singular, e.g. a fixed keyframe)
  double d_opt = 0;            ///< det(Σ)^(1/6)
  double a_opt = 0;            ///< trace(Σ)/6
  double e_opt = 0;            ///< largest eigenvalue of Σ
  double log10_det_rot = 0;    ///< log10 det of the rotation block Σ[3:6, 3:6]
  double log10_det_trans = 0;  ///< log10 det of the translation block Σ[0:3, 0:3]
};

/// Eigenvalues at or below 1e-14 × the largest eigenvalue (or exactly zero) count as zero, so a
/// covariance that a hard gauge makes singular reports log10 det = −inf and D-opt = 0 instead of
/// the logarithm of round-off. Precondition: Σ symmetric positive semi-definite.
UncertaintyCriteria computeCriteria(const Matrix6d& Sigma);

}  // namespace dbacov
