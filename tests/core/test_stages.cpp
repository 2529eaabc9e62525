// The engine's internal stages one at a time, each against an independent dense computation on a
// small graph (conventions §4): the linearization and Schur complement against the dense Jacobian
// product JᵀΛJ of every factor row (dense_reference.h), and the gauge against the dense basis P of
// the reference applied to the same S. The whole chain (through CHOLMOD) is test_covariance.cpp's.
#include <cstdlib>

#include <gtest/gtest.h>
#include <Eigen/Dense>

#include "dbacov/core/dot_products.h"
#include "dbacov/core/gauge.h"
#include "dbacov/core/kernel_isa.h"
#include "dbacov/core/linearization.h"
#include "dbacov/core/marginal_solver.h"
#include "dense_reference.h"
#include "fixtures.h"
#include "kernel_variants.h"

namespace dbacov {
namespace {

double relativeError(const Eigen::MatrixXd& a, const Eigen::MatrixXd& b) {
  return (a - b).norm() / std::max(1e-300, b.norm());
}

/// The hard two-pose gauge adds no prior to the reference's H: H is the pure JᵀΛJ.
DbaOptions hardGauge() {
  return testing::gaugeOptions(GaugeOptions::Type::TwoPose, 0, 0);
}

/// The snapshot with edge e appended once more (its own flow and weights again): two edges of one
/// source into one target, whose terms the kernel keeps apart and linearizeSource adds on one slot.
Snapshot withEdgeTwice(Snapshot s, int e) {
  const std::size_t plane = 2 * s.pixelsPerFrame(), at = static_cast<std::size_t>(e) * plane;
  s.ii.push_back(s.ii[e]);
  s.jj.push_back(s.jj[e]);
  const std::vector<float> t(s.target.begin() + at, s.target.begin() + at + plane);
  const std::vector<float> w(s.weight.begin() + at, s.weight.begin() + at + plane);
  s.target.insert(s.target.end(), t.begin(), t.end());
  s.weight.insert(s.weight.end(), w.begin(), w.end());
  return s;
}

// Every variant of the pixel kernel this CPU runs (kernel_isa.h: AVX2+FMA, the x86-64 baseline)
// against the same dense reference; the 8 × 10 grid ends in a short chunk of 16 lanes.
TEST(LinearizationStage, NormalEquationsEqualTheDenseJacobianProduct) {
  const sim::SyntheticSnapshot syn = testing::tinySnapshot(11, 0);
  for (const bool twice : {false, true})
    testing::forEachKernelIsa([&](kernel::Isa) {
      SCOPED_TRACE(twice ? "edge 0 twice" : "every edge once");
      const Snapshot s = twice ? withEdgeTwice(syn.snapshot, 0) : syn.snapshot;
      ASSERT_NO_THROW(s.validate());
      const DbaOptions o = hardGauge();
      const DbaNormalEquations ne = linearizeDba(s, o, true);
      const testing::DenseFullSystem ref = testing::denseFullSystem(s, o);
      const int np = ref.numPoseDims(), nd = static_cast<int>(ref.depth_vars.size());
      ASSERT_EQ(ne.keyframes, ref.keyframes);
      ASSERT_GT(nd, 0);

      const Eigen::MatrixXd Hpp = ref.H.topLeftCorner(np, np);
      const Eigen::MatrixXd Hpd = ref.H.topRightCorner(np, nd);
      const Eigen::VectorXd hdd = ref.H.bottomRightCorner(nd, nd).diagonal();
      // Hdd is diagonal: each depth is a scalar shared only by the factors of its pixel.
      EXPECT_LT((ref.H.bottomRightCorner(nd, nd) - Eigen::MatrixXd(hdd.asDiagonal())).norm(),
                1e-12 * hdd.norm());
      EXPECT_LT(relativeError(ne.Hpp.toDense(), Hpp), 1e-10);
      EXPECT_LT(relativeError(ne.g_p, ref.g.head(np)), 1e-10);

      // S = Hpp − Hpd Hdd⁻¹ Hdp and g_S = g_p − Hpd Hdd⁻¹ g_d, formed densely.
      const Eigen::VectorXd inv_h = hdd.cwiseInverse();
      const Eigen::MatrixXd S = Hpp - Hpd * inv_h.asDiagonal() * Hpd.transpose();
      const Eigen::VectorXd gS = ref.g.head(np) - Hpd * inv_h.cwiseProduct(ref.g.tail(nd));
      EXPECT_LT(relativeError(ne.S.toDense(), S), 1e-9);
      EXPECT_LT(relativeError(ne.g_S, gS), 1e-9);

      // The kept depth terms: h_k and the columns b_k of Hpd on the touched slots.
      std::size_t kept = 0;
      for (const DepthTerms& dt : ne.depths) {
        const int source = ne.keyframes[dt.source_slot];
        for (std::size_t c = 0; c < dt.pixel.size(); ++c, ++kept) {
          int var = -1;
          for (int v = 0; v < nd; ++v)
            if (ref.depth_vars[v] == std::make_pair(source, dt.pixel[c])) var = v;
          ASSERT_GE(var, 0);
          EXPECT_NEAR(dt.h[c], hdd[var], 1e-10 * hdd[var]);
          for (std::size_t t = 0; t < dt.touched.size(); ++t)
            EXPECT_LT((dt.B.block(6 * t, c, 6, 1) - Hpd.block(6 * dt.touched[t], var, 6, 1)).norm(),
                      1e-9 * (1 + Hpd.col(var).norm()));
        }
      }
      EXPECT_EQ(kept, static_cast<std::size_t>(nd));
      EXPECT_EQ(ne.stats.depths_used, static_cast<std::size_t>(nd));
    });
}

// The self-calibration's products over pixels (dot_products.h) against Eigen's, in every variant:
// sizes below, at and past the 2 × 4 block and the 4-wide vectors (odd rows, remainders), rows
// with padding between them, += into C, and with lower only the entries with column <= row
// written (the sentinels elsewhere must survive), for A = B (a rank update) and for A ≠ B of any
// shape (the likelihood's whitened products).
TEST(DotProducts, EqualTheDenseProductInEveryVariant) {
  std::srand(7);
  testing::forEachKernelIsa([&](kernel::Isa) {
    for (const int m : {1, 2, 3, 5, 8, 13})
      for (const int n : {1, 4, 6, 7, 13})
        for (const int K : {1, 3, 4, 9, 42})
          for (const int mode : {0, 1, 2}) {  // full; lower with A = B; lower with A ≠ B
            const bool lower = mode > 0, same = mode == 1;
            if (same && m != n) continue;
            const int lda = K + 3, ldb = K + 1, ldc = n + 2;
            const Eigen::MatrixXd A = Eigen::MatrixXd::Random(m, lda);
            const Eigen::MatrixXd B = same ? A : Eigen::MatrixXd::Random(n, ldb);
            const int ldB = same ? lda : ldb;
            using RowMajor = Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor>;
            const RowMajor Ar = A, Br = B;
            RowMajor C = RowMajor::Constant(m, ldc, 0.5);
            kernel::gemmNT(m, n, K, Ar.data(), lda, Br.data(), ldB, C.data(), ldc, lower);
            const Eigen::MatrixXd want = A.leftCols(K) * B.leftCols(K).transpose();
            for (int r = 0; r < m; ++r)
              for (int c = 0; c < ldc; ++c) {
                const bool written = c < n && (!lower || c <= r);
                const double expect = written ? 0.5 + want(r, c) : 0.5;
                ASSERT_NEAR(C(r, c), expect, 1e-13 * (1 + std::abs(expect)))
                    << m << " x " << n << " x " << K << (lower ? " lower" : "") << " at (" << r
                    << ", " << c << ")";
              }
          }
  });
}

TEST(LinearizationStage, AWrongJacobianIsCaught) {
  // The comparison above can fail: perturbing one pixel's target changes the dense product.
  const sim::SyntheticSnapshot syn = testing::tinySnapshot(12, 0);
  Snapshot s = syn.snapshot;
  const DbaOptions o = hardGauge();
  const DbaNormalEquations ne = linearizeDba(s, o);
  s.disps[s.pixelsPerFrame() * static_cast<std::size_t>(s.ii[0]) + 5] *= 1.5f;
  const testing::DenseFullSystem ref = testing::denseFullSystem(s, o);
  const int np = ref.numPoseDims();
  EXPECT_GT(relativeError(ne.Hpp.toDense(), ref.H.topLeftCorner(np, np)), 1e-8);
}

/// Σ of the poses (6 per slot) from the engine's gauge alone: S_r = reduceSystem(S), inverted
/// densely, mapped back with the bases.
Eigen::MatrixXd engineGaugeCovariance(const BlockSymmetricMatrix& S,
                                      const GaugeParameterization& g) {
  const Eigen::MatrixXd Sr_upper = Eigen::MatrixXd(reduceSystem(S, g));
  const Eigen::MatrixXd Sr = Sr_upper.selfadjointView<Eigen::Upper>();
  const Eigen::MatrixXd Cr = Sr.inverse();
  const int n = S.numSlots();
  Eigen::MatrixXd B = Eigen::MatrixXd::Zero(6 * n, g.dim());
  for (int a = 0; a < n; ++a) B.block(6 * a, g.offset[a], 6, g.dimOf(a)) = g.basis[a];
  return B * Cr * B.transpose();
}

class GaugeStage : public ::testing::TestWithParam<std::tuple<GaugeOptions::Type, double>> {};

TEST_P(GaugeStage, EqualsTheDenseProjectionOfTheSameS) {
  const auto [type, sigma] = GetParam();
  const sim::SyntheticSnapshot syn = testing::tinySnapshot(13, 0);
  const Snapshot& s = syn.snapshot;
  const DbaOptions o = testing::gaugeOptions(type, sigma, sigma);
  const DbaNormalEquations ne = linearizeDba(s, o);
  const GaugeParameterization g = makeGauge(o.gauge, s, ne.keyframes);
  const int np = 6 * static_cast<int>(ne.keyframes.size());

  // The reference's gauge (basis P over poses + depths, priors in H) on the dense Schur
  // complement of its own H: Σ_poses = [P (Pᵀ H P)⁻¹ Pᵀ]_poses.
  const testing::DenseFullSystem ref = testing::denseFullSystem(s, o);
  const Eigen::MatrixXd Cfull =
      ref.P * (ref.P.transpose() * ref.H * ref.P).inverse() * ref.P.transpose();
  const Eigen::MatrixXd expected = Cfull.topLeftCorner(np, np);
  const Eigen::MatrixXd got = engineGaugeCovariance(ne.S, g);
  EXPECT_LT(relativeError(got, expected), 1e-7) << toString(type) << " sigma " << sigma;

  // Hard-fixed directions have exactly zero covariance.
  for (int slot : g.gauge_slots) {
    if (g.dimOf(slot) == 0) {
      EXPECT_EQ(got.block(6 * slot, 6 * slot, 6, 6).norm(), 0.0);
    }
  }
}

INSTANTIATE_TEST_SUITE_P(Gauges, GaugeStage,
                         ::testing::Values(std::make_tuple(GaugeOptions::Type::TwoPose, 0.0),
                                           std::make_tuple(GaugeOptions::Type::TwoPose, 0.05),
                                           std::make_tuple(GaugeOptions::Type::Minimal, 0.0)));

// Where a factorization broke down, as the errors name it: the column (firstBadPivot, against
// matrices whose first bad pivot is known) and the slot that column belongs to (slots without
// free coordinates, as a hard gauge leaves them, own no column).
TEST(BreakdownColumn, FirstBadPivotAndItsSlot) {
  Eigen::MatrixXd S = Eigen::MatrixXd::Identity(5, 5);
  EXPECT_EQ(firstBadPivot(S), -1);
  S(3, 3) = -1;  // indefinite at column 3
  EXPECT_EQ(firstBadPivot(S), 3);
  // Column 2 a combination of columns 0 and 1: its pivot is round-off, below the relative limit.
  Eigen::MatrixXd A = Eigen::MatrixXd::Random(5, 5);
  A.col(2) = A.col(0) - 2.0 * A.col(1);
  EXPECT_EQ(firstBadPivot(A.transpose() * A), 2);
  // Eigen's LLT fails on the same matrices.
  EXPECT_NE(Eigen::LLT<Eigen::MatrixXd>(S).info(), Eigen::Success);

  GaugeParameterization g;
  g.offset = {0, 0, 5, 5, 11};  // slot 0 hard-fixed, slot 1 five free, slot 2 none, slot 3 six
  EXPECT_EQ(g.slotOfColumn(0), 1);
  EXPECT_EQ(g.slotOfColumn(4), 1);
  EXPECT_EQ(g.slotOfColumn(5), 3);
  EXPECT_EQ(g.slotOfColumn(10), 3);
}

TEST(OptionsBuilder, GaugeNamesTheTypeOnlyAndKeepsThePresetSigmas) {
  DbaOptionOverrides o;
  o.preset = Preset::Paper;
  o.gauge = GaugeOptions::Type::TwoPose;
  const DbaOptions p = o.resolve();
  EXPECT_EQ(p.gauge.sigma_rot, DbaOptions::paper().gauge.sigma_rot);
  EXPECT_EQ(p.gauge.sigma_trans, DbaOptions::paper().gauge.sigma_trans);
  o.gauge = GaugeOptions::Type::Minimal;
  EXPECT_EQ(o.resolve().gauge.sigma_rot, 0.0);
  o.gauge_sigma_rot = 0.1;
  EXPECT_THROW(o.resolve(), std::invalid_argument);
  o = {};
  o.min_depth_ratio = 0;
  EXPECT_FALSE(o.resolve().min_depth_ratio.has_value());
  o.weight_scale = -1;
  EXPECT_THROW(o.resolve(), std::invalid_argument);
}

TEST(EnumNames, ParseAndToStringAreInverseAndNameTheValidChoices) {
  for (const auto& name : enumNames<GaugeOptions::Type>())
    EXPECT_EQ(toString(parseEnum<GaugeOptions::Type>(name)), name);
  for (const auto& name : enumNames<Ordering>())
    EXPECT_EQ(toString(parseEnum<Ordering>(name)), name);
  try {
    parseEnum<GaugeOptions::Type>("three-pose");
    FAIL();
  } catch (const std::invalid_argument& e) {
    EXPECT_STREQ(e.what(), "unknown gauge 'three-pose', expected two-pose, minimal or droid");
  }
  EXPECT_THROW(parseEnum<SolverKind>("fast"), std::invalid_argument);
}

}  // namespace
}  // namespace dbacov
