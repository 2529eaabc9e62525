// The one conversion between dbacov's pose convention (conventions §3) and MRPT's (conventions §6).
//
// dbacov:  T_wc with right perturbation T_wc·Exp(ξ), ξ = [ρ; φ] (body frame).
// MRPT:    CPose3DPDFGaussian over [x y z yaw pitch roll]: global position plus Z-Y-X Euler angles
//          (R = Rz(yaw)·Ry(pitch)·Rx(roll)), with additive Gaussian noise on those six numbers.
// First order: δposition = R_wc ρ and δ[yaw pitch roll] = E⁻¹ φ, with
//   E⁻¹ = [[0, sin r / cos p, cos r / cos p],
//          [0, cos r,        −sin r       ],
//          [1, sin r·tan p,   cos r·tan p ]],
// so Σ_ypr = J Σ Jᵀ with J = blockdiag(R_wc, E⁻¹). The map is singular at pitch = ±90° (gimbal
// lock), where yaw and roll are not separable: the conversion refuses |cos p| < 1e-9.
#pragma once

#include <mrpt/poses/CPose3D.h>
#include <mrpt/poses/CPose3DPDFGaussian.h>
#include <Eigen/Geometry>

#include "dbacov/core/se3.h"

namespace dbacov::mrpt_bridge {

mrpt::poses::CPose3D toCPose3D(const Eigen::Isometry3d& T);
Eigen::Isometry3d fromCPose3D(const mrpt::poses::CPose3D& pose);

/// J = blockdiag(R_wc, E⁻¹) at the pose T_wc (see above). Throws std::domain_error at gimbal lock.
Matrix6d tangentToYprJacobian(const Eigen::Isometry3d& T_wc);

/// CPose3DPDFGaussian with mean T_wc and covariance J Σ Jᵀ of the tangent covariance Σ.
mrpt::poses::CPose3DPDFGaussian toPoseGaussian(const Eigen::Isometry3d& T_wc,
                                               const Matrix6d& Sigma_tangent);

/// The inverse: the tangent covariance J⁻¹ Σ_ypr J⁻ᵀ of an MRPT [x y z yaw pitch roll] covariance
/// at T_wc (what a pose rawlog read back holds). Throws std::domain_error at gimbal lock.
Matrix6d yprToTangentCovariance(const Eigen::Isometry3d& T_wc, const Matrix6d& Sigma_ypr);

}  // namespace dbacov::mrpt_bridge
