// Outputs are never half-written: the real dba-covariance is killed (SIGKILL, SIGTERM, SIGINT) in
// the middle of a run, and the previous output files are intact with no temporary left behind.
// The run reads its snapshots from a FIFO that the test feeds, so "the middle" is certain: the
// app has processed part of the input (its depth-sigma spool holds their maps) and is waiting for
// more. A second test kills it while gnuplot draws the --plots figures.
#include <fcntl.h>
#include <signal.h>
#include <spawn.h>
#include <sys/stat.h>
#include <sys/wait.h>
#include <unistd.h>

#include <cerrno>
#include <chrono>
#include <filesystem>
#include <fstream>
#include <thread>

#include <gtest/gtest.h>

#include "app_runner.h"
#include "fixtures.h"
#include "rawlog_records.h"
#include "temp_dir.h"

extern char** environ;

namespace dbacov {
namespace kill {  // not anonymous: the suite is compiled as a unity build

namespace fs = std::filesystem;
const std::string kBin = std::string(DBACOV_BINARY_DIR) + "/bin/";

/// Starts `argv` with stdout and stderr to `log`, SIGINT and SIGTERM at their default action
/// (a shell may have started the tests with them ignored).
pid_t spawn(const std::vector<std::string>& args, const std::string& log) {
  posix_spawn_file_actions_t actions;
  posix_spawn_file_actions_init(&actions);
  posix_spawn_file_actions_addopen(&actions, 1, log.c_str(), O_WRONLY | O_CREAT | O_TRUNC, 0644);
  posix_spawn_file_actions_adddup2(&actions, 1, 2);
  posix_spawnattr_t attr;
  posix_spawnattr_init(&attr);
  sigset_t defaults, none;
  sigemptyset(&defaults);
  sigaddset(&defaults, SIGINT);
  sigaddset(&defaults, SIGTERM);
  sigemptyset(&none);
  posix_spawnattr_setsigdefault(&attr, &defaults);
  posix_spawnattr_setsigmask(&attr, &none);
  posix_spawnattr_setflags(&attr, POSIX_SPAWN_SETSIGDEF | POSIX_SPAWN_SETSIGMASK);
  std::vector<std::string> storage = args;
  std::vector<char*> argv;
  for (auto& a : storage) argv.push_back(a.data());
  argv.push_back(nullptr);
  pid_t pid = -1;
  if (posix_spawn(&pid, argv[0], &actions, &attr, argv.data(), environ) != 0) pid = -1;
  posix_spawn_file_actions_destroy(&actions);
  posix_spawnattr_destroy(&attr);
  return pid;
}

/// Waits until `done()` holds; false if the process `pid` exited first or a minute passed (a
/// safety net against hanging, not a timing condition of the test).
bool waitFor(pid_t pid, const std::function<bool()>& done) {
  const auto deadline = std::chrono::steady_clock::now() + std::chrono::minutes(1);
  while (std::chrono::steady_clock::now() < deadline) {
    if (done()) return true;
    int status = 0;
    if (::waitpid(pid, &status, WNOHANG) == pid) return false;
    std::this_thread::sleep_for(std::chrono::milliseconds(2));
  }
  return false;
}

/// Largest unnamed temporary (O_TMPFILE) that `pid` holds open in directory `dir`.
std::uintmax_t unnamedBytesIn(pid_t pid, const std::string& dir) {
  std::uintmax_t largest = 0;
  std::error_code ec;
  for (const auto& e : fs::directory_iterator("/proc/" + std::to_string(pid) + "/fd", ec)) {
    const std::string target = fs::read_symlink(e.path(), ec).string();
    if (ec || target.rfind(dir + "/#", 0) != 0) continue;
    struct stat st {};
    if (::stat(e.path().c_str(), &st) == 0) largest = std::max<std::uintmax_t>(largest, st.st_size);
  }
  return largest;
}

/// Every file under `dir` with its contents.
std::map<std::string, std::string> snapshotOf(const std::string& dir) {
  std::map<std::string, std::string> files;
  for (const auto& e : fs::recursive_directory_iterator(dir))
    files[e.path().string()] = e.is_regular_file() ? testing::readFile(e.path().string()) : "<dir>";
  return files;
}

/// Opens the FIFO for writing once the app has opened it for reading.
int openFeed(pid_t pid, const std::string& fifo) {
  int fd = -1;
  waitFor(pid, [&] { return (fd = ::open(fifo.c_str(), O_WRONLY | O_NONBLOCK)) >= 0; });
  if (fd >= 0) ::fcntl(fd, F_SETFL, 0);  // blocking writes from now on
  return fd;
}

bool writeAll(int fd, const std::vector<unsigned char>& bytes) {
  for (std::size_t done = 0; done < bytes.size();) {
    const ssize_t n = ::write(fd, bytes.data() + done, bytes.size() - done);
    if (n <= 0) return false;
    done += static_cast<std::size_t>(n);
  }
  return true;
}

/// Uncompressed rawlog records of `n` small snapshots (ids 0..n-1).
std::vector<unsigned char> records(int n) {
  std::vector<unsigned char> bytes;
  for (int i = 0; i < n; ++i) {
    const auto r = testing::serializeRecord(testing::tinySnapshot(i + 1, i).snapshot);
    bytes.insert(bytes.end(), r.bytes.begin(), r.bytes.end());
  }
  return bytes;
}

class KillTest : public ::testing::TestWithParam<int> {};

TEST_P(KillTest, MidRunLeavesThePreviousOutputsAndNoTemporary) {
  const int sig = GetParam();
  testing::TempDir dir;
  fs::create_directories(dir.file("out/sigma"));
  for (const char* name : {"k.csv", "r.csv", "p.rawlog", "g.graphbin", "g.graph", "g.g2o",
                           "g.nodes.csv", "scene.png", "sigma/1_0.npy"})
    std::ofstream(dir.file(std::string("out/") + name)) << "previous " << name;
  const auto before = snapshotOf(dir.file("out"));
  ASSERT_EQ(::mkfifo(dir.file("in.rawlog").c_str(), 0600), 0);
  const std::string o = dir.file("out/");
  const pid_t pid = spawn({kBin + "dba-covariance",
                           "-i",
                           dir.file("in.rawlog"),
                           "--csv",
                           o + "k.csv",
                           "--relative-csv",
                           o + "r.csv",
                           "-o",
                           o + "p.rawlog",
                           "--graph",
                           o + "g",
                           "--depth-sigma",
                           o + "sigma",
                           "--snapshot",
                           o + "scene.png",
                           "--snapshot-every",
                           "2",
                           "--snapshot-size",
                           "64x48",
                           "--weight-scale",
                           "4"},
                          dir.file("log.txt"));
  ASSERT_GT(pid, 0);
  const int fd = openFeed(pid, dir.file("in.rawlog"));
  ASSERT_GE(fd, 0) << testing::readFile(dir.file("log.txt"));
  // 24 snapshots, more than the pipe holds: the writes return once the app has read them.
  ASSERT_TRUE(writeAll(fd, records(24)));
  // Processed: the spool holds at least 12 snapshots' depth-sigma maps (6 maps of 8×10 floats).
  const std::uintmax_t twelve = 12 * 6 * (128 + 8 * 10 * 4);
  ASSERT_TRUE(waitFor(pid, [&] { return unnamedBytesIn(pid, o + "sigma") >= twelve; }))
      << testing::readFile(dir.file("log.txt"));
  ASSERT_EQ(::kill(pid, sig), 0);
  int status = 0;
  ASSERT_EQ(::waitpid(pid, &status, 0), pid);
  ::close(fd);
  ASSERT_TRUE(WIFSIGNALED(status)) << testing::readFile(dir.file("log.txt"));
  EXPECT_EQ(WTERMSIG(status), sig);
  EXPECT_EQ(snapshotOf(dir.file("out")), before);  // same files, same contents, nothing else
}

INSTANTIATE_TEST_SUITE_P(Signals, KillTest, ::testing::Values(SIGKILL, SIGTERM, SIGINT),
                         [](const auto& p) {
                           return std::string(p.param == SIGKILL   ? "SIGKILL"
                                              : p.param == SIGTERM ? "SIGTERM"
                                                                   : "SIGINT");
                         });

/// True while `pid` runs (not gone, not a zombie that nobody reaps).
bool running(pid_t pid) {
  std::ifstream stat("/proc/" + std::to_string(pid) + "/stat");
  std::string id, comm, state;
  return static_cast<bool>(stat >> id >> comm >> state) && state != "Z";
}

/// The pid of a child of `parent` whose command is `name`, or -1.
pid_t childNamed(pid_t parent, const std::string& name) {
  std::error_code ec;
  for (const auto& e : fs::directory_iterator("/proc", ec)) {
    std::ifstream stat(e.path() / "stat");
    std::string pid, comm, state;
    pid_t ppid = 0;
    if (stat >> pid >> comm >> state >> ppid && ppid == parent && comm == "(" + name + ")")
      return std::stoi(pid);
  }
  return -1;
}

TEST(Kill, WhileGnuplotDrawsThePlotsLeavesThePreviousFigures) {
  testing::TempDir dir;
  fs::create_directories(dir.file("plots/depth_sigma"));
  for (const char* name :
       {"keyframes.csv", "pose_sigmas.png", "covariance_covisibility.png", "depth_sigma/0_2.png"})
    std::ofstream(dir.file(std::string("plots/") + name)) << "previous " << name;
  const auto before = snapshotOf(dir.file("plots"));
  ASSERT_EQ(::mkfifo(dir.file("in.rawlog").c_str(), 0600), 0);
  const pid_t pid = spawn({kBin + "dba-covariance", "-i", dir.file("in.rawlog"), "--plots",
                           dir.file("plots"), "--weight-scale", "4", "-q"},
                          dir.file("log.txt"));
  ASSERT_GT(pid, 0);
  const int fd = openFeed(pid, dir.file("in.rawlog"));
  ASSERT_GE(fd, 0) << testing::readFile(dir.file("log.txt"));
  ASSERT_TRUE(writeAll(fd, records(12)));
  ::close(fd);  // end of input: the app draws the figures
  pid_t gnuplot = -1;
  ASSERT_TRUE(waitFor(pid, [&] { return (gnuplot = childNamed(pid, "gnuplot")) > 0; }))
      << testing::readFile(dir.file("log.txt"));
  ASSERT_EQ(::kill(pid, SIGKILL), 0);
  int status = 0;
  ASSERT_EQ(::waitpid(pid, &status, 0), pid);
  EXPECT_TRUE(WIFSIGNALED(status));
  // gnuplot, orphaned, may still be writing into the unnamed temporaries: let it finish.
  while (running(gnuplot)) std::this_thread::sleep_for(std::chrono::milliseconds(5));
  EXPECT_EQ(snapshotOf(dir.file("plots")), before);
}

}  // namespace kill
}  // namespace dbacov
