// io::DeferredFiles: outputs queued in an unnamed spool appear only at commit(), each complete;
// without commit nothing appears; a file that cannot be written does not stop the others.
#include <filesystem>
#include <fstream>

#include <gtest/gtest.h>

#include "dbacov/io/deferred_files.h"
#include "io_test_util.h"

namespace dbacov::io::testing {
namespace {

std::vector<unsigned char> bytesOf(const std::string& s) {
  return {s.begin(), s.end()};
}

TEST(DeferredFiles, FilesAppearOnlyAtCommitWithTheirLastContents) {
  TempDir dir;
  {
    DeferredFiles files(dir.path());
    files.add(dir.file("a.txt"), bytesOf("first a"));
    files.add(dir.file("b.txt"), bytesOf(std::string(100000, 'b')));
    files.add(dir.file("a.txt"), bytesOf("second a"));  // replaces the first
    EXPECT_EQ(files.size(), 2u);
    EXPECT_TRUE(dir.entries().empty());  // the spool has no name
    files.commit();
    EXPECT_THROW(files.add(dir.file("c.txt"), bytesOf("c")), std::logic_error);
  }
  EXPECT_EQ(dir.entries(), (std::vector<std::string>{"a.txt", "b.txt"}));
  EXPECT_EQ(readText(dir.file("a.txt")), "second a");
  EXPECT_EQ(readText(dir.file("b.txt")), std::string(100000, 'b'));
}

TEST(DeferredFiles, WithoutCommitNothingAppears) {
  TempDir dir;
  std::ofstream(dir.file("a.txt")) << "previous";
  {
    DeferredFiles files(dir.path());
    files.add(dir.file("a.txt"), bytesOf("new"));
    files.add(dir.file("b.txt"), bytesOf("new"));
  }
  EXPECT_EQ(dir.entries(), (std::vector<std::string>{"a.txt"}));
  EXPECT_EQ(readText(dir.file("a.txt")), "previous");
}

TEST(DeferredFiles, AFileThatCannotBeWrittenDoesNotStopTheOthers) {
  TempDir dir;
  std::filesystem::create_directory(dir.file("x.npy"));  // a directory where a file should go
  std::filesystem::create_directory(dir.file("y.npy"));
  DeferredFiles files(dir.path());
  for (const char* name : {"a.npy", "x.npy", "b.npy", "y.npy", "c.npy"})
    files.add(dir.file(name), bytesOf(name));
  try {
    files.commit();
    ADD_FAILURE() << "commit() did not report the directories";
  } catch (const InputError& e) {
    EXPECT_EQ(std::string(e.what()),
              dir.file("x.npy") +
                  ": is a directory, expected a file path (and 1 more files not written)");
  }
  for (const char* name : {"a.npy", "b.npy", "c.npy"}) EXPECT_EQ(readText(dir.file(name)), name);
}

TEST(DeferredFiles, AnUnusableSpoolDirectoryIsNamed) {
  expectMentions(inputErrorOf([] { DeferredFiles files("/proc"); }),
                 {"/proc", "cannot create a temporary spool file"});
}

}  // namespace
}  // namespace dbacov::io::testing
