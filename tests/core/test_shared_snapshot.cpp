// The real DROID-SLAM snapshot of ../shared/data (conventions §1): conventions, covariance
// properties.
#include <filesystem>

#include <gtest/gtest.h>
#include <Eigen/Eigenvalues>

#include "dbacov/core/covariance.h"
#include "dbacov/core/reprojection.h"
#include "dbacov/io/snapshot_npz.h"

namespace dbacov {
namespace {

const std::string kShared = std::string(DBACOV_SHARED_DATA_DIR) + "/droid_window_0055.npz";

class SharedSnapshot : public ::testing::Test {
 protected:
  void SetUp() override {
    if (!std::filesystem::exists(kShared)) GTEST_SKIP() << "missing " << kShared;
    snapshot_ = io::loadSnapshotNpz(kShared, 0);
  }
  Snapshot snapshot_;
};

TEST_F(SharedSnapshot, ReprojectionErrorAtStoredStateIsSubPixel) {
  DbaOptions o = DbaOptions::droid();
  const double med = weightedMedian(reprojectionErrors(snapshot_, o));
  EXPECT_LT(med, 0.1);
  // The conventions matter: treating the poses as camera-to-world breaks the fit (conventions §1:
  // ~13 px).
  Snapshot wrong = snapshot_;
  for (int k = 0; k < wrong.numKeyframes(); ++k) wrong.setT_wc(k, snapshot_.T_cw(k));
  o.min_depth_ratio.reset();
  EXPECT_GT(weightedMedian(reprojectionErrors(wrong, o)), 1.0);
}

void expectSpd(const Matrix6d& S, const std::string& what) {
  EXPECT_LT((S - S.transpose()).norm(), 1e-12 * S.norm()) << what;
  EXPECT_GT(Eigen::SelfAdjointEigenSolver<Matrix6d>(S).eigenvalues().minCoeff(), 0.0) << what;
}

TEST_F(SharedSnapshot, DroidPresetGivesSpdCovariancesAndZeroForFixedKeyframes) {
  const DbaCovariance cov(snapshot_, DbaOptions::droid());
  EXPECT_EQ(cov.keyframes(), (std::vector<int>{1, 2, 3, 4, 5, 6, 7, 8, 9, 10}));  // 0 has no edge
  EXPECT_EQ(cov.gaugeKeyframes(), (std::vector<int>{1, 2}));
  for (int k : cov.keyframes()) {
    if (k <= 2) {
      EXPECT_EQ(cov.marginal(k), Matrix6d::Zero()) << "hard-fixed keyframe " << k;
      continue;
    }
    expectSpd(cov.marginal(k), "keyframe " + std::to_string(k));
  }
  EXPECT_GT(cov.stats().factors_used, 100000u);
}

TEST_F(SharedSnapshot, PaperPresetGaugeCovarianceNeverExceedsItsPrior) {
  const DbaOptions o = DbaOptions::paper();
  const DbaCovariance cov(snapshot_, o);
  Vector6d prior_var;
  prior_var << Eigen::Vector3d::Constant(o.gauge.sigma_trans * o.gauge.sigma_trans),
      Eigen::Vector3d::Constant(o.gauge.sigma_rot * o.gauge.sigma_rot);
  for (int k : cov.keyframes()) {
    const Matrix6d S = cov.marginal(k);
    expectSpd(S, "keyframe " + std::to_string(k));
    if (k > 2) continue;
    // Loewner order: prior − Σ is positive semi-definite (to round-off: the data add little to
    // the gauge keyframes, so Σ is within ~1e-10 of the prior in some directions).
    const Matrix6d gap = Matrix6d(prior_var.asDiagonal()) - S;
    EXPECT_GE(Eigen::SelfAdjointEigenSolver<Matrix6d>(gap).eigenvalues().minCoeff(),
              -1e-9 * prior_var.maxCoeff())
        << "gauge keyframe " << k;
  }
}

TEST_F(SharedSnapshot, MinimalGaugeRemovesExactlySevenDof) {
  DbaOptions o = DbaOptions::droid();
  o.gauge.type = GaugeOptions::Type::Minimal;
  const DbaCovariance cov(snapshot_, o);
  EXPECT_EQ(cov.freeDof(1), 0);
  EXPECT_EQ(cov.freeDof(2), 5);
  // The second keyframe keeps its rotation uncertainty.
  const Matrix6d S2 = cov.marginal(2);
  EXPECT_GT(Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d>(S2.bottomRightCorner<3, 3>())
                .eigenvalues()
                .minCoeff(),
            0);
}

}  // namespace
}  // namespace dbacov
