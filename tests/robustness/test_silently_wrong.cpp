// Inputs that used to give plausible but wrong outputs with exit 0: near-singular
// systems reported as gauge-fixed keyframes, keyframes merged through duplicate tstamps, times
// that MRPT cannot represent. Each is refused with a message naming the file, key, keyframe or
// option, and the other snapshots' outputs are complete.
#include <cmath>
#include <filesystem>

#include <gtest/gtest.h>

#include "app_runner.h"
#include "bad_inputs.h"
#include "dbacov/app/covariance_app.h"
#include "dbacov/app/droid2rawlog_app.h"
#include "dbacov/core/covariance.h"
#include "dbacov/io/snapshot_npz.h"
#include "fixtures.h"
#include "temp_dir.h"

namespace dbacov {
namespace silently_wrong {  // not anonymous: the suite is compiled as a unity build

using testing::AppResult;

AppResult covariance(const std::vector<std::string>& args) {
  return testing::runApp(app::runCovarianceApp, "dba-covariance", args);
}

/// log10_det (column 10) is -inf only when a variance (cov_00, cov_11, ...) is zero.
void expectMinusInfOnlyWhenFixed(const std::string& row) {
  const auto f = testing::splitCsv(row);
  ASSERT_EQ(f.size(), 16u + 21 + 1);  // ..., cov_55, noise_model
  if (f[10] != "-inf") return;
  bool zero_variance = false;
  for (int d = 0, col = 16; d < 6; col += 6 - d, ++d) zero_variance |= std::stod(f[col]) == 0;
  EXPECT_TRUE(zero_variance) << "a free keyframe reported as fixed: " << row;
}

/// A good snapshot (id 1) and a damaged one (id 2) in `dir`; returns the damaged file's path.
std::string goodAndBad(const testing::TempDir& dir,
                       const std::function<void(testing::NpzArrays&)>& damage) {
  testing::writeTinySnapshot(dir.file("a.npz"), 1, 1);
  testing::NpzArrays arrays = testing::snapshotArrays(testing::tinySnapshot(2, 2).snapshot);
  damage(arrays);
  testing::writeArrays(dir.file("b.npz"), arrays);
  return dir.file("b.npz");
}

/// The CSV rows of the good snapshot only (header + 6 keyframes). A row reads log10_det = -inf
/// only for a keyframe that the gauge fixed (its covariance has a zero variance), never for a
/// free one.
void expectOnlyTheGoodSnapshot(const std::string& csv) {
  const auto lines = testing::splitLines(testing::readFile(csv));
  ASSERT_EQ(lines.size(), 1u + 6);
  for (std::size_t i = 1; i < lines.size(); ++i) {
    EXPECT_EQ(lines[i].rfind("1,", 0), 0u) << lines[i];
    expectMinusInfOnlyWhenFixed(lines[i]);
  }
}

TEST(SilentlyWrong, NearSingularSystemsAreNumericalFailuresNotFixedKeyframes) {
  struct Case {
    std::string name;
    std::function<void(testing::NpzArrays&)> damage;
  };
  for (const Case& c : std::vector<Case>{
           {"inverse depths around 1e-6",
            [](testing::NpzArrays& a) {
              io::NpyArray& d = testing::arrayOf(a, "disps");
              const auto v = io::npyToDoubles(d, "");
              for (std::size_t i = 0; i < v.size(); ++i) testing::setValue(d, i, v[i] * 1e-6);
            }},
       }) {
    SCOPED_TRACE(c.name);
    testing::TempDir dir;
    const std::string bad = goodAndBad(dir, c.damage);
    const AppResult r = covariance(
        {"-i", dir.file("a.npz"), "-i", bad, "--csv", dir.file("k.csv"), "--weight-scale", "4"});
    EXPECT_EQ(r.code, 1);
    const std::string prefix =
        "dba-covariance: error: " + bad + " (snapshot 2): the covariances of keyframes ";
    EXPECT_EQ(r.err.rfind(prefix, 0), 0u) << r.err;
    EXPECT_NE(r.err.find(" are numerically singular (condition number "), std::string::npos);
    EXPECT_NE(r.err.find(" > 1e14 over their free DoF): their poses are not determined in double "
                         "precision; check the scale of the inverse depths 'disps' and of the "
                         "focal lengths 'intrinsics'\n"),
              std::string::npos)
        << r.err;
    EXPECT_NE(r.err.find("2 snapshots read, 1 processed, 1 failed: 1 numerical"), std::string::npos)
        << r.err;
    expectOnlyTheGoodSnapshot(dir.file("k.csv"));
    // The library says the same through its API.
    const Snapshot s = io::loadSnapshotNpz(bad, 2);
    EXPECT_THROW(DbaCovariance(s, testing::gaugeOptions(GaugeOptions::Type::TwoPose, 0, 0)),
                 NumericalError);
  }
}

TEST(SilentlyWrong, ScaledFocalLengthsAreRefusedOrReportedAsFree) {
  // Focal lengths ×1e-5 scale the information by 1e-10; with the droid preset's soft gauge
  // priors the system may stay well conditioned (then every keyframe is reported with finite
  // criteria) or not (then the snapshot fails as numerical): never a free keyframe shown fixed.
  testing::TempDir dir;
  const std::string bad = goodAndBad(dir, [](testing::NpzArrays& a) {
    io::NpyArray& k = testing::arrayOf(a, "intrinsics");
    const auto v = io::npyToDoubles(k, "");
    for (std::size_t i = 0; i < 4; ++i) testing::setValue(k, i, v[i] * 1e-5);
  });
  const AppResult r = covariance({"-i", bad, "--csv", dir.file("k.csv")});
  if (r.code == 0) {
    for (const std::string& row : testing::splitLines(testing::readFile(dir.file("k.csv"))))
      if (row.rfind("snapshot,", 0) != 0) expectMinusInfOnlyWhenFixed(row);
  } else {
    EXPECT_NE(r.err.find(" are numerically singular (condition number "), std::string::npos)
        << r.err;
  }
}

TEST(SilentlyWrong, DuplicateTstampsAreRefusedNotMerged) {
  testing::TempDir dir;
  double value = 0;
  const std::string bad = goodAndBad(dir, [&](testing::NpzArrays& a) {
    io::NpyArray& t = testing::arrayOf(a, "tstamp");
    value = io::npyToDoubles(t, "")[2];
    testing::setValue(t, 4, value);
  });
  for (const std::vector<std::string>& outputs :
       {std::vector<std::string>{"-o", dir.file("p.rawlog"), "--emit", "final"},
        std::vector<std::string>{"--plots", dir.file("plots")},
        std::vector<std::string>{"--scene", dir.file("s.3Dscene")}}) {
    SCOPED_TRACE(outputs[0]);
    std::vector<std::string> args{
        "-i", dir.file("a.npz"), "-i", bad, "--csv", dir.file("k.csv"), "--weight-scale", "4"};
    args.insert(args.end(), outputs.begin(), outputs.end());
    const AppResult r = covariance(args);
    EXPECT_EQ(r.code, 1);
    std::ostringstream v;
    v.precision(17);
    v << value;
    EXPECT_EQ(r.err, "dba-covariance: error: " + bad +
                         ": key 'tstamp' gives keyframes 2 and 4 "
                         "the same value " +
                         v.str() +
                         ": a keyframe is identified by its tstamp (the image index), expected "
                         "distinct values\ndba-covariance: 2 snapshots read, 1 processed, 1 "
                         "failed: 1 invalid input (b.npz)\n");
    expectOnlyTheGoodSnapshot(dir.file("k.csv"));
  }
}

TEST(SilentlyWrong, TimesThatMrptCannotRepresentAreRefused) {
  testing::TempDir dir;
  const std::string bad = goodAndBad(dir, [](testing::NpzArrays& a) {
    testing::setValue(testing::arrayOf(a, "timestamps_s"), 5, -1.0);
  });
  const std::string what =
      " s, which MRPT cannot represent: expected 0 < t <= 1e10 s since 1970; give such times (key "
      "'timestamps_s', or --fps with --start-time)";
  const Snapshot b = io::loadSnapshotNpz(bad, 2);
  const std::string kf5 =
      "keyframe 5 (tstamp " + std::to_string(static_cast<long long>(b.tstamp[5])) + ")";
  AppResult r = covariance({"-i", dir.file("a.npz"), "-i", bad, "--csv", dir.file("k.csv"), "-o",
                            dir.file("p.rawlog"), "--weight-scale", "4"});
  EXPECT_EQ(r.code, 1);
  EXPECT_EQ(r.err, "dba-covariance: error: " + bad + " (snapshot 2): " + kf5 + " has the time -1" +
                       what +
                       "\ndba-covariance: 2 snapshots read, 1 processed, 1 failed: 1 "
                       "invalid input (b.npz)\n");
  expectOnlyTheGoodSnapshot(dir.file("k.csv"));
  r = testing::runApp(app::runDroid2RawlogApp, "droid2rawlog",
                      {"-i", bad, "-o", dir.file("s.rawlog"), "-q"});
  EXPECT_EQ(r.code, 1);
  EXPECT_EQ(r.err, "droid2rawlog: error: " + bad + " (snapshot 2): " + kf5 + " has the time -1" +
                       what + "\n");
  EXPECT_FALSE(std::filesystem::exists(dir.file("s.rawlog")));

  // --fps: NaN, infinite and zero rates are bad usage, in every app.
  auto untimed = testing::tinySnapshot(3, 3).snapshot;
  untimed.timestamps_s.reset();
  io::saveSnapshotNpz(dir.file("u.npz"), untimed);
  for (const std::string fps : {"nan", "inf", "0"}) {
    SCOPED_TRACE(fps);
    for (const auto& [app, name] : std::vector<std::pair<testing::AppMain, std::string>>{
             {app::runCovarianceApp, "dba-covariance"},
             {app::runDroid2RawlogApp, "droid2rawlog"}}) {
      r = testing::runApp(app, name,
                          {"-i", dir.file("u.npz"), "-o", dir.file("u.rawlog"), "--fps", fps});
      EXPECT_EQ(r.code, 2);
      EXPECT_EQ(r.err, name + ": --fps " + fps +
                           ": expected a finite positive frame rate (frames per second)\nRun with "
                           "--help for usage.\n");
    }
  }
  // 1e-300 is finite, but tstamp / fps is not a time: the snapshot fails naming the keyframe.
  r = covariance({"-i", dir.file("u.npz"), "-o", dir.file("u.rawlog"), "--fps", "1e-300"});
  EXPECT_EQ(r.code, 1);
  EXPECT_NE(r.err.find(dir.file("u.npz") + " (snapshot 3): keyframe "), std::string::npos) << r.err;
  EXPECT_NE(r.err.find(what), std::string::npos) << r.err;
  EXPECT_FALSE(std::filesystem::exists(dir.file("u.rawlog")));
  // tstamp 0 at --fps 20 is time 0, MRPT's "no time": refused where MRPT times are written (-o,
  // droid2rawlog's object times), naming the keyframe and the fix; --start-time moves the times.
  auto zero = untimed;  // its first graph keyframe at tstamp 0
  const int kf0 = zero.graphKeyframes().front();
  const double t0 = zero.tstamp[kf0];
  for (double& t : zero.tstamp) t -= t0;
  io::saveSnapshotNpz(dir.file("u.npz"), zero);
  r = covariance({"-i", dir.file("u.npz"), "-o", dir.file("u.rawlog"), "--emit", "all", "--fps",
                  "20", "-q", "--weight-scale", "4"});
  EXPECT_EQ(r.code, 1);
  EXPECT_EQ(r.err, "dba-covariance: error: " + dir.file("u.npz") + " (snapshot 3): keyframe " +
                       std::to_string(kf0) +
                       " (tstamp 0) has the time 0 s, which MRPT reads as \"no time\" "
                       "(INVALID_TIMESTAMP): expected 0 < t <= 1e10 s since 1970; give "
                       "--start-time T (time = T + tstamp / fps, T > 0, e.g. the recording's "
                       "start in seconds since 1970) or 'timestamps_s' > 0\n");
  EXPECT_FALSE(std::filesystem::exists(dir.file("u.rawlog")));
  // The tables keep time 0 (time_s is not an MRPT time).
  r = covariance({"-i", dir.file("u.npz"), "--csv", dir.file("u.csv"), "--fps", "20", "-q",
                  "--weight-scale", "4"});
  EXPECT_EQ(r.code, 0) << r.err;
  r = covariance({"-i", dir.file("u.npz"), "-o", dir.file("u.rawlog"), "--fps", "20",
                  "--start-time", "1700000000", "-q", "--weight-scale", "4"});
  EXPECT_EQ(r.code, 0) << r.err;
  EXPECT_TRUE(std::filesystem::exists(dir.file("u.rawlog")));
}

}  // namespace silently_wrong
}  // namespace dbacov
