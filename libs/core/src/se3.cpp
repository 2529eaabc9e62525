#include "dbacov/core/se3.h"

#include <cmath>

namespace dbacov {

Eigen::Matrix3d expSO3(const Eigen::Vector3d& phi) {
  const double theta2 = phi.squaredNorm();
  const Eigen::Matrix3d K = hat(phi);
  double a, b;  // R = I + a K + b K^2
  if (theta2 < 1e-10) {
    // Taylor: sin θ/θ = 1 − θ²/6, (1 − cos θ)/θ² = 1/2 − θ²/24; error O(θ⁴) < 1e-20.
    a = 1.0 - theta2 / 6.0;
    b = 0.5 - theta2 / 24.0;
  } else {
    const double theta = std::sqrt(theta2);
    a = std::sin(theta) / theta;
    b = (1.0 - std::cos(theta)) / theta2;
  }
  return Eigen::Matrix3d::Identity() + a * K + b * K * K;
}

Eigen::Vector3d logSO3(const Eigen::Matrix3d& R) {
  // Eigen's AngleAxis is robust near 0 and π (it goes through a quaternion).
  const Eigen::AngleAxisd aa(Eigen::Quaterniond(R).normalized());
  double angle = aa.angle();
  Eigen::Vector3d axis = aa.axis();
  if (angle > M_PI) {
    angle = 2.0 * M_PI - angle;
    axis = -axis;
  }
  return angle * axis;
}

Eigen::Matrix3d leftJacobianSO3(const Eigen::Vector3d& phi) {
  const double theta2 = phi.squaredNorm();
  const Eigen::Matrix3d K = hat(phi);
  double a, b;  // V = I + a K + b K^2
  if (theta2 < 1e-10) {
    a = 0.5 - theta2 / 24.0;
    b = 1.0 / 6.0 - theta2 / 120.0;
  } else {
    const double theta = std::sqrt(theta2);
    a = (1.0 - std::cos(theta)) / theta2;
    b = (theta - std::sin(theta)) / (theta2 * theta);
  }
  return Eigen::Matrix3d::Identity() + a * K + b * K * K;
}

Eigen::Matrix3d leftJacobianInvSO3(const Eigen::Vector3d& phi) {
  const double theta2 = phi.squaredNorm();
  const Eigen::Matrix3d K = hat(phi);
  double b;  // V^-1 = I − K/2 + b K^2
  if (theta2 < 1e-10) {
    b = 1.0 / 12.0 + theta2 / 720.0;
  } else {
    const double theta = std::sqrt(theta2);
    b = (1.0 - theta * std::sin(theta) / (2.0 * (1.0 - std::cos(theta)))) / theta2;
  }
  return Eigen::Matrix3d::Identity() - 0.5 * K + b * K * K;
}

Eigen::Isometry3d expSE3(const Vector6d& xi) {
  const Eigen::Vector3d rho = xi.head<3>(), phi = xi.tail<3>();
  Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
  T.linear() = expSO3(phi);
  T.translation() = leftJacobianSO3(phi) * rho;
  return T;
}

Vector6d logSE3(const Eigen::Isometry3d& T) {
  Vector6d xi;
  const Eigen::Vector3d phi = logSO3(T.linear());
  xi.head<3>() = leftJacobianInvSO3(phi) * T.translation();
  xi.tail<3>() = phi;
  return xi;
}

Matrix6d adjoint(const Eigen::Isometry3d& T) {
  // T Exp(ξ) T^-1 with ξ = [ρ; φ]: rotation part R φ, translation part R ρ + t × (R φ).
  Matrix6d Ad = Matrix6d::Zero();
  const Eigen::Matrix3d R = T.linear();
  Ad.topLeftCorner<3, 3>() = R;
  Ad.topRightCorner<3, 3>() = hat(T.translation()) * R;
  Ad.bottomRightCorner<3, 3>() = R;
  return Ad;
}

Matrix6d adSE3(const Vector6d& xi) {
  Matrix6d ad = Matrix6d::Zero();
  ad.topLeftCorner<3, 3>() = hat(xi.tail<3>());
  ad.topRightCorner<3, 3>() = hat(xi.head<3>());
  ad.bottomRightCorner<3, 3>() = hat(xi.tail<3>());
  return ad;
}

Matrix6d rightJacobianSE3(const Vector6d& xi) {
  // The series converges for every ξ; terms shrink like |ξ|^k/(k+1)!, so stop once they are below
  // round-off (for |ξ| <= π this takes ~25 terms).
  const Matrix6d A = -adSE3(xi);
  Matrix6d J = Matrix6d::Identity(), term = Matrix6d::Identity();
  for (int k = 1; k < 60; ++k) {
    term = term * A / static_cast<double>(k + 1);
    J += term;
    if (term.cwiseAbs().maxCoeff() < 1e-17) break;
  }
  return J;
}

Eigen::Isometry3d poseFromTQ(const double* v) {
  Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
  const Eigen::Quaterniond q(v[6], v[3], v[4], v[5]);  // Eigen's constructor order is (w, x, y, z)
  T.linear() = q.normalized().toRotationMatrix();
  T.translation() << v[0], v[1], v[2];
  return T;
}

Eigen::Matrix<double, 7, 1> poseToTQ(const Eigen::Isometry3d& T) {
  Eigen::Quaterniond q(T.linear());
  q.normalize();
  if (q.w() < 0) q.coeffs() = -q.coeffs();
  Eigen::Matrix<double, 7, 1> v;
  v << T.translation(), q.x(), q.y(), q.z(), q.w();
  return v;
}

Matrix6d relativeCovariance(const Eigen::Isometry3d& T_a, const Eigen::Isometry3d& T_b,
                            const Matrix12d& joint_ab) {
  // Z = T_a^-1 T_b. With T_a Exp(δa), T_b Exp(δb):
  //   Z' = Exp(−δa) Z Exp(δb) = Z Exp(−Ad(Z^-1) δa) Exp(δb) ≈ Z Exp(δb − Ad(Z^-1) δa).
  const Eigen::Isometry3d Z = T_a.inverse() * T_b;
  Eigen::Matrix<double, 6, 12> A;
  A.leftCols<6>() = -adjoint(Z.inverse());
  A.rightCols<6>().setIdentity();
  const Matrix6d S = A * joint_ab * A.transpose();
  return 0.5 * (S + S.transpose());
}

}  // namespace dbacov
