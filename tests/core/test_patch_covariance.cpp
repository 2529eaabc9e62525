// DbaCovariance of a patch graph: equal to that of the equivalent dense snapshot under every gauge,
// and to a naive dense inverse of the full (poses + depths) information with the droid gauge.

#include <gtest/gtest.h>

#include "dbacov/core/covariance.h"
#include "patch_graph_fixture.h"

namespace dbacov {
namespace {

using testing::denseEquivalent;
using testing::makePatchGraph;

DbaOptions withGauge(GaugeOptions::Type type) {
  DbaOptions o = DbaOptions::dpvo();
  o.max_residual.reset();  // linearizeDba has no residual or image bounds
  o.image_margin.reset();
  o.gauge.type = type;
  return o;
}

TEST(PatchCovariance, EqualsTheDenseSnapshotsUnderEveryGauge) {
  PatchGraph g = makePatchGraph(11, 6, 8, 3);
  g.t0 = 2;  // two held frames fix the monocular scale (one would leave it to DPVO's damping)
  const Snapshot s = denseEquivalent(g);
  for (GaugeOptions::Type type :
       {GaugeOptions::Type::Droid, GaugeOptions::Type::TwoPose, GaugeOptions::Type::Minimal}) {
    SCOPED_TRACE(static_cast<int>(type));
    const DbaOptions o = withGauge(type);
    CovarianceOptions co;
    co.depth_variances = true;
    const DbaCovariance pc(g, o, co), dc(s, o, co);
    ASSERT_EQ(pc.keyframes(), dc.keyframes());
    EXPECT_EQ(pc.gaugeKeyframes(), dc.gaugeKeyframes());
    for (int a : pc.keyframes()) {
      const Matrix6d M = dc.marginal(a);
      EXPECT_LE((pc.marginal(a) - M).norm(), 1e-9 * std::max(1e-300, M.norm())) << a;
      for (int b : pc.keyframes()) {
        if (b <= a) continue;
        const Matrix6d R = dc.relative(a, b);
        EXPECT_LE((pc.relative(a, b) - R).norm(), 1e-9 * std::max(1e-300, R.norm()));
      }
    }
    // One inverse-depth sigma per patch, equal to the dense one at the patch's pixel.
    const int f = pc.keyframes()[2];
    const std::vector<float> ps = pc.inverseDepthSigma(f), ds = dc.inverseDepthSigma(f);
    ASSERT_EQ(static_cast<int>(ps.size()), g.M);
    for (int m = 0; m < g.M; ++m) {
      const int p = f * g.M + m;
      const float d = ds[static_cast<std::size_t>(g.patch_y[p]) * s.W + g.patch_x[p]];
      EXPECT_NEAR(ps[m], d, 1e-5 * d) << m;
    }
  }
}

TEST(PatchCovariance, DroidGaugeEqualsTheNaiveInverseOfTheFullInformation) {
  PatchGraph g = makePatchGraph(12, 5, 6, 2);
  g.t0 = 2;
  const DbaOptions o = DbaOptions::dpvo();
  const DbaCovariance cov(g, o);
  // Full information over (free frames >= t0, then every patch depth) from the analytic factor.
  const std::vector<int> frames = g.graphFrames();
  std::vector<int> free;
  for (int k : frames)
    if (k >= g.t0) free.push_back(k);
  const int nf = static_cast<int>(free.size()), P = g.numPatches(), D = 6 * nf + P;
  auto col = [&](int k) {
    const auto it = std::find(free.begin(), free.end(), k);
    return it == free.end() ? -1 : 6 * static_cast<int>(it - free.begin());
  };
  const PinholeIntrinsics K = PinholeIntrinsics::fromVector(g.intrinsics);
  Eigen::MatrixXd H = Eigen::MatrixXd::Zero(D, D);
  for (int e = 0; e < g.numEdges(); ++e) {
    if (g.ii[e] == g.jj[e]) continue;
    const int i = g.ii[e], j = g.jj[e], p = g.kk[e];
    const Eigen::Isometry3d T_ji = g.T_cw(j) * g.T_wc(i);
    PixelFactorLinearization f;
    linearizePixelFactor(T_ji.linear(), T_ji.translation(), K, g.patch_x[p], g.patch_y[p],
                         g.patch_d[p], g.target[2 * e], g.target[2 * e + 1], &f);
    Eigen::MatrixXd J = Eigen::MatrixXd::Zero(2, D);
    if (col(i) >= 0) J.middleCols<6>(col(i)) = f.J_i;
    if (col(j) >= 0) J.middleCols<6>(col(j)) += f.J_j;
    J.col(6 * nf + p) = f.J_d;
    const Eigen::Vector2d w(g.weight[2 * e], g.weight[2 * e + 1]);
    H += J.transpose() * w.asDiagonal() * J;
  }
  // Patches without information (none here) would make H singular.
  const Eigen::MatrixXd Sigma = H.inverse();
  for (int k : frames) {
    const Matrix6d M = col(k) < 0 ? Matrix6d::Zero() : Matrix6d(Sigma.block<6, 6>(col(k), col(k)));
    EXPECT_LE((cov.marginal(k) - M).norm(), 1e-8 * std::max(1.0, M.norm())) << k;
  }
  EXPECT_EQ(cov.gaugeKeyframes(), (std::vector<int>{0, 1}));
}

}  // namespace
}  // namespace dbacov

namespace dbacov {
namespace {

// A DPVO-sized window (10 frames, 96 patches per frame, every patch seen by every frame: 9600
// edges) goes through; its time is bench_snapshot's PatchGraph (docs/development/performance.md).
TEST(PatchCovariance, ADpvoSizedWindowGivesFiniteMarginals) {
  PatchGraph g = testing::makePatchGraph(13, 10, 96, 9);
  g.t0 = 2;
  const DbaCovariance cov(g, DbaOptions::dpvo());
  for (int k : cov.keyframes()) EXPECT_TRUE(cov.marginal(k).allFinite());
  EXPECT_GT(cov.stats().factors_used, 0u);
}

}  // namespace
}  // namespace dbacov
