// The 3D scene's geometry against independent references: the world position covariance (MRPT's
// yaw/pitch/roll conversion and Monte Carlo), frustums (their far-plane corners, as MRPT computes
// them, projected with the pinhole model land on the image corners), ellipsoids (the vertices MRPT
// generates lie on the exaggerated 3-sigma surface, with the reference eigen-axes) and the display
// rotation. Also pins down the MRPT 2.5.8 CEllipsoid3D behaviour that the scene works around.
#include <cmath>
#include <random>

#include <gtest/gtest.h>
#include <mrpt/opengl/CEllipsoid3D.h>
#include <mrpt/opengl/CFrustum.h>
#include <mrpt/opengl/CGridPlaneXY.h>
#include <mrpt/opengl/CSetOfLines.h>
#include <Eigen/Cholesky>
#include <Eigen/Eigenvalues>

#include "dbacov/mrpt/pose_conversion.h"
#include "dbacov/mrpt/scene.h"
#include "viz_fixtures.h"

namespace dbacov {
namespace {

using mrpt_bridge::SceneContent;
using mrpt_bridge::SceneKeyframe;
using mrpt_bridge::SceneStyle;

Eigen::Isometry3d randomPose(std::mt19937& rng) {
  std::normal_distribution<double> n01;
  Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
  T.linear() =
      Eigen::Quaterniond(n01(rng), n01(rng), n01(rng), n01(rng)).normalized().toRotationMatrix();
  T.translation() << n01(rng), n01(rng), n01(rng);
  return T;
}

/// A random SPD 6×6 covariance with strong correlations (scale `s`).
Matrix6d randomCovariance(std::mt19937& rng, double s) {
  std::normal_distribution<double> n01;
  Matrix6d A;
  for (int i = 0; i < 36; ++i) A(i / 6, i % 6) = n01(rng);
  return s * s * (A * A.transpose() + 0.1 * Matrix6d::Identity());
}

/// Reference: δp_world = R_wc ρ, so Σ_pos = R Σ_ρρ Rᵀ (written out here, not taken from the code).
Eigen::Matrix3d referencePositionCovariance(const Eigen::Isometry3d& T, const Matrix6d& S) {
  Eigen::Matrix3d C = Eigen::Matrix3d::Zero();
  for (int a = 0; a < 3; ++a)
    for (int b = 0; b < 3; ++b)
      for (int i = 0; i < 3; ++i)
        for (int j = 0; j < 3; ++j) C(a, b) += T.linear()(a, i) * S(i, j) * T.linear()(b, j);
  return C;
}

TEST(SceneGeometry, WorldPositionCovarianceIsThePositionBlockOfMrptsCovariance) {
  std::mt19937 rng(7);
  for (int trial = 0; trial < 20; ++trial) {
    const Eigen::Isometry3d T = randomPose(rng);
    const Matrix6d S = randomCovariance(rng, 0.1);
    const Eigen::Matrix3d C = mrpt_bridge::worldPositionCovariance(T, S);
    const auto pdf = mrpt_bridge::toPoseGaussian(T, S);
    for (int a = 0; a < 3; ++a)
      for (int b = 0; b < 3; ++b) {
        EXPECT_NEAR(C(a, b), pdf.cov(a, b), 1e-12 * (1 + std::abs(C(a, b))));
        EXPECT_NEAR(C(a, b), referencePositionCovariance(T, S)(a, b), 1e-12);
      }
  }
}

TEST(SceneGeometry, WorldPositionCovarianceMatchesMonteCarlo) {
  std::mt19937 rng(11);
  const Eigen::Isometry3d T = randomPose(rng);
  const Matrix6d S = randomCovariance(rng, 0.01);  // small: first order is accurate
  const Matrix6d L = S.llt().matrixL();
  std::normal_distribution<double> n01;
  const int n = 100000;
  Eigen::Matrix3d C = Eigen::Matrix3d::Zero();
  for (int s = 0; s < n; ++s) {
    Vector6d w;
    for (int i = 0; i < 6; ++i) w[i] = n01(rng);
    const Eigen::Vector3d d = (T * expSE3(L * w)).translation() - T.translation();
    C += d * d.transpose();
  }
  C /= n;
  const Eigen::Matrix3d ref = mrpt_bridge::worldPositionCovariance(T, S);
  EXPECT_LT((C - ref).norm(), 0.02 * ref.norm());
}

TEST(SceneGeometry, DisplayRotationTurnsTheUpAxisIntoPlusZ) {
  for (int axis = 0; axis < 3; ++axis)
    for (double sign : {-1.0, 1.0}) {
      const Eigen::Vector3d up = sign * Eigen::Vector3d::Unit(axis);
      const Eigen::Matrix3d R = mrpt_bridge::displayRotation(up);
      EXPECT_NEAR((R * R.transpose() - Eigen::Matrix3d::Identity()).norm(), 0, 1e-15);
      EXPECT_NEAR(R.determinant(), 1, 1e-15);
      EXPECT_NEAR((R * up - Eigen::Vector3d::UnitZ()).norm(), 0, 1e-15);
    }
  SceneStyle bad;
  bad.up = Eigen::Vector3d(1, 1, 0).normalized();
  EXPECT_THROW(bad.validate(), std::invalid_argument);
}

/// One keyframe with off-centre intrinsics, so that a mirrored frustum would be caught.
SceneContent oneKeyframe(const Eigen::Isometry3d& T, const Matrix6d& S) {
  SceneContent c;
  c.keyframes.push_back({"k", T, S, false});
  c.W = 40;
  c.H = 30;
  c.intrinsics << 30, 33, 13.0, 20.5;
  return c;
}

/// Pose of an object inside the "world" set, in world coordinates (the set's pose maps world to
/// display; undoing it gives the object's pose in the world frame).
Eigen::Isometry3d objectPoseInWorld(const mrpt::opengl::CRenderizable& o) {
  return testing::toIsometry(o.getPoseRef());
}

TEST(SceneGeometry, FrustumFarCornersProjectOntoTheImageCorners) {
  std::mt19937 rng(5);
  for (int trial = 0; trial < 10; ++trial) {
    const Eigen::Isometry3d T_wc = randomPose(rng);
    const SceneContent c = oneKeyframe(T_wc, Matrix6d::Zero());
    SceneStyle style;
    style.frustum_depth = 0.7;
    const auto scene = mrpt_bridge::buildScene(c, style);
    const auto f = testing::worldObject<mrpt::opengl::CFrustum>(*scene, "frustum k");
    ASSERT_TRUE(f);
    // MRPT's own local geometry of the frustum: the far plane is the x = far face of its box.
    const auto bb = f->internalBoundingBoxLocal();
    EXPECT_NEAR(bb.max.x, 0.7, 1e-6);
    const Eigen::Isometry3d P = objectPoseInWorld(*f);
    std::vector<Eigen::Vector2d> projected;
    for (double y : {bb.min.y, bb.max.y})
      for (double z : {bb.min.z, bb.max.z}) {
        const Eigen::Vector3d X = T_wc.inverse() * (P * Eigen::Vector3d(bb.max.x, y, z));
        ASSERT_GT(X.z(), 0) << "the frustum must open in front of the camera";
        projected.emplace_back(30 * X.x() / X.z() + 13.0, 33 * X.y() / X.z() + 20.5);
      }
    for (const Eigen::Vector2d& corner :
         {Eigen::Vector2d(-0.5, -0.5), Eigen::Vector2d(39.5, -0.5), Eigen::Vector2d(-0.5, 29.5),
          Eigen::Vector2d(39.5, 29.5)}) {
      double best = 1e9;
      for (const auto& p : projected) best = std::min(best, (p - corner).norm());
      EXPECT_LT(best, 1e-3) << "image corner " << corner.transpose() << " not covered";
    }
    // The frustum's axis (local +X) is the optical axis R_wc·z.
    EXPECT_NEAR((P.linear().col(0) - T_wc.linear().col(2)).norm(), 0, 1e-9);
  }
}

TEST(SceneGeometry, EllipsoidIsTheExaggeratedThreeSigmaSurfaceOfTheWorldCovariance) {
  std::mt19937 rng(9);
  for (int trial = 0; trial < 10; ++trial) {
    const Eigen::Isometry3d T_wc = randomPose(rng);
    const Matrix6d S = randomCovariance(rng, trial % 2 ? 1e-4 : 0.05);  // tiny ones too
    SceneStyle style;
    style.exaggeration = 7;
    const auto scene = mrpt_bridge::buildScene(oneKeyframe(T_wc, S), style);
    const auto e = testing::worldObject<mrpt::opengl::CEllipsoid3D>(*scene, "ellipsoid k");
    ASSERT_TRUE(e);
    const Eigen::Matrix3d M = 9 * 49 * referencePositionCovariance(T_wc, S);  // (3σ·f)² Σ_pos
    const Eigen::Matrix3d Minv = M.inverse();
    const Eigen::Vector3d c = T_wc.translation();
    const auto verts = testing::ellipsoidVertices(*e);
    ASSERT_GT(verts.size(), 100u);
    for (const auto& p : verts) ASSERT_NEAR((p - c).dot(Minv * (p - c)), 1.0, 2e-3);
    // Extent along each reference eigenvector = 3·f·sqrt(λ).
    const Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> es(M);
    for (int i = 0; i < 3; ++i) {
      double extent = 0;
      for (const auto& p : verts)
        extent = std::max(extent, std::abs((p - c).dot(es.eigenvectors().col(i))));
      EXPECT_NEAR(extent, std::sqrt(es.eigenvalues()[i]), 0.02 * std::sqrt(es.eigenvalues()[i]));
    }
  }
}

TEST(SceneGeometry, MrptCholeskyEllipsoidIsWrongForCorrelatedCovariances) {
  // MRPT 2.5.8 maps the unit sphere by the upper Cholesky factor U (C = UᵀU): the drawn surface is
  // that of U·Uᵀ. This is why the scene passes a diagonal matrix and rotates by the eigenvectors.
  Eigen::Matrix3d C;
  C << 4, 1.5, 0.5, 1.5, 1, 0.2, 0.5, 0.2, 0.25;
  auto e = mrpt::opengl::CEllipsoid3D::Create();
  mrpt::math::CMatrixDouble33 m;
  for (int i = 0; i < 9; ++i) m(i / 3, i % 3) = C(i / 3, i % 3);
  e->setCovMatrix(m);
  e->setQuantiles(1);
  double lo = 1e9, hi = 0;
  for (const auto& p : testing::ellipsoidVertices(*e)) {
    const double d2 = p.dot(C.inverse() * p);
    lo = std::min(lo, d2);
    hi = std::max(hi, d2);
  }
  EXPECT_TRUE(lo < 0.9 || hi > 1.1) << "MRPT now draws C itself; the eigenbasis workaround can go";
}

TEST(SceneGeometry, OneFrustumPerKeyframeEllipsoidsOnlyWhereTheCovarianceIsNotZero) {
  std::mt19937 rng(3);
  SceneContent c = oneKeyframe(randomPose(rng), Matrix6d::Zero());
  c.keyframes[0].gauge = true;
  for (int k = 1; k < 5; ++k) {
    Eigen::Isometry3d T = c.keyframes[0].T_wc;
    T.translation() += Eigen::Vector3d(0.3 * k, 0.05 * k, 0);
    c.keyframes.push_back({"k" + std::to_string(k), T, randomCovariance(rng, 0.01), false});
  }
  c.covisible = {{0, 1}, {1, 2}, {0, 2}, {3, 4}};
  const auto scene = mrpt_bridge::buildScene(c, SceneStyle{});
  EXPECT_EQ(testing::countWorldObjects<mrpt::opengl::CFrustum>(*scene), 5);
  EXPECT_EQ(testing::countWorldObjects<mrpt::opengl::CEllipsoid3D>(*scene), 4);
  EXPECT_FALSE(testing::worldObject<mrpt::opengl::CEllipsoid3D>(*scene, "ellipsoid k"));
  EXPECT_EQ(testing::worldObject<mrpt::opengl::CSetOfLines>(*scene, "trajectory")->size(), 4u);
  EXPECT_EQ(testing::worldObject<mrpt::opengl::CSetOfLines>(*scene, "covisibility")->size(), 4u);
  // The grid lies below every camera centre, in display coordinates.
  const auto grid = std::dynamic_pointer_cast<mrpt::opengl::CGridPlaneXY>(scene->getByName("grid"));
  ASSERT_TRUE(grid);
  const Eigen::Isometry3d T_dw = testing::toIsometry(scene->getByName("world")->getPoseRef());
  for (const auto& kf : c.keyframes)
    EXPECT_LT(grid->getBoundingBox().max.z, (T_dw * kf.T_wc.translation()).z());
  c.covisible.push_back({0, 5});
  EXPECT_THROW(mrpt_bridge::buildScene(c, SceneStyle{}), std::invalid_argument);
}

TEST(SceneGeometry, AutoExaggerationIsTheLargestOneTwoFiveValueBelowTheTarget) {
  // Keyframes 0.5 apart; isotropic translation sigma s: the 3-sigma semi-axis is 3s.
  for (double s : {1e-4, 3e-3, 0.02, 0.4}) {
    SceneContent c;
    for (int k = 0; k < 4; ++k) {
      Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
      T.translation().x() = 0.5 * k;
      c.keyframes.push_back({std::to_string(k), T, s * s * Matrix6d::Identity(), false});
    }
    const double wanted = 0.4 * 0.5 / (3 * s);
    double expected = 0;
    for (int e = -8; e <= 8; ++e)
      for (double m : {1.0, 2.0, 5.0})
        if (m * std::pow(10.0, e) <= wanted) expected = std::max(expected, m * std::pow(10.0, e));
    EXPECT_NEAR(mrpt_bridge::autoExaggeration(c, 3), expected, 1e-9 * expected) << "s = " << s;
  }
  EXPECT_EQ(mrpt_bridge::ellipsoidLegend(3, 20),
            "ellipsoids: 3-sigma world position covariance, scaled x 20");
}

}  // namespace
}  // namespace dbacov
