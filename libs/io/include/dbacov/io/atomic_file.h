// Atomic replacement of an output file: readers see either the previous file or the complete new
// one, never a partial write, and an interrupted program leaves nothing behind.
//
// Contract:
//   - The constructor creates the temporary output in the directory of `final_path` (so that the
//     final rename stays within one file system). Preferred: an unnamed inode via
//     open(dir, O_TMPFILE), which even SIGKILL cannot leave behind. Fallback (file system or
//     kernel without O_TMPFILE, or no /proc): a named file `.<name>.tmp.<pid>.XXXXXX` (mkstemp).
//     New files get mode 0644 (minus the umask for O_TMPFILE); an existing file's mode is not kept.
//   - commit() makes the data durable (fsync) and atomically replaces `final_path` with it
//     (O_TMPFILE: linkat to a unique temporary name, then rename; named: rename). The containing
//     directory is fsync'ed afterwards (best effort).
//   - Destroying the object without a successful commit() discards the output; `final_path` is
//     never touched. Only a SIGKILL between linkat and rename in commit() (microseconds) can leave
//     a named temporary behind.
// Errors (`final_path` is a directory, directory missing or not writable, disk full, rename
// failure) throw dbacov::InputError
// naming `final_path` and the system error. Misuse (write or commit after commit) throws
// std::logic_error. Not thread-safe; one object per output file.
#pragma once

#include <functional>
#include <ostream>
#include <string>

#include "dbacov/core/errors.h"

namespace dbacov::io {

class AtomicOutputFile {
 public:
  /// How the temporary output is created.
  enum class TempKind {
    kAuto,   ///< O_TMPFILE where supported, else a named temporary
    kNamed,  ///< always a named temporary (for callers that must reopen it in another process)
  };

  /// Creates the temporary output for `final_path`. Throws InputError if it cannot be created.
  explicit AtomicOutputFile(std::string final_path, TempKind kind = TempKind::kAuto);
  /// Discards the output unless commit() succeeded.
  ~AtomicOutputFile();

  AtomicOutputFile(const AtomicOutputFile&) = delete;
  AtomicOutputFile& operator=(const AtomicOutputFile&) = delete;

  /// The open, writable descriptor of the temporary output (-1 after commit()).
  int fd() const { return fd_; }
  /// A path that another library can open for writing by name: "/proc/self/fd/<fd>" for an
  /// unnamed temporary, else the temporary's name. Valid until commit() or destruction.
  std::string writePath() const;
  /// The path that commit() replaces.
  const std::string& finalPath() const { return final_path_; }
  /// True when the temporary is an O_TMPFILE inode (nothing to clean up after a crash).
  bool isUnnamed() const { return unnamed_; }
  bool committed() const { return committed_; }

  /// Appends `size` bytes through fd() (retrying partial writes). Throws InputError on failure.
  void write(const void* data, std::size_t size);

  /// fsync, then atomically replaces finalPath(). Throws InputError on failure (the output is then
  /// discarded and finalPath() untouched); std::logic_error if already committed.
  void commit();

 private:
  [[noreturn]] void fail(const std::string& what, int err) const;
  void discard() noexcept;

  std::string final_path_;
  std::string dir_;        ///< directory of final_path_ ("." if it has none)
  std::string temp_name_;  ///< named temporary (fallback), empty for O_TMPFILE
  int fd_ = -1;
  bool unnamed_ = false;
  bool committed_ = false;
};

/// Writes `path` atomically by streaming into an AtomicOutputFile: `writer` receives a binary
/// std::ostream; the file is committed only if `writer` returns normally and the stream is still
/// good after flushing. If `writer` throws, its exception propagates; if the stream failed (write
/// error, disk full, or the writer set failbit/badbit) InputError is thrown naming `path`. In both
/// cases nothing is left behind and the previous file at `path`, if any, is untouched.
void writeFileAtomically(const std::string& path, const std::function<void(std::ostream&)>& writer);

/// An anonymous scratch file in directory `dir` (O_TMPFILE; where that is unsupported, a named
/// temporary unlinked at once): read-write, close-on-exec, gone with its last descriptor, so a
/// process killed at any moment leaves nothing behind. Returns the descriptor, or -1 with errno
/// set (e.g. EACCES, ENOENT) when no file can be created there.
int openScratchFile(const std::string& dir);

}  // namespace dbacov::io
