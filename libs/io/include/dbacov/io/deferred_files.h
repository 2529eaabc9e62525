// Output files that are produced one by one during a run but must appear only when the run
// completes (e.g. dba-covariance --depth-sigma: one map per keyframe and snapshot).
//
// Contract:
//   - add(path, bytes) appends the bytes to a spool: an unnamed temporary file (O_TMPFILE) in
//     `spool_dir`, so that memory does not grow with the run and a killed process (even SIGKILL)
//     leaves nothing behind. Without O_TMPFILE the spool is a named temporary that is unlinked
//     right after it is created. A later add() for the same path replaces the earlier contents.
//   - commit() writes every file atomically (AtomicOutputFile), in the order of their first add():
//     each file is the previous version or the complete new one, never a partial write; a file
//     that fails does not stop the others. All files are prepared (written, fsync'ed) before the
//     first is renamed, in one io::CommitGroup (the caller's, when one is active).
//   - Destroying the object without commit() writes nothing (the spool disappears).
// Errors (spool cannot be created or written, a file cannot be written) throw dbacov::InputError
// naming the path. Misuse (add or commit after commit) throws std::logic_error. Not thread-safe.
#pragma once

#include <cstddef>
#include <cstdint>
#include <map>
#include <string>
#include <vector>

#include "dbacov/core/errors.h"

namespace dbacov::io {

class DeferredFiles {
 public:
  /// Creates the spool in `spool_dir`. Throws InputError naming the directory when it cannot.
  explicit DeferredFiles(const std::string& spool_dir);
  ~DeferredFiles();
  DeferredFiles(const DeferredFiles&) = delete;
  DeferredFiles& operator=(const DeferredFiles&) = delete;

  /// Queues `size` bytes as the contents of `path`.
  void add(const std::string& path, const void* data, std::size_t size);
  void add(const std::string& path, const std::vector<unsigned char>& bytes) {
    add(path, bytes.data(), bytes.size());
  }
  /// Number of distinct files queued.
  std::size_t size() const { return order_.size(); }

  /// Writes every queued file atomically. A file that cannot be written does not stop the
  /// others; then InputError with the first failure (and how many more failed).
  void commit();

 private:
  struct Extent {
    std::uint64_t offset = 0, size = 0;
  };
  std::string dir_;
  int fd_ = -1;
  std::uint64_t end_ = 0;
  std::vector<std::string> order_;
  std::map<std::string, Extent> files_;
  bool committed_ = false;
};

}  // namespace dbacov::io
