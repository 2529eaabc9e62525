// Pose-graph pieces against independent references: the SE(3) right Jacobian and the edge
// Jacobians against finite differences, node covariances against closed-form propagation along a
// chain and against the dense solver.
#include <random>

#include <gtest/gtest.h>

#include "dbacov/core/pose_graph.h"
#include "fixtures.h"

namespace dbacov {
namespace {

using testing::randomTangent;

TEST(PoseGraph, RightJacobianMatchesFiniteDifferences) {
  std::mt19937 rng(3);
  for (int t = 0; t < 30; ++t) {
    const Vector6d xi = randomTangent(rng, 0.8);
    const Matrix6d Jinv = rightJacobianSE3(xi).inverse();
    Matrix6d fd;
    const double h = 1e-6;
    for (int k = 0; k < 6; ++k) {
      Vector6d d = Vector6d::Zero();
      d[k] = h;
      fd.col(k) = (logSE3(expSE3(xi) * expSE3(d)) - logSE3(expSE3(xi) * expSE3(-d))) / (2 * h);
    }
    EXPECT_LT((Jinv - fd).norm(), 1e-6) << xi.transpose();
  }
}

TEST(PoseGraph, EdgeJacobiansMatchFiniteDifferences) {
  std::mt19937 rng(5);
  for (int t = 0; t < 30; ++t) {
    const Eigen::Isometry3d Ta = expSE3(randomTangent(rng, 1.0)),
                            Tb = expSE3(randomTangent(rng, 1.0));
    const Eigen::Isometry3d Z = Ta.inverse() * Tb * expSE3(randomTangent(rng, 0.3));
    Vector6d r;
    Matrix6d Ja, Jb;
    poseGraphEdgeResidual(Ta, Tb, Z, &r, &Ja, &Jb);
    Matrix6d fa, fb;
    const double h = 1e-6;
    auto res = [&](const Eigen::Isometry3d& A, const Eigen::Isometry3d& B) {
      return logSE3(Z.inverse() * A.inverse() * B);
    };
    for (int k = 0; k < 6; ++k) {
      Vector6d d = Vector6d::Zero();
      d[k] = h;
      fa.col(k) = (res(Ta * expSE3(d), Tb) - res(Ta * expSE3(-d), Tb)) / (2 * h);
      fb.col(k) = (res(Ta, Tb * expSE3(d)) - res(Ta, Tb * expSE3(-d))) / (2 * h);
    }
    EXPECT_LT((Ja - fa).norm(), 1e-6);
    EXPECT_LT((Jb - fb).norm(), 1e-6);
    EXPECT_LT((r - res(Ta, Tb)).norm(), 1e-12);
  }
}

TEST(PoseGraph, ChainCovarianceMatchesPropagation) {
  // A consistent chain 0 → 1 → 2 → 3 with node 0 fixed: Σ_{k+1} = Ad(Z⁻¹) Σ_k Ad(Z⁻¹)ᵀ + Λ_k⁻¹.
  std::mt19937 rng(9);
  PoseGraph g;
  g.nodes[0] = expSE3(randomTangent(rng, 1.0));
  Matrix6d expected = Matrix6d::Zero();
  std::map<int, Matrix6d> want{{0, expected}};
  for (int k = 0; k < 3; ++k) {
    PoseGraphEdge e;
    e.from = k;
    e.to = k + 1;
    e.Z = expSE3(randomTangent(rng, 0.7));
    Eigen::Matrix<double, 6, 6> A = Eigen::Matrix<double, 6, 6>::Random();
    const Matrix6d C = 1e-3 * (A * A.transpose() + Matrix6d::Identity());
    e.information = C.inverse();
    g.nodes[k + 1] = g.nodes[k] * e.Z;
    g.edges.push_back(e);
    const Matrix6d Ad = adjoint(e.Z.inverse());
    expected = Ad * expected * Ad.transpose() + C;
    want[k + 1] = expected;
  }
  for (SolverKind kind : {SolverKind::Sparse, SolverKind::Dense}) {
    const auto cov = poseGraphCovariances(g, {0}, kind);
    for (const auto& [id, W] : want)
      EXPECT_LT((cov.at(id) - W).norm(), 1e-9 * (1 + W.norm())) << "node " << id;
  }
}

TEST(PoseGraph, FloatingPartIsNamed) {
  PoseGraph g;
  for (int k = 0; k < 4; ++k) g.nodes[k] = Eigen::Isometry3d::Identity();
  g.edges.push_back({0, 1, Eigen::Isometry3d::Identity(), Matrix6d::Identity()});
  g.edges.push_back({2, 3, Eigen::Isometry3d::Identity(), Matrix6d::Identity()});
  try {
    poseGraphCovariances(g, {0});
    FAIL();
  } catch (const NumericalError& e) {
    EXPECT_EQ(e.keyframes(), (std::vector<int>{2, 3}));
  }
}

}  // namespace
}  // namespace dbacov
