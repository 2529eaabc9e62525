// The covariance engine (linearization → Schur → gauge → solver) against the dense reference of
// the full (poses + depths) information matrix, and its invariances.
#include <gtest/gtest.h>

#include "dbacov/core/covariance.h"
#include "dbacov/sim/synthetic_snapshot.h"
#include "dense_reference.h"
#include "fixtures.h"

namespace dbacov {
namespace {

using testing::gaugeOptions;

sim::SyntheticSnapshotConfig smallConfig(std::uint64_t seed) {
  return testing::gridConfig(seed, 5, 6, 8);
}

double relErr(const Eigen::MatrixXd& a, const Eigen::MatrixXd& b) {
  return (a - b).norm() / std::max(b.norm(), 1e-300);
}

void expectMatchesDense(const Snapshot& s, const DbaOptions& o, double tol) {
  const testing::DenseReference ref = testing::denseReference(s, o);
  for (SolverKind kind : {SolverKind::Sparse, SolverKind::Dense}) {
    SCOPED_TRACE(kind == SolverKind::Sparse ? "sparse solver" : "dense solver");
    CovarianceOptions so;
    so.kind = kind;
    const DbaCovariance cov(s, o, so);
    ASSERT_EQ(cov.keyframes(), ref.keyframes);
    for (int a : cov.keyframes()) {
      const Matrix6d R = ref.marginal(a);
      if (R.norm() == 0) {
        EXPECT_EQ(cov.marginal(a).norm(), 0.0) << "keyframe " << a;
        continue;
      }
      EXPECT_LT(relErr(cov.marginal(a), R), tol) << "keyframe " << a << "\n"
                                                 << cov.marginal(a) << "\nvs\n"
                                                 << R;
      for (int b : cov.keyframes()) {
        const Matrix12d J = cov.joint(a, b);
        EXPECT_LT((J.topRightCorner<6, 6>() - ref.cross(a, b)).norm(), tol * R.norm())
            << "pair " << a << "," << b;
      }
    }
  }
}

TEST(Covariance, MatchesDenseFullInverseHardTwoPose) {
  for (std::uint64_t seed : {1, 2}) {
    const auto syn = sim::generateSyntheticSnapshot(smallConfig(seed));
    expectMatchesDense(syn.snapshot, gaugeOptions(GaugeOptions::Type::TwoPose, 0, 0), 1e-8);
  }
}

TEST(Covariance, MatchesDenseFullInverseSoftTwoPose) {
  const auto syn = sim::generateSyntheticSnapshot(smallConfig(3));
  expectMatchesDense(syn.snapshot, gaugeOptions(GaugeOptions::Type::TwoPose, 0.02, 0.05), 1e-8);
}

TEST(Covariance, MatchesDenseFullInverseMixedTwoPose) {
  // Rotation hard-fixed, translation soft: components are removed independently.
  const auto syn = sim::generateSyntheticSnapshot(smallConfig(4));
  expectMatchesDense(syn.snapshot, gaugeOptions(GaugeOptions::Type::TwoPose, 0, 0.05), 1e-8);
}

TEST(Covariance, MatchesDenseFullInverseMinimal) {
  const auto syn = sim::generateSyntheticSnapshot(smallConfig(5));
  expectMatchesDense(syn.snapshot, gaugeOptions(GaugeOptions::Type::Minimal, 0, 0), 1e-8);
  const DbaCovariance cov(syn.snapshot, gaugeOptions(GaugeOptions::Type::Minimal, 0, 0));
  EXPECT_EQ(cov.freeDof(0), 0);
  EXPECT_EQ(cov.freeDof(1), 5);
  EXPECT_EQ(cov.freeDof(2), 6);
}

TEST(Covariance, MatchesDenseWithPaperFilters) {
  auto c = smallConfig(6);
  auto syn = sim::generateSyntheticSnapshot(c);
  DbaOptions o = DbaOptions::paper();
  o.near = 0.5;  // the room's walls are 1..7 m away: this filter removes some pixels
  o.far = 5.0;
  o.weight_scale = 4.0;
  expectMatchesDense(syn.snapshot, o, 1e-8);
  EXPECT_GT(DbaCovariance(syn.snapshot, o).stats().factors_filtered, 0u);
}

TEST(Covariance, TightSoftPriorApproachesHardFix) {
  const auto syn = sim::generateSyntheticSnapshot(smallConfig(7));
  const DbaCovariance hard(syn.snapshot, gaugeOptions(GaugeOptions::Type::TwoPose, 0, 0));
  const DbaCovariance tight(syn.snapshot, gaugeOptions(GaugeOptions::Type::TwoPose, 1e-7, 1e-7));
  const DbaCovariance loose(syn.snapshot, gaugeOptions(GaugeOptions::Type::TwoPose, 1e-2, 1e-2));
  for (int k : hard.keyframes()) {
    if (hard.freeDof(k) == 0) {
      EXPECT_LT(tight.marginal(k).norm(), 1e-12);
      continue;
    }
    EXPECT_LT(relErr(tight.marginal(k), hard.marginal(k)), 1e-5) << "keyframe " << k;
    EXPECT_GT(relErr(loose.marginal(k), hard.marginal(k)), 1e-3) << "keyframe " << k;
  }
}

TEST(Covariance, WeightScalingDividesCovariance) {
  const auto syn = sim::generateSyntheticSnapshot(smallConfig(8));
  DbaOptions o = gaugeOptions(GaugeOptions::Type::TwoPose, 0, 0);
  const DbaCovariance a(syn.snapshot, o);
  Snapshot scaled = syn.snapshot;
  for (float& w : scaled.weight) w *= 0.25f;  // exact in binary floating point
  const DbaCovariance b(scaled, o);
  for (int k : a.keyframes()) EXPECT_LT(relErr(b.marginal(k), 4.0 * a.marginal(k)), 1e-10);
  o.weight_scale *= 8.0;
  const DbaCovariance c(syn.snapshot, o);
  for (int k : a.keyframes()) EXPECT_LT(relErr(c.marginal(k), a.marginal(k) / 8.0), 1e-10);
}

TEST(Covariance, RigidWorldChangeLeavesTangentCovariancesUnchanged) {
  const auto syn = sim::generateSyntheticSnapshot(smallConfig(9));
  const Eigen::Isometry3d G = expSE3((Vector6d() << 2.0, -1.0, 0.5, 0.3, -1.2, 2.0).finished());
  Snapshot moved = syn.snapshot;
  for (int k = 0; k < moved.numKeyframes(); ++k) moved.setT_wc(k, G * syn.snapshot.T_wc(k));
  for (auto type : {GaugeOptions::Type::TwoPose, GaugeOptions::Type::Minimal}) {
    const DbaOptions o = gaugeOptions(type, type == GaugeOptions::Type::TwoPose ? 0.01 : 0, 0.02);
    const DbaCovariance a(syn.snapshot, o), b(moved, o);
    for (int k : a.keyframes()) {
      if (a.marginal(k).norm() == 0) continue;
      EXPECT_LT(relErr(b.marginal(k), a.marginal(k)), 1e-6) << "keyframe " << k;
    }
    // ... while the world-frame position covariance does change with the rotation of the world.
  }
}

TEST(Covariance, DisconnectedPartIsNamed) {
  auto c = smallConfig(10);
  c.num_keyframes = 6;
  c.covisibility.edge_radius = 1;
  auto syn = sim::generateSyntheticSnapshot(c);
  Snapshot& s = syn.snapshot;
  // Drop the edges between keyframes 2 and 3: {0,1,2} and {3,4,5} become disconnected.
  Snapshot cut = s;
  cut.ii.clear();
  cut.jj.clear();
  cut.target.clear();
  cut.weight.clear();
  const std::size_t plane = 2 * s.pixelsPerFrame();
  for (int e = 0; e < s.numEdges(); ++e) {
    if ((s.ii[e] == 2 && s.jj[e] == 3) || (s.ii[e] == 3 && s.jj[e] == 2)) continue;
    cut.ii.push_back(s.ii[e]);
    cut.jj.push_back(s.jj[e]);
    cut.target.insert(cut.target.end(), s.target.begin() + e * plane,
                      s.target.begin() + (e + 1) * plane);
    cut.weight.insert(cut.weight.end(), s.weight.begin() + e * plane,
                      s.weight.begin() + (e + 1) * plane);
  }
  cut.validate();
  try {
    DbaCovariance cov(cut, gaugeOptions(GaugeOptions::Type::TwoPose, 0, 0));
    FAIL() << "expected a NumericalError";
  } catch (const NumericalError& e) {
    EXPECT_EQ(e.keyframes(), (std::vector<int>{3, 4, 5}));
    EXPECT_NE(std::string(e.what()).find("3, 4, 5"), std::string::npos) << e.what();
  }
}

TEST(Covariance, AllZeroWeightsOfAKeyframeIsNumericalError) {
  auto syn = sim::generateSyntheticSnapshot(smallConfig(11));
  Snapshot& s = syn.snapshot;
  // Keyframe 4 loses every weight of the edges that touch it: it carries no information.
  const std::size_t plane = 2 * s.pixelsPerFrame();
  for (int e = 0; e < s.numEdges(); ++e)
    if (s.ii[e] == 4 || s.jj[e] == 4)
      std::fill(s.weight.begin() + e * plane, s.weight.begin() + (e + 1) * plane, 0.0f);
  try {
    DbaCovariance cov(s, gaugeOptions(GaugeOptions::Type::TwoPose, 0, 0));
    FAIL() << "expected a NumericalError";
  } catch (const NumericalError& e) {
    EXPECT_EQ(e.keyframes(), std::vector<int>{4}) << e.what();
  }
}

}  // namespace
}  // namespace dbacov

namespace dbacov {
namespace {

TEST(Covariance, TwoKeyframesUnderAHardGaugeHaveZeroCovariance) {
  auto c = smallConfig(12);
  c.num_keyframes = 2;
  const auto syn = sim::generateSyntheticSnapshot(c);
  for (SolverKind kind : {SolverKind::Sparse, SolverKind::Dense}) {
    CovarianceOptions so;
    so.kind = kind;
    so.depth_variances = true;
    const DbaCovariance cov(syn.snapshot, gaugeOptions(GaugeOptions::Type::TwoPose, 0, 0), so);
    EXPECT_EQ(cov.marginal(0), Matrix6d::Zero());
    EXPECT_EQ(cov.relative(0, 1), Matrix6d::Zero());
    // Depths still have a variance: 1/h (the poses are fixed).
    std::size_t finite = 0;
    for (float v : cov.inverseDepthSigma(0)) finite += std::isfinite(v);
    EXPECT_GT(finite, 0u);
  }
}

}  // namespace
}  // namespace dbacov
