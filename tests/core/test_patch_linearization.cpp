// linearizePatchGraph: against a full system built from central finite differences of the
// independent residual (pixelFactorResidual), against linearizeDba on the equivalent dense
// snapshot, and DPVO's edge filters.
#include <gtest/gtest.h>

#include "dbacov/core/linearization.h"
#include "patch_graph_fixture.h"

namespace dbacov {
namespace {

using testing::denseEquivalent;
using testing::makePatchGraph;

double relDiff(const Eigen::MatrixXd& a, const Eigen::MatrixXd& b) {
  return (a - b).norm() / std::max(1e-300, b.norm());
}

DbaOptions dpvoNoBounds() {
  DbaOptions o = DbaOptions::dpvo();
  o.max_residual.reset();
  o.image_margin.reset();
  return o;
}

/// Full normal equations over (6 per graph frame, one depth per patch) with every Jacobian from
/// central differences of pixelFactorResidual (right perturbations T_wc Exp(ξ)), then the depths
/// eliminated densely: S and g_S.
std::pair<Eigen::MatrixXd, Eigen::VectorXd> finiteDifferenceSchur(const PatchGraph& g,
                                                                  const DbaOptions& o) {
  const std::vector<int> frames = g.graphFrames();
  const int n = static_cast<int>(frames.size()), P = g.numPatches(), D = 6 * n + P;
  const PinholeIntrinsics K = PinholeIntrinsics::fromVector(g.intrinsics);
  Eigen::MatrixXd H = Eigen::MatrixXd::Zero(D, D);
  Eigen::VectorXd grad = Eigen::VectorXd::Zero(D);
  const double h = 1e-6;
  for (int e = 0; e < g.numEdges(); ++e) {
    if (g.ii[e] == g.jj[e]) continue;
    const int i = static_cast<int>(g.ii[e]), j = static_cast<int>(g.jj[e]), p = g.kk[e];
    const int si = std::find(frames.begin(), frames.end(), i) - frames.begin();
    const int sj = std::find(frames.begin(), frames.end(), j) - frames.begin();
    auto res = [&](const Eigen::Isometry3d& Ti, const Eigen::Isometry3d& Tj, double d) {
      return pixelFactorResidual(Ti, Tj, K, g.patch_x[p], g.patch_y[p], d, g.target[2 * e],
                                 g.target[2 * e + 1]);
    };
    const Eigen::Isometry3d Ti = g.T_wc(i), Tj = g.T_wc(j);
    const double d = g.patch_d[p];
    Eigen::MatrixXd J = Eigen::MatrixXd::Zero(2, D);
    for (int k = 0; k < 6; ++k) {
      Vector6d dx = Vector6d::Zero();
      dx[k] = h;
      J.col(6 * si + k) = (res(Ti * expSE3(dx), Tj, d) - res(Ti * expSE3(-dx), Tj, d)) / (2 * h);
      J.col(6 * sj + k) = (res(Ti, Tj * expSE3(dx), d) - res(Ti, Tj * expSE3(-dx), d)) / (2 * h);
    }
    J.col(6 * n + p) = (res(Ti, Tj, d + h) - res(Ti, Tj, d - h)) / (2 * h);
    const Eigen::Vector2d w(o.weight_scale * g.weight[2 * e], o.weight_scale * g.weight[2 * e + 1]);
    H += J.transpose() * w.asDiagonal() * J;
    grad += J.transpose() * w.asDiagonal() * res(Ti, Tj, d);
  }
  const Eigen::MatrixXd Hpp = H.topLeftCorner(6 * n, 6 * n), Hpd = H.topRightCorner(6 * n, P);
  const Eigen::VectorXd hdd = H.bottomRightCorner(P, P).diagonal();
  Eigen::MatrixXd S = Hpp;
  Eigen::VectorXd gS = grad.head(6 * n);
  for (int k = 0; k < P; ++k)
    if (hdd[k] > 0) {
      S -= Hpd.col(k) * Hpd.col(k).transpose() / hdd[k];
      gS -= Hpd.col(k) * grad[6 * n + k] / hdd[k];
    }
  return {S, gS};
}

TEST(PatchLinearization, MatchesFiniteDifferencesOfTheIndependentResidual) {
  for (unsigned seed : {1u, 2u, 3u}) {
    const PatchGraph g = makePatchGraph(seed);
    const DbaOptions o = DbaOptions::dpvo();
    const DbaNormalEquations ne = linearizePatchGraph(g, o);
    const auto [S, gS] = finiteDifferenceSchur(g, o);
    EXPECT_LT(relDiff(ne.S.toDense(), S), 1e-6) << seed;
    EXPECT_LT(relDiff(ne.g_S, gS), 1e-6) << seed;
    EXPECT_EQ(ne.stats.factors_filtered, 0u);
    EXPECT_EQ(ne.stats.depths_used, static_cast<std::size_t>(g.numPatches()));
  }
}

TEST(PatchLinearization, EqualsTheDenseSnapshotWithTheSameFactors) {
  for (unsigned seed : {4u, 5u}) {
    const PatchGraph g = makePatchGraph(seed, 6, 8, 3);
    const Snapshot s = denseEquivalent(g);
    const DbaOptions o = dpvoNoBounds();  // linearizeDba has no residual or image bounds
    const DbaNormalEquations pg = linearizePatchGraph(g, o), dense = linearizeDba(s, o);
    ASSERT_EQ(pg.keyframes, dense.keyframes);
    EXPECT_LT(relDiff(pg.S.toDense(), dense.S.toDense()), 1e-10) << seed;
    EXPECT_LT(relDiff(pg.g_S, dense.g_S), 1e-10) << seed;
    EXPECT_LT(relDiff(pg.Hpp.toDense(), dense.Hpp.toDense()), 1e-10) << seed;
    EXPECT_LT(relDiff(pg.g_p, dense.g_p), 1e-10) << seed;
    EXPECT_NEAR(pg.stats.chi2, dense.stats.chi2, 1e-10 * dense.stats.chi2);
    EXPECT_EQ(pg.stats.depths_used, dense.stats.depths_used);
  }
}

TEST(PatchLinearization, DropsEdgesAsDpvosBaDoes) {
  PatchGraph g = makePatchGraph(7);
  const DbaOptions o = DbaOptions::dpvo();
  const DbaNormalEquations clean = linearizePatchGraph(g, o);
  // A residual of norm >= 128 px (each axis below 128) and a frame 4 units ahead of frame 0, which
  // has the patches' points (depth 1/d <= 3.4) behind it.
  auto addEdge = [&](int i, int j, int m, double dx, double dy) {
    const int e = g.numEdges(), p = i * g.M + m;
    g.ii.push_back(i);
    g.jj.push_back(j);
    g.kk.push_back(p);
    const Eigen::Vector2d r0 =
        pixelFactorResidual(g.T_wc(i), g.T_wc(j), PinholeIntrinsics::fromVector(g.intrinsics),
                            g.patch_x[p], g.patch_y[p], g.patch_d[p], 0, 0);
    g.target.insert(g.target.end(), {-r0.x() + dx, -r0.y() + dy});
    g.weight.insert(g.weight.end(), {0.5, 0.5});
    return e;
  };
  addEdge(0, 1, 0, 100, 100);
  Eigen::Isometry3d ahead = g.T_wc(0);
  ahead.translation() += ahead.linear() * Eigen::Vector3d(0, 0, 4.0);
  g.poses_cw.conservativeResize(g.numFrames() + 1, 7);
  g.poses_cw.row(g.numFrames() - 1) = poseToTQ(ahead.inverse()).transpose();
  g.tstamp.push_back(100);
  const int N = g.numFrames();
  g.patch_x.resize(N * g.M, 1);
  g.patch_y.resize(N * g.M, 1);
  g.patch_d.resize(N * g.M, 1);
  for (int m = 0; m < g.M; ++m) addEdge(0, N - 1, m, 0, 0);
  g.validate();
  const DbaNormalEquations dropped = linearizePatchGraph(g, o);
  EXPECT_EQ(dropped.stats.factors_filtered, 1u + g.M);
  EXPECT_EQ(dropped.stats.factors_used, clean.stats.factors_used);
  const int n = static_cast<int>(clean.keyframes.size());
  EXPECT_EQ(dropped.S.toDense().topLeftCorner(6 * n, 6 * n), clean.S.toDense());
  EXPECT_TRUE(dropped.S.toDense().rightCols(6).isZero(0));

  // Without DPVO's bounds the residual edge counts.
  DbaOptions no_bounds = o;
  no_bounds.max_residual.reset();
  EXPECT_EQ(linearizePatchGraph(g, no_bounds).stats.factors_filtered,
            static_cast<std::size_t>(g.M));
}

TEST(PatchLinearization, TheImageMarginDropsProjectionsOutsideTheWidenedImage) {
  const PatchGraph g = makePatchGraph(8, 5, 40, 4);
  const PinholeIntrinsics K = PinholeIntrinsics::fromVector(g.intrinsics);
  std::size_t outside = 0, pair_edges = 0;
  for (int e = 0; e < g.numEdges(); ++e) {
    if (g.ii[e] == g.jj[e]) continue;
    ++pair_edges;
    const int p = g.kk[e];
    const Eigen::Vector2d r =
        pixelFactorResidual(g.T_wc(g.ii[e]), g.T_wc(g.jj[e]), K, g.patch_x[p], g.patch_y[p],
                            g.patch_d[p], g.target[2 * e], g.target[2 * e + 1]);
    const double px = g.target[2 * e] - r.x(), py = g.target[2 * e + 1] - r.y();
    const double m = 0.0;
    outside += !(px > -m && py > -m && px < 2 * K.cx + m && py < 2 * K.cy + m);
  }
  DbaOptions o = DbaOptions::dpvo();
  o.image_margin = 0.0;
  const DbaNormalEquations ne = linearizePatchGraph(g, o);
  EXPECT_GT(outside, 0u);  // the fixture's motion carries some patches out of the grid
  EXPECT_EQ(ne.stats.factors_filtered, outside);
  EXPECT_EQ(ne.stats.factors_used, pair_edges - outside);
}

TEST(PatchLinearization, DenseSnapshotsRefuseThePatchGraphOnlyFilters) {
  const Snapshot s = denseEquivalent(makePatchGraph(9));
  EXPECT_THROW(linearizeDba(s, DbaOptions::dpvo()), std::invalid_argument);
  EXPECT_EQ(DbaOptions::preset("dpvo").weight_scale, 1.0);
  EXPECT_EQ(DbaOptions::preset(Preset::Dpvo).gauge.type, GaugeOptions::Type::Droid);
}

}  // namespace
}  // namespace dbacov
