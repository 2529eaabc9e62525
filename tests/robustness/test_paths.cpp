// Paths that cannot be used: empty or unreadable input directories, inputs that are not regular
// files, unwritable outputs. An unusable input among usable ones is one failed input (the others
// are processed and written); when no input is usable, or an output cannot be created, the run
// stops before anything is read or written. Checked in-process and with the real executables.
#include <sys/stat.h>
#include <unistd.h>

#include <filesystem>

#include <gtest/gtest.h>

#include "app_runner.h"
#include "dbacov/app/covariance_app.h"
#include "dbacov/app/droid2rawlog_app.h"
#include "fixtures.h"
#include "temp_dir.h"

namespace dbacov {
namespace paths {  // not anonymous: the suite is compiled as a unity build

using testing::AppResult;
namespace fs = std::filesystem;

const std::string kBin = std::string(DBACOV_BINARY_DIR) + "/bin/";

AppResult covariance(const std::vector<std::string>& args) {
  return testing::runApp(app::runCovarianceApp, "dba-covariance", args);
}

/// What Linux answers when a file is created in /proc (even for root).
const std::string kNoFiles = "No such file or directory";

/// The real dba-covariance, as a user that file permissions apply to. Permissions deny nothing
/// to root, and CI containers often run as root: there the command runs as `nobody` (setpriv
/// drops every privilege). Empty when that user cannot run the build's executables (a build
/// tree that `nobody` cannot read): the caller skips.
std::string unprivilegedCovariance() {
  const std::string exe = kBin + "dba-covariance";
  if (::geteuid() != 0) return exe;
  const std::string cmd = "setpriv --reuid=65534 --regid=65534 --clear-groups " + exe;
  return testing::runCommand(cmd + " --help").code == 0 ? cmd : std::string();
}

/// A temporary directory that `nobody` may create files in (mkdtemp makes it 0700).
void openToEveryone(const testing::TempDir& dir) {
  ::chmod(dir.path().c_str(), 0777);
}

TEST(Paths, UnusableInputAmongUsableOnesIsOneFailure) {
  testing::TempDir dir;
  fs::create_directory(dir.file("empty"));
  testing::writeTinySnapshot(dir.file("a.npz"), 1, 1);
  ASSERT_EQ(::mkfifo(dir.file("fifo.npz").c_str(), 0644), 0);
  fs::create_directory(dir.file("dir.npz"));
  struct Case {
    std::string input, error, name;
  };
  for (const Case& c : std::vector<Case>{
           {dir.file("empty"), dir.file("empty") + ": directory holds no .npz snapshot", "empty"},
           {dir.file("nope.npz"), dir.file("nope.npz") + ": no such file or directory", "nope.npz"},
           {dir.file("a.txt"), dir.file("a.txt") + ": no such file or directory", "a.txt"},
           {dir.file("fifo.npz"),
            dir.file("fifo.npz") + ": cannot open .npz archive: not a regular file", "fifo.npz"},
           {dir.file("dir.npz"), dir.file("dir.npz") + ": directory holds no .npz snapshot",
            "dir.npz"},
       }) {
    SCOPED_TRACE(c.input);
    const AppResult r = covariance({"-i", c.input, "-i", dir.file("a.npz"), "--csv",
                                    dir.file("k.csv"), "--weight-scale", "4"});
    EXPECT_EQ(r.code, 1);
    EXPECT_EQ(r.err,
              "dba-covariance: error: " + c.error +
                  "\ndba-covariance: 2 snapshots read, 1 processed, 1 failed: 1 invalid input (" +
                  c.name + ")\n");
    EXPECT_EQ(testing::splitLines(testing::readFile(dir.file("k.csv"))).size(), 1u + 6);
  }
}

TEST(Paths, NoUsableInputStopsBeforeAnythingIsWritten) {
  testing::TempDir dir;
  fs::create_directory(dir.file("empty"));
  std::ofstream(dir.file("k.csv")) << "previous";
  std::ofstream(dir.file("notes.csv")) << "not a snapshot";  // (k.csv itself: test_path_clashes)
  for (const auto& [input, error] : std::vector<std::pair<std::string, std::string>>{
           {dir.file("empty"), ": directory holds no .npz snapshot"},
           {dir.file("notes.csv"),
            ": not a snapshot input (expected a .npz file, a .rawlog of DBA "
            "snapshots, or a directory of .npz files)"}}) {
    const AppResult r = covariance({"-i", input, "--csv", dir.file("k.csv")});
    EXPECT_EQ(r.code, 1);
    EXPECT_EQ(r.err, "dba-covariance: error: " + input + error + "\n");
    EXPECT_EQ(testing::readFile(dir.file("k.csv")), "previous");
  }
  // The real executable gives the same message and exit status.
  const AppResult r = testing::runCommand(kBin + "dba-covariance -i " + dir.file("empty") +
                                          " --csv " + dir.file("k.csv"));
  EXPECT_EQ(r.code, 1);
  EXPECT_EQ(r.out,
            "dba-covariance: error: " + dir.file("empty") + ": directory holds no .npz snapshot\n");
  EXPECT_EQ(dir.entries(), (std::vector<std::string>{"empty", "k.csv", "notes.csv"}));
}

TEST(Paths, UnreadableInputs) {
  const std::string exe = unprivilegedCovariance();
  if (exe.empty()) GTEST_SKIP() << "running as root and user nobody cannot run " << kBin;
  testing::TempDir dir;
  openToEveryone(dir);
  fs::create_directory(dir.file("locked"));
  testing::writeTinySnapshot(dir.file("locked/x.npz"), 1, 1);
  testing::writeTinySnapshot(dir.file("a.npz"), 1, 1);
  testing::writeTinySnapshot(dir.file("secret.npz"), 2, 2);
  ::chmod(dir.file("a.npz").c_str(), 0644);
  ::chmod(dir.file("secret.npz").c_str(), 0);
  ::chmod(dir.file("locked").c_str(), 0);
  const AppResult r = testing::runCommand(exe + " -i " + dir.file("secret.npz") + " -i " +
                                          dir.file("locked") + " -i " + dir.file("a.npz") +
                                          " --csv " + dir.file("k.csv") + " --weight-scale 4");
  ::chmod(dir.file("locked").c_str(), 0755);
  EXPECT_EQ(r.code, 1);
  EXPECT_EQ(r.out, "dba-covariance: error: " + dir.file("secret.npz") +
                       ": cannot open as a .npz (zip) archive: Can't open file: Permission denied\n"
                       "dba-covariance: error: " +
                       dir.file("locked") +
                       ": cannot list .npz files: Permission denied\n"
                       "dba-covariance: 3 snapshots read, 1 processed, 2 failed: 2 invalid input "
                       "(secret.npz, locked)\n");
  // The readable snapshot is still processed and written.
  EXPECT_EQ(testing::splitLines(testing::readFile(dir.file("k.csv"))).size(), 1u + 6);
}

TEST(Paths, UnwritableOutputsStopBeforeAnyWork) {
  testing::TempDir dir;
  testing::writeTinySnapshot(dir.file("a.npz"), 1, 1);
  std::ofstream(dir.file("file")) << "x";
  fs::create_directory(dir.file("adir"));
  struct Case {
    std::vector<std::string> output;
    std::string error;
  };
  for (const Case& c : std::vector<Case>{
           {{"--csv", "/proc/dbacov.csv"},
            "/proc/dbacov.csv: cannot create a temporary file in directory '/proc': " + kNoFiles},
           {{"--csv", dir.file("adir")},
            dir.file("adir") + ": is a directory, expected a file path"},
           {{"--csv", dir.file("file/k.csv")},
            dir.file("file/k.csv") + ": cannot create a temporary file in directory '" +
                dir.file("file") + "': Not a directory"},
           {{"-o", "/proc/p.rawlog"},
            "/proc/p.rawlog: cannot create a temporary file in directory '/proc': " + kNoFiles},
           {{"--graph", "/proc/g"},
            "/proc/g.graphbin: cannot create a temporary file in directory '/proc': " + kNoFiles},
           {{"--depth-sigma", dir.file("file")},
            dir.file("file") + ": cannot use as the depth-sigma directory: " + dir.file("file") +
                " exists and is not a directory"},
           {{"--depth-sigma", "/proc/sigma"},
            "/proc/sigma: cannot use as the depth-sigma directory: cannot create files in "
            "'/proc': " +
                kNoFiles},
       }) {
    SCOPED_TRACE(c.output[1]);
    std::vector<std::string> args{"-i", dir.file("a.npz"), "--weight-scale", "4"};
    args.insert(args.end(), c.output.begin(), c.output.end());
    const AppResult r = covariance(args);
    EXPECT_EQ(r.code, 1);
    EXPECT_EQ(r.err, "dba-covariance: error: " + c.error + "\n");
  }
  EXPECT_EQ(dir.entries(), (std::vector<std::string>{"a.npz", "adir", "file"}));
  // droid2rawlog, as the real executable.
  const AppResult r =
      testing::runCommand(kBin + "droid2rawlog -i " + dir.file("a.npz") + " -o /proc/s.rawlog");
  EXPECT_EQ(r.code, 1);
  EXPECT_EQ(
      r.out,
      "droid2rawlog: error: /proc/s.rawlog: cannot create a temporary file in directory '/proc': " +
          kNoFiles + "\n");
}

TEST(Paths, UnwritableDirectory) {
  const std::string exe = unprivilegedCovariance();
  if (exe.empty()) GTEST_SKIP() << "running as root and user nobody cannot run " << kBin;
  testing::TempDir dir;
  openToEveryone(dir);
  testing::writeTinySnapshot(dir.file("a.npz"), 1, 1);
  ::chmod(dir.file("a.npz").c_str(), 0644);
  fs::create_directory(dir.file("ro"));
  ::chmod(dir.file("ro").c_str(), 0555);
  const AppResult r =
      testing::runCommand(exe + " -i " + dir.file("a.npz") + " --csv " + dir.file("ro/k.csv"));
  ::chmod(dir.file("ro").c_str(), 0755);
  EXPECT_EQ(r.code, 1);
  EXPECT_EQ(r.out, "dba-covariance: error: " + dir.file("ro/k.csv") +
                       ": cannot create a temporary file in directory '" + dir.file("ro") +
                       "': Permission denied\n");
  EXPECT_TRUE(fs::is_empty(dir.file("ro")));
}

}  // namespace paths
}  // namespace dbacov
