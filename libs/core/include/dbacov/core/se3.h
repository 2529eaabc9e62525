// The one convention file for poses (conventions §3).
//
// Frames:       T_wc maps camera coordinates to world coordinates (camera-to-world); T_cw =
// T_wc^-1. Perturbation: on the right, T_true = T · Exp(ξ). Tangent:      ξ = [ρ; φ] ∈ R^6,
// translation first, rotation second, with the true SE(3)
//               exponential Exp(ξ) = [Exp_SO3(φ), V(φ) ρ; 0, 1] (V = left Jacobian of SO(3)).
//               This is MRPT's graph-slam edge convention ([t; ω], right perturbation).
// Adjoint:      T Exp(ξ) T^-1 = Exp(Ad(T) ξ),  Ad(T) = [R, [t]× R; 0, R].
//
// All 6×6 pose covariances in the library are covariances of ξ in this tangent.
#pragma once

#include <Eigen/Core>
#include <Eigen/Geometry>

namespace dbacov {

using Vector6d = Eigen::Matrix<double, 6, 1>;
using Matrix6d = Eigen::Matrix<double, 6, 6>;
using Matrix12d = Eigen::Matrix<double, 12, 12>;

/// Skew-symmetric matrix: hat(a) b = a × b.
inline Eigen::Matrix3d hat(const Eigen::Vector3d& a) {
  Eigen::Matrix3d m;
  m << 0, -a.z(), a.y(), a.z(), 0, -a.x(), -a.y(), a.x(), 0;
  return m;
}

/// SO(3) exponential of a rotation vector (Rodrigues, with a Taylor branch near 0).
Eigen::Matrix3d expSO3(const Eigen::Vector3d& phi);
/// SO(3) logarithm; returns φ with |φ| <= π. Precondition: R is a rotation matrix.
Eigen::Vector3d logSO3(const Eigen::Matrix3d& R);
/// Left Jacobian of SO(3): V(φ) = Σ_k hat(φ)^k / (k+1)!.
Eigen::Matrix3d leftJacobianSO3(const Eigen::Vector3d& phi);
/// Inverse of leftJacobianSO3.
Eigen::Matrix3d leftJacobianInvSO3(const Eigen::Vector3d& phi);

/// SE(3) exponential of ξ = [ρ; φ].
Eigen::Isometry3d expSE3(const Vector6d& xi);
/// SE(3) logarithm, ξ = [ρ; φ] with Exp(ξ) = T. Precondition: T's linear part is a rotation.
Vector6d logSE3(const Eigen::Isometry3d& T);
/// Adjoint in the [ρ; φ] layout: Exp(Ad(T) ξ) = T Exp(ξ) T^-1.
Matrix6d adjoint(const Eigen::Isometry3d& T);

/// Pose from [tx ty tz qx qy qz qw] (lietorch / TUM order). The quaternion is normalized; its norm
/// must be positive (callers validate first).
Eigen::Isometry3d poseFromTQ(const double* v);
/// [tx ty tz qx qy qz qw] of T, with qw >= 0.
Eigen::Matrix<double, 7, 1> poseToTQ(const Eigen::Isometry3d& T);

/// ad(ξ) = [hat(φ), hat(ρ); 0, hat(φ)]: the adjoint of the Lie algebra in the [ρ; φ] layout.
Matrix6d adSE3(const Vector6d& xi);
/// Right Jacobian of SE(3): Exp(ξ + δ) ≈ Exp(ξ) Exp(Jr(ξ) δ); Jr(ξ) = Σ_k (−ad ξ)^k / (k+1)!
/// (series to machine precision). Its inverse gives Log(Exp(ξ) Exp(δ)) ≈ ξ + Jr(ξ)⁻¹ δ.
Matrix6d rightJacobianSE3(const Vector6d& xi);

/// Relative pose Z = T_a^-1 T_b and the covariance of its tangent (conventions §5):
/// δz ≈ δb − Ad(Z^-1) δa, so Σ_z = [−Ad(Z^-1)  I] Σ_ab [−Ad(Z^-1)  I]^T, with Σ_ab the 12×12 joint
/// covariance of (ξ_a, ξ_b) (a first).
Matrix6d relativeCovariance(const Eigen::Isometry3d& T_a, const Eigen::Isometry3d& T_b,
                            const Matrix12d& joint_ab);

}  // namespace dbacov
