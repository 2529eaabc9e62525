#include "dbacov/mrpt/pose_conversion.h"

#include <cmath>
#include <stdexcept>

namespace dbacov::mrpt_bridge {

mrpt::poses::CPose3D toCPose3D(const Eigen::Isometry3d& T) {
  mrpt::math::CMatrixDouble33 R;
  mrpt::math::CVectorFixedDouble<3> t;
  for (int r = 0; r < 3; ++r) {
    t[r] = T.translation()[r];
    for (int c = 0; c < 3; ++c) R(r, c) = T.linear()(r, c);
  }
  return mrpt::poses::CPose3D(R, t);
}

Eigen::Isometry3d fromCPose3D(const mrpt::poses::CPose3D& pose) {
  Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
  const auto& R = pose.getRotationMatrix();
  for (int r = 0; r < 3; ++r) {
    T.translation()[r] = pose.m_coords[r];
    for (int c = 0; c < 3; ++c) T.linear()(r, c) = R(r, c);
  }
  return T;
}

Matrix6d tangentToYprJacobian(const Eigen::Isometry3d& T_wc) {
  const mrpt::poses::CPose3D p = toCPose3D(T_wc);
  const double pitch = p.pitch(), roll = p.roll();
  const double cp = std::cos(pitch), sr = std::sin(roll), cr = std::cos(roll);
  if (std::abs(cp) < 1e-9)
    throw std::domain_error(
        "pose at pitch ±90° (gimbal lock): yaw/pitch/roll covariance undefined");
  const double tp = std::tan(pitch);
  Eigen::Matrix3d Einv;
  Einv << 0, sr / cp, cr / cp, 0, cr, -sr, 1, sr * tp, cr * tp;
  Matrix6d J = Matrix6d::Zero();
  J.topLeftCorner<3, 3>() = T_wc.linear();
  J.bottomRightCorner<3, 3>() = Einv;
  return J;
}

mrpt::poses::CPose3DPDFGaussian toPoseGaussian(const Eigen::Isometry3d& T_wc,
                                               const Matrix6d& Sigma_tangent) {
  const Matrix6d J = tangentToYprJacobian(T_wc);
  Matrix6d C = J * Sigma_tangent * J.transpose();
  C = 0.5 * (C + C.transpose());
  mrpt::math::CMatrixDouble66 cov;
  for (int r = 0; r < 6; ++r)
    for (int c = 0; c < 6; ++c) cov(r, c) = C(r, c);
  return mrpt::poses::CPose3DPDFGaussian(toCPose3D(T_wc), cov);
}

Matrix6d yprToTangentCovariance(const Eigen::Isometry3d& T_wc, const Matrix6d& Sigma_ypr) {
  const Matrix6d Jinv = tangentToYprJacobian(T_wc).inverse();
  Matrix6d Sigma = Jinv * Sigma_ypr * Jinv.transpose();
  return 0.5 * (Sigma + Sigma.transpose());
}

}  // namespace dbacov::mrpt_bridge
