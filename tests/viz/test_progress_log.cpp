// The progress line of a run whose standard error is a log file (not a terminal): one plain line
// per period with items done, rate and estimate; nothing with --quiet. No test depends on timing:
// the clock is injected, or the period is 0 (DBACOV_PROGRESS_PERIOD).
#include <fcntl.h>
#include <stdlib.h>
#include <unistd.h>

#include <filesystem>
#include <sstream>

#include <gtest/gtest.h>

#include "app_runner.h"
#include "dbacov/app/covariance_app.h"
#include "dbacov/app/progress.h"
#include "dbacov/app/simul_app.h"
#include "dbacov/io/snapshot_npz.h"
#include "temp_dir.h"
#include "viz_fixtures.h"

namespace dbacov {
namespace {

using app::Progress;

TEST(ProgressLog, LineShowsDoneRateElapsedAndEstimate) {
  EXPECT_EQ(Progress::formatLogLine(12, 24, 4, "snapshots"),
            "progress: 12/24 snapshots (50%), 3 snapshots/s, 4 s elapsed, ~4 s left");
  EXPECT_EQ(Progress::formatLogLine(0, 24, 5, "snapshots"),
            "progress: 0/24 snapshots (0%), 5 s elapsed");
  EXPECT_EQ(Progress::formatLogLine(7, 0, 2, "snapshots"),
            "progress: 7 snapshots, 3.5 snapshots/s, 2 s elapsed");
  EXPECT_EQ(Progress::formatLogLine(1, 3, 4000, "snapshots"),
            "progress: 1/3 snapshots (33%), 0.00025 snapshots/s, 1 h 06 min elapsed, ~2 h 13 min "
            "left");
}

/// The log display (standard error not a terminal) with a 5 s period, on the clock `t`.
Progress::Display logEveryFiveSeconds(const double& t) {
  Progress::Display d;
  d.log = true;
  d.log_period_s = 5;
  d.clock = [&t] { return t; };
  return d;
}

TEST(ProgressLog, OneLinePerPeriodOnAnInjectedClock) {
  double t = 100;
  const Progress::Display d = logEveryFiveSeconds(t);
  std::ostringstream err;
  {
    Progress p(err, 10, d);
    for (int i = 0; i < 10; ++i) {
      p.step("s" + std::to_string(i));  // item i starts at t = 100 + 2 i
      t += 2;
    }
  }
  // Lines when 5 s have passed since the previous one: at t = 106 (items 0..2 done), 112, 118.
  EXPECT_EQ(err.str(),
            "progress: 3/10 snapshots (30%), 0.5 snapshots/s, 6 s elapsed, ~14 s left\n"
            "progress: 6/10 snapshots (60%), 0.5 snapshots/s, 12 s elapsed, ~8 s left\n"
            "progress: 9/10 snapshots (90%), 0.5 snapshots/s, 18 s elapsed, ~2 s left\n");
}

TEST(ProgressLog, StatusOfOneLongItemEndsTheLogLine) {
  double t = 0;
  const Progress::Display d = logEveryFiveSeconds(t);
  std::ostringstream err;
  {
    Progress p(err, 1, d);
    p.step("snapshot_0000.npz");
    for (int it = 1; it <= 4; ++it) {
      t += 3;
      p.status("snapshot_0000.npz: DBA solve, iteration " + std::to_string(it));
    }
  }
  // Lines at t = 6 and 12 (5 s after the start, then after the previous line).
  EXPECT_EQ(err.str(),
            "progress: 0/1 snapshots (0%), 6 s elapsed: snapshot_0000.npz: DBA solve, iteration "
            "2\n"
            "progress: 0/1 snapshots (0%), 12 s elapsed: snapshot_0000.npz: DBA solve, iteration "
            "4\n");
}

/// Runs `body` with file descriptor 2 replaced by `fd`.
template <class F>
void withStderr(int fd, F body) {
  const int saved = ::dup(2);
  ::dup2(fd, 2);
  body();
  ::dup2(saved, 2);
  ::close(saved);
}

TEST(ProgressLog, DbaCovarianceWithStderrInAFilePrintsProgressLines) {
  testing::TempDir dir;
  std::filesystem::create_directories(dir.file("in"));
  for (int s = 0; s < 3; ++s)
    io::saveSnapshotNpz(dir.file("in/snap_" + std::to_string(s) + ".npz"),
                        testing::windowSnapshot(s, 5));
  const int log = ::open(dir.file("stderr.log").c_str(), O_WRONLY | O_CREAT | O_TRUNC, 0644);
  ASSERT_GE(log, 0);
  ASSERT_EQ(::isatty(log), 0);
  ::setenv("DBACOV_PROGRESS_PERIOD", "0", 1);  // a line at every snapshot, whatever the speed
  testing::AppResult r, quiet;
  withStderr(log, [&] {
    r = testing::runApp(app::runCovarianceApp, "dba-covariance",
                        {"-i", dir.file("in"), "--weight-scale", "4", "--csv", dir.file("k.csv")});
    quiet = testing::runApp(
        app::runCovarianceApp, "dba-covariance",
        {"-i", dir.file("in"), "--weight-scale", "4", "--csv", dir.file("k.csv"), "-q"});
  });
  ::unsetenv("DBACOV_PROGRESS_PERIOD");
  ::close(log);
  ASSERT_EQ(r.code, 0) << r.err;
  const auto lines = testing::splitLines(r.err);
  ASSERT_EQ(lines.size(), 4u) << r.err;  // 3 progress lines, then the summary
  EXPECT_EQ(lines[0].rfind("progress: 0/3 snapshots (0%), ", 0), 0u) << lines[0];
  EXPECT_EQ(lines[1].rfind("progress: 1/3 snapshots (33%), ", 0), 0u) << lines[1];
  EXPECT_NE(lines[1].find(" left"), std::string::npos) << lines[1];
  EXPECT_EQ(lines[2].rfind("progress: 2/3 snapshots (66%), ", 0), 0u) << lines[2];
  EXPECT_EQ(r.err.find('\r'), std::string::npos) << "no terminal control in a log";
  EXPECT_EQ(r.err.find('\033'), std::string::npos);
  EXPECT_EQ(lines[3].rfind("dba-covariance: 3 snapshots read, 3 processed", 0), 0u) << lines[3];
  EXPECT_EQ(quiet.code, 0);
  EXPECT_EQ(quiet.err, "") << "-q";
}

TEST(ProgressLog, SimulatingAWholeTrajectoryShowsTheSolvesIterations) {
  testing::TempDir dir;
  const int log = ::open(dir.file("stderr.log").c_str(), O_WRONLY | O_CREAT | O_TRUNC, 0644);
  ASSERT_GE(log, 0);
  ::setenv("DBACOV_PROGRESS_PERIOD", "0", 1);
  testing::AppResult r;
  withStderr(log, [&] {
    r = testing::runApp(app::runSimulApp, "simul-dba",
                        {"-o", dir.file("w"), "--mode", "whole", "--keyframes", "8", "--width",
                         "16", "--height", "12"});
  });
  ::unsetenv("DBACOV_PROGRESS_PERIOD");
  ::close(log);
  ASSERT_EQ(r.code, 0) << r.err;
  const auto lines = testing::splitLines(r.err);
  ASSERT_GE(lines.size(), 3u) << r.err;
  EXPECT_EQ(lines[0].rfind("progress: 0/1 snapshots (0%), ", 0), 0u) << lines[0];
  EXPECT_NE(lines[1].find(" elapsed: snapshot_0000.npz: DBA solve, iteration 1, cost "),
            std::string::npos)
      << lines[1];
}

}  // namespace
}  // namespace dbacov
