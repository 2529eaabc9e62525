// Valid files whose graphs are bad: keyframes outside the graph, disconnected parts, a single
// source keyframe, degenerate geometry (all depths at DROID's clamp, zero baseline). Each is
// either processed correctly or refused with the exact numerical reason naming the keyframes,
// the other snapshots of the run are still written, and no output holds a NaN.
#include <algorithm>
#include <filesystem>
#include <functional>
#include <set>

#include <gtest/gtest.h>
#include <Eigen/Eigenvalues>

#include "app_runner.h"
#include "dbacov/app/covariance_app.h"
#include "dbacov/core/covariance.h"
#include "fixtures.h"
#include "temp_dir.h"

namespace dbacov {
namespace bad_graphs {  // not anonymous: the suite is compiled as a unity build

using testing::AppResult;

AppResult run(const std::vector<std::string>& args) {
  return testing::runApp(app::runCovarianceApp, "dba-covariance", args);
}

/// Keeps only the edges for which `keep(i, j)` holds.
void keepEdges(Snapshot& s, const std::function<bool(std::int64_t, std::int64_t)>& keep) {
  Snapshot out = s;
  out.ii.clear(), out.jj.clear(), out.target.clear(), out.weight.clear();
  const std::size_t plane = 2 * s.pixelsPerFrame();
  for (int e = 0; e < s.numEdges(); ++e) {
    if (!keep(s.ii[e], s.jj[e])) continue;
    out.ii.push_back(s.ii[e]);
    out.jj.push_back(s.jj[e]);
    out.target.insert(out.target.end(), s.target.begin() + e * plane,
                      s.target.begin() + (e + 1) * plane);
    out.weight.insert(out.weight.end(), s.weight.begin() + e * plane,
                      s.weight.begin() + (e + 1) * plane);
  }
  s = out;
}

struct BadGraph {
  std::string name;
  std::function<void(Snapshot&)> edit;
  std::vector<std::string> extra_args;
  std::string expected;  ///< the error after "<path> (snapshot 2): ", "" = processed normally
};

void PrintTo(const BadGraph& c, std::ostream* os) {
  *os << c.name;
}

std::vector<BadGraph> corpus() {
  return {
      {"disconnected",
       [](Snapshot& s) { keepEdges(s, [](auto i, auto j) { return (i < 3) == (j < 3); }); },
       {},
       "no gauge reaches keyframes 3, 4, 5: they share no information with gauge keyframes 0, 1 "
       "(disconnected part of the graph)"},
      {"single_source_keyframe",
       [](Snapshot& s) { keepEdges(s, [](auto i, auto) { return i == 2; }); },
       {},
       "the gauge needs two keyframes in 'ii', found only keyframe 2"},
      {"keyframe_without_information",
       [](Snapshot& s) {
         const std::size_t plane = 2 * s.pixelsPerFrame();
         for (int e = 0; e < s.numEdges(); ++e)
           if (s.ii[e] == 4 || s.jj[e] == 4)
             std::fill(s.weight.begin() + e * plane, s.weight.begin() + (e + 1) * plane, 0.0f);
       },
       {},
       "no gauge reaches keyframes 4: they share no information with gauge keyframes 0, 1 "
       "(disconnected part of the graph)"},
      // Degenerate but valid: computed (first-order covariances of a nearly or exactly
      // unobservable geometry); DegenerateGeometryGivesHugeFiniteCovariances checks the values.
      {"all_depths_at_the_clamp",
       [](Snapshot& s) { std::fill(s.disps.begin(), s.disps.end(), 0.001f); },
       {},
       ""},
      {"zero_baseline",
       [](Snapshot& s) {
         for (int k = 1; k < s.numKeyframes(); ++k) s.poses_cw.row(k) = s.poses_cw.row(0);
       },
       {},
       ""},
      {"zero_baseline_minimal_gauge",
       [](Snapshot& s) { s.poses_cw.row(1) = s.poses_cw.row(0); },
       {"--gauge", "minimal"},
       "minimal gauge: keyframes 0, 1 share one centre, so their distance cannot fix the scale"},
      {"one_edge_without_weights",
       [](Snapshot& s) {
         std::fill(s.weight.begin(), s.weight.begin() + 2 * s.pixelsPerFrame(), 0.0f);
       },
       {},
       ""},
  };
}

class BadGraphTest : public ::testing::TestWithParam<BadGraph> {};

TEST_P(BadGraphTest, IsRefusedWithTheKeyframesOrProcessedAndTheOthersAreWritten) {
  const BadGraph& c = GetParam();
  testing::TempDir dir;
  std::filesystem::create_directory(dir.file("in"));
  testing::writeTinySnapshot(dir.file("in/a.npz"), 1, 1);
  Snapshot bad = testing::tinySnapshot(2, 2).snapshot;
  c.edit(bad);
  io::saveSnapshotNpz(dir.file("in/b.npz"), bad);
  testing::writeTinySnapshot(dir.file("in/c.npz"), 3, 3);
  std::vector<std::string> args{"-i",
                                dir.file("in"),
                                "--csv",
                                dir.file("k.csv"),
                                "--relative-csv",
                                dir.file("r.csv"),
                                "--depth-sigma",
                                dir.file("sigma"),
                                "--weight-scale",
                                "4"};
  args.insert(args.end(), c.extra_args.begin(), c.extra_args.end());
  const AppResult r = run(args);
  const std::string csv =
      testing::readFile(dir.file("k.csv")) + testing::readFile(dir.file("r.csv"));
  EXPECT_EQ(csv.find("nan"), std::string::npos);
  std::set<std::string> ids;
  for (const auto& line : testing::splitLines(testing::readFile(dir.file("k.csv"))))
    ids.insert(testing::splitCsv(line)[0]);
  if (c.expected.empty()) {
    EXPECT_EQ(r.code, 0) << r.err;
    EXPECT_EQ(r.err, "dba-covariance: 3 snapshots read, 3 processed, 0 failed\n");
    EXPECT_EQ(ids, (std::set<std::string>{"snapshot", "1", "2", "3"}));
    return;
  }
  // The summary keeps the first clause of the reason when it is not too short (run_summary.h).
  const std::size_t colon = c.expected.find(": ");
  const std::string reason =
      colon != std::string::npos && colon >= 20 ? c.expected.substr(0, colon) : c.expected;
  EXPECT_EQ(r.code, 1);
  EXPECT_EQ(r.err, "dba-covariance: error: " + dir.file("in/b.npz") + " (snapshot 2): " +
                       c.expected + "\ndba-covariance: 3 snapshots read, 2 processed, 1 failed: " +
                       "1 numerical (b.npz: " + reason + ")\n");
  EXPECT_EQ(ids, (std::set<std::string>{"snapshot", "1", "3"}));
  for (int k = 0; k < 6; ++k)
    EXPECT_FALSE(std::filesystem::exists(dir.file("sigma/2_" + std::to_string(k) + ".npy")));
}

INSTANTIATE_TEST_SUITE_P(Corpus, BadGraphTest, ::testing::ValuesIn(corpus()),
                         [](const auto& p) { return p.param.name; });

TEST(BadGraphs, ValuesThatOverflowDoublePrecisionGiveANumericalErrorNotNaN) {
  // Found by fuzz_rawlog (regressions/rawlog/principal_point_1e154_overflows_the_covariance):
  // intrinsics far out of range pass validation (finite; a rawlog keeps float64 intrinsics), and
  // the factor's products overflow. Each case must end in a NumericalError, never in NaN. Which
  // check fires for the principal point depends on the order of the overflowing sums (compiler,
  // optimization, instruction set): the overflow check, the conditioning check (condition number
  // 4.9e295 with GCC 12 -O3 and AVX2 since the kernel sums only J_j's blocks) or the Cholesky
  // breakdown (clang -O1, the sanitizer tree); each names the keyframes.
  struct Case {
    int intrinsic;
    double value;
    std::vector<std::string> accepted;  ///< the message starts with one of these
  };
  for (const Case& c : std::vector<Case>{
           {0,
            1e153,
            {"the information matrix has non-finite entries at keyframe 0: the snapshot's values "
             "overflow double precision in the DBA factor (intrinsics, poses or inverse depths "
             "far out of range)"}},
           {2,
            1e140,
            {"the covariances of keyframes 4, 5 overflow double precision (the information "
             "matrix is numerically singular)",
             "the covariances of keyframes 2, 3, 4, 5 are numerically singular (condition "
             "number ",
             "the reduced information matrix S is not positive definite (breakdown at keyframe "
             "4): "}}}) {
    SCOPED_TRACE(c.accepted[0]);
    Snapshot s = testing::tinySnapshot(2, 2).snapshot;
    s.intrinsics[c.intrinsic] = c.value;
    ASSERT_NO_THROW(s.validate());
    DbaOptions o = DbaOptions::droid();
    o.weight_scale = 4;
    try {
      const DbaCovariance cov(s, o);
      ADD_FAILURE() << "expected a NumericalError";
    } catch (const NumericalError& e) {
      const std::string what = e.what();
      EXPECT_TRUE(std::any_of(c.accepted.begin(), c.accepted.end(), [&](const std::string& a) {
        return what.rfind(a, 0) == 0;
      })) << what;
    }
  }
}

TEST(BadGraphs, DegenerateGeometryGivesHugeFiniteCovariances) {
  DbaOptions o = DbaOptions::droid();
  o.weight_scale = 4;
  const Snapshot normal = testing::tinySnapshot(2, 2).snapshot;
  Snapshot clamped = normal, still = normal;
  std::fill(clamped.disps.begin(), clamped.disps.end(), 0.001f);
  for (int k = 1; k < still.numKeyframes(); ++k) still.poses_cw.row(k) = still.poses_cw.row(0);
  const DbaCovariance a(normal, o), b(clamped, o), c(still, o);
  for (int k = 2; k < 6; ++k) {
    SCOPED_TRACE(k);
    for (const DbaCovariance* cov : {&a, &b, &c}) {
      const Matrix6d S = cov->marginal(k);
      EXPECT_TRUE(S.allFinite());
      EXPECT_GT(Eigen::SelfAdjointEigenSolver<Matrix6d>(S).eigenvalues().minCoeff(), 0);
    }
    // Translation is seen through d·t: with every depth 1000 × farther (d = 0.001 instead of
    // about 1) its variance grows by orders of magnitude; rotation hardly changes.
    const double trans_a = a.marginal(k).topLeftCorner(3, 3).trace();
    const double trans_b = b.marginal(k).topLeftCorner(3, 3).trace();
    const double rot_a = a.marginal(k).bottomRightCorner(3, 3).trace();
    const double rot_b = b.marginal(k).bottomRightCorner(3, 3).trace();
    EXPECT_GT(trans_b, 1e4 * trans_a);
    EXPECT_LT(rot_b, 1e2 * rot_a);
  }
}

}  // namespace bad_graphs
}  // namespace dbacov
