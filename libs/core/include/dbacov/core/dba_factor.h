// The DBA pixel factor (conventions §2) and its analytic Jacobians (conventions §3 tangent).
//
// For edge (i, j) and pixel (x, y) of frame i with inverse depth d:
//   X  = [ (x−cx)/fx, (y−cy)/fy, 1, d ]ᵀ            homogeneous point of frame i (metric =
//   X[0:3]/d) Y  = T_ji X,   T_ji = T_cw_j · T_wc_i           same point in frame j (Y[3] = d) r  =
//   target − π(Y),  π(Y) = [fx·Y0/Y2 + cx, fy·Y1/Y2 + cy]
//
// Derivatives, with the right perturbations T_wc_i Exp(ξ_i), T_wc_j Exp(ξ_j), ξ = [ρ; φ]:
//   Exp(ξ_i) X ≈ X + [φ_i × p + d ρ_i; 0]  (p = X[0:3])  ⇒ ∂Y/∂ξ_i = R_ji [d·I, −[p]×]
//   T_cw_j → Exp(−ξ_j) T_cw_j             ⇒ ∂Y/∂ξ_j = [−d·I, [Y]×]   (Y = Y[0:3])
//   ∂Y/∂d = t_ji
//   ∂π/∂Y = [fx/Y2, 0, −fx·Y0/Y2²; 0, fy/Y2, −fy·Y1/Y2²]
// and r = target − π, so every Jacobian carries a minus sign.
#pragma once

#include <Eigen/Core>
#include <Eigen/Geometry>

#include "dbacov/core/se3.h"

namespace dbacov {

struct PinholeIntrinsics {
  double fx = 1, fy = 1, cx = 0, cy = 0;
  static PinholeIntrinsics fromVector(const Eigen::Vector4d& v) { return {v[0], v[1], v[2], v[3]}; }
};

/// One pixel factor linearized at the current state.
struct PixelFactorLinearization {
  Eigen::Vector2d r;                ///< residual target − π(Y), pixels
  Eigen::Matrix<double, 2, 6> J_i;  ///< ∂r/∂ξ_i (source keyframe)
  Eigen::Matrix<double, 2, 6> J_j;  ///< ∂r/∂ξ_j (target keyframe)
  Eigen::Vector2d J_d;              ///< ∂r/∂d   (inverse depth of the source pixel)
};

/// The point in frame j, Y[0:3] of conventions §2 (Y[3] = d). Y.z() = z_j·d is DROID's "depth
/// ratio".
inline Eigen::Vector3d transferPoint(const Eigen::Matrix3d& R_ji, const Eigen::Vector3d& t_ji,
                                     const PinholeIntrinsics& K, double x, double y, double d) {
  const Eigen::Vector3d p((x - K.cx) / K.fx, (y - K.cy) / K.fy, 1.0);
  return R_ji * p + t_ji * d;
}

/// The residual, ∂r/∂ξ_j and ∂r/∂d of one pixel factor from its point Y in frame j
/// (transferPoint); out->J_i is left as it is (it is −J_j Ad(T_ji), dba_kernel.h). Returns
/// −∂π/∂Y, from which linearizePixelFactor forms J_i. Precondition: Y.z() > 0.
inline Eigen::Matrix<double, 2, 3> linearizePixelFactorAt(const Eigen::Vector3d& Y,
                                                          const Eigen::Vector3d& t_ji,
                                                          const PinholeIntrinsics& K, double d,
                                                          double target_x, double target_y,
                                                          PixelFactorLinearization* out) {
  const double iz = 1.0 / Y.z();
  out->r << target_x - (K.fx * Y.x() * iz + K.cx), target_y - (K.fy * Y.y() * iz + K.cy);

  // −∂π/∂Y
  Eigen::Matrix<double, 2, 3> mdPi;
  mdPi << -K.fx * iz, 0.0, K.fx * Y.x() * iz * iz, 0.0, -K.fy * iz, K.fy * Y.y() * iz * iz;

  out->J_j.leftCols<3>() = -d * mdPi;
  out->J_j.rightCols<3>() = mdPi * hat(Y);
  out->J_d = mdPi * t_ji;
  return mdPi;
}

/// Residual and Jacobians of one pixel factor. Precondition: Y.z() > 0 (callers filter pixels).
inline void linearizePixelFactor(const Eigen::Matrix3d& R_ji, const Eigen::Vector3d& t_ji,
                                 const PinholeIntrinsics& K, double x, double y, double d,
                                 double target_x, double target_y, PixelFactorLinearization* out) {
  const Eigen::Vector3d p((x - K.cx) / K.fx, (y - K.cy) / K.fy, 1.0);
  const Eigen::Vector3d Y = R_ji * p + t_ji * d;
  const Eigen::Matrix<double, 2, 3> mdPi =
      linearizePixelFactorAt(Y, t_ji, K, d, target_x, target_y, out);
  const Eigen::Matrix<double, 2, 3> mdPiR = mdPi * R_ji;
  out->J_i.leftCols<3>() = d * mdPiR;
  out->J_i.rightCols<3>() = -mdPiR * hat(p);
}

/// Residual from the two camera-to-world poses directly (the reference for finite differences).
Eigen::Vector2d pixelFactorResidual(const Eigen::Isometry3d& T_wc_i,
                                    const Eigen::Isometry3d& T_wc_j, const PinholeIntrinsics& K,
                                    double x, double y, double d, double target_x, double target_y);

}  // namespace dbacov
