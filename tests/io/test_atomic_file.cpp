// AtomicOutputFile and writeFileAtomically: replacement only on commit, nothing left behind on
// failure, a crash (SIGKILL) or destruction, for both the O_TMPFILE and the named-temporary paths.
#include <signal.h>
#include <sys/stat.h>
#include <sys/types.h>
#include <sys/wait.h>
#include <unistd.h>

#include <fstream>
#include <stdexcept>

#include <gtest/gtest.h>

#include "dbacov/io/atomic_file.h"
#include "io_test_util.h"

namespace dbacov::io::testing {
namespace {

using Kind = AtomicOutputFile::TempKind;

class AtomicFileTest : public ::testing::TestWithParam<Kind> {
 protected:
  void SetUp() override { std::ofstream(dir_.file("out.txt")) << "previous"; }
  std::string path() const { return dir_.file("out.txt"); }
  TempDir dir_;
};

void writeString(AtomicOutputFile& f, const std::string& s) {
  f.write(s.data(), s.size());
}

TEST_P(AtomicFileTest, CommitReplacesAndLeavesNoTemporary) {
  {
    AtomicOutputFile f(path(), GetParam());
    EXPECT_EQ(f.finalPath(), path());
    if (GetParam() == Kind::kNamed) {
      EXPECT_FALSE(f.isUnnamed());
    }
    writeString(f, "new content");
    EXPECT_EQ(readText(path()), "previous");
    f.commit();
    EXPECT_TRUE(f.committed());
    EXPECT_EQ(readText(path()), "new content");
    EXPECT_THROW(f.commit(), std::logic_error);
    EXPECT_THROW(writeString(f, "x"), std::logic_error);
  }
  EXPECT_EQ(readText(path()), "new content");
  EXPECT_EQ(dir_.entries(), std::vector<std::string>{"out.txt"});
}

TEST_P(AtomicFileTest, WithoutCommitThePreviousFileIsUntouched) {
  {
    AtomicOutputFile f(path(), GetParam());
    writeString(f, "never seen");
    // A named temporary is visible while writing; an O_TMPFILE inode is not.
    EXPECT_EQ(dir_.entries().size(), f.isUnnamed() ? 1u : 2u);
  }
  EXPECT_EQ(readText(path()), "previous");
  EXPECT_EQ(dir_.entries(), std::vector<std::string>{"out.txt"});
  {
    AtomicOutputFile f(dir_.file("new.txt"), GetParam());
    writeString(f, "never seen");
  }
  EXPECT_EQ(dir_.entries(), std::vector<std::string>{"out.txt"});
}

TEST_P(AtomicFileTest, WritePathCanBeOpenedByName) {
  AtomicOutputFile f(path(), GetParam());
  const std::string wp = f.writePath();
  if (f.isUnnamed()) {
    EXPECT_EQ(wp, "/proc/self/fd/" + std::to_string(f.fd()));
  } else {
    EXPECT_EQ(wp.rfind(dir_.file(".out.txt.tmp." + std::to_string(::getpid()) + "."), 0), 0u) << wp;
  }
  {
    std::ofstream os(wp, std::ios::binary | std::ios::trunc);
    os << "written by name";
    ASSERT_TRUE(os.good());
  }
  f.commit();
  EXPECT_EQ(readText(path()), "written by name");
  EXPECT_EQ(dir_.entries(), std::vector<std::string>{"out.txt"});
}

TEST_P(AtomicFileTest, NewFilesAreReadableByOthers) {
  const mode_t mask = ::umask(022);
  ::umask(mask);
  AtomicOutputFile f(dir_.file("fresh.txt"), GetParam());
  f.commit();
  struct stat st {};
  ASSERT_EQ(::stat(dir_.file("fresh.txt").c_str(), &st), 0);
  const mode_t expected = f.isUnnamed() ? (0644 & ~mask) : 0644;
  EXPECT_EQ(st.st_mode & 0777, expected);
}

TEST_P(AtomicFileTest, FailuresNameThePathAndLeaveNothing) {
  expectMentions(
      inputErrorOf([&] { AtomicOutputFile f(dir_.file("no/such/dir/x.txt"), GetParam()); }),
      {dir_.file("no/such/dir/x.txt"), "No such file or directory"});
  expectMentions(inputErrorOf([&] { AtomicOutputFile f(dir_.path() + "/", GetParam()); }),
                 {"not a file path"});
  // A directory at the final path is refused at once; one that appears later makes rename()
  // fail at commit (it cannot replace a non-empty directory), which cleans up.
  std::filesystem::create_directory(dir_.file("dir"));
  expectMentions(inputErrorOf([&] { AtomicOutputFile d(dir_.file("dir"), GetParam()); }),
                 {dir_.file("dir"), "is a directory"});
  std::filesystem::remove(dir_.file("dir"));
  AtomicOutputFile f(dir_.file("taken"), GetParam());
  std::filesystem::create_directory(dir_.file("taken"));
  std::ofstream(dir_.file("taken/inner")) << "x";
  writeString(f, "data");
  expectMentions(inputErrorOf([&] { f.commit(); }), {dir_.file("taken"), "cannot rename"});
  EXPECT_EQ(dir_.entries(), (std::vector<std::string>{"out.txt", "taken"}));
  EXPECT_THROW(f.commit(), std::logic_error);
}

INSTANTIATE_TEST_SUITE_P(BothTempKinds, AtomicFileTest,
                         ::testing::Values(Kind::kAuto, Kind::kNamed), [](const auto& test_param) {
                           return std::string(test_param.param == Kind::kAuto ? "Auto" : "Named");
                         });

TEST(AtomicOutputFile, SigkillLeavesNoTemporaryWithOTmpfile) {
  TempDir dir;
  std::ofstream(dir.file("out.txt")) << "previous";
  if (!AtomicOutputFile(dir.file("probe")).isUnnamed())
    GTEST_SKIP() << "O_TMPFILE is not supported in " << dir.path();
  const pid_t child = ::fork();
  ASSERT_GE(child, 0);
  if (child == 0) {
    AtomicOutputFile f(dir.file("out.txt"));
    f.write("partial", 7);
    ::raise(SIGKILL);
    ::_exit(0);  // not reached
  }
  int status = 0;
  ASSERT_EQ(::waitpid(child, &status, 0), child);
  ASSERT_TRUE(WIFSIGNALED(status));
  EXPECT_EQ(WTERMSIG(status), SIGKILL);
  EXPECT_EQ(dir.entries(), std::vector<std::string>{"out.txt"});
  EXPECT_EQ(readText(dir.file("out.txt")), "previous");
}

TEST(WriteFileAtomically, CommitsOnlyWhenTheWriterSucceeds) {
  TempDir dir;
  const std::string path = dir.file("data.csv");
  writeFileAtomically(path, [](std::ostream& os) { os << "a,b\n1,2\n"; });
  EXPECT_EQ(readText(path), "a,b\n1,2\n");

  EXPECT_THROW(writeFileAtomically(path,
                                   [](std::ostream& os) {
                                     os << std::string(200000, 'x');  // beyond the buffer
                                     throw std::runtime_error("writer failed");
                                   }),
               std::runtime_error);
  EXPECT_EQ(readText(path), "a,b\n1,2\n");
  EXPECT_EQ(dir.entries(), std::vector<std::string>{"data.csv"});

  expectMentions(inputErrorOf([&] {
                   writeFileAtomically(path, [](std::ostream& os) {
                     os << "half";
                     os.setstate(std::ios::failbit);
                   });
                 }),
                 {path, "failed state"});
  EXPECT_EQ(readText(path), "a,b\n1,2\n");
  EXPECT_EQ(dir.entries(), std::vector<std::string>{"data.csv"});

  std::string big(5 << 20, '\0');
  for (std::size_t i = 0; i < big.size(); ++i) big[i] = static_cast<char>('a' + i % 26);
  writeFileAtomically(dir.file("big.txt"), [&](std::ostream& os) {
    os.write(big.data(), 1234);
    os.write(big.data() + 1234, static_cast<std::streamsize>(big.size() - 1234));
  });
  EXPECT_EQ(readText(dir.file("big.txt")), big);
  expectMentions(
      inputErrorOf([&] { writeFileAtomically(dir.file("nodir/x"), [](std::ostream&) {}); }),
      {dir.file("nodir/x")});
}

}  // namespace
}  // namespace dbacov::io::testing
