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
//   - Symlinks are followed: `final_path` a symlink (even a dangling one) → the temporary is made
//     next to its target and the target is replaced; the link stays.
//   - A `final_path` that exists and is not a regular file (character device such as /dev/null or
//     a terminal, FIFO, socket) is written in place, at commit() only: the data are spooled in an
//     anonymous scratch file in $TMPDIR (or /tmp) until then, so a run that fails or is killed
//     before commit() writes nothing to it. Such a write is not atomic (a FIFO's reader sees it
//     as it comes).
//   - While a CommitGroup is active on the calling thread, commit() only prepares the file
//     (fsync) and hands it to the group, which publishes every file of the run together.
// Errors (`final_path` is a directory, directory missing or not writable, disk full, rename
// failure) throw dbacov::InputError
// naming `final_path` and the system error. Misuse (write or commit after commit) throws
// std::logic_error. Not thread-safe; one object per output file.
#pragma once

#include <functional>
#include <ostream>
#include <string>
#include <vector>

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
  /// The file that commit() replaces or writes: finalPath() with its symlinks resolved.
  const std::string& targetPath() const { return target_; }
  /// True when the target is a device, FIFO or socket, written in place by commit().
  bool inPlace() const { return in_place_; }

  /// Appends `size` bytes through fd() (retrying partial writes). Throws InputError on failure.
  void write(const void* data, std::size_t size);

  /// fsync, then atomically replaces finalPath(). Throws InputError on failure (the output is then
  /// discarded and finalPath() untouched); std::logic_error if already committed.
  void commit();

 private:
  [[noreturn]] void fail(const std::string& what, int err) const;
  void discard() noexcept;

  std::string final_path_;
  std::string target_;     ///< final_path_ with symlinks resolved
  std::string dir_;        ///< directory of target_ ("." if it has none)
  std::string temp_name_;  ///< named temporary (fallback), empty for O_TMPFILE
  int fd_ = -1;
  bool unnamed_ = false;
  bool in_place_ = false;
  bool committed_ = false;
};

/// Makes the outputs of a run change together. While a CommitGroup is alive, every
/// AtomicOutputFile::commit() on this thread (also through writeFileAtomically, DeferredFiles and
/// the writers built on them) prepares its file — data fsync'ed, the unnamed temporary still
/// open — and leaves every final path untouched. publish() then replaces all of them in one tight
/// loop (linkat + rename per file, no data written), writes the in-place targets (devices, FIFOs),
/// and fsyncs each directory once. Destroying the group without publish() discards every
/// prepared file: the previous files stay as they were.
///
/// What a kill can leave (docs/reference/reliability.md): before publish() — only the previous
/// files, nothing else (unnamed temporaries vanish with the process); inside the rename loop
/// (microseconds per file) — the files renamed so far are new, the others previous, and at most
/// one hidden temporary `.<name>.tmp.<pid>.XXXXXX` (between its linkat and rename); a power cut
/// before the directory fsyncs may undo renames (each file stays whole, old or new).
/// Groups do not nest (a second one on the same thread throws std::logic_error). Not thread-safe.
class CommitGroup {
 public:
  CommitGroup();
  ~CommitGroup();
  CommitGroup(const CommitGroup&) = delete;
  CommitGroup& operator=(const CommitGroup&) = delete;

  /// The group active on this thread, or nullptr.
  static CommitGroup* active();
  /// Number of prepared files waiting for publish().
  std::size_t size() const { return entries_.size(); }
  /// Publishes every prepared file (see above) and ends the group. A file that cannot be
  /// published does not stop the others; then InputError with the first failure (and how many
  /// more failed).
  void publish();

 private:
  friend class AtomicOutputFile;
  struct Entry {
    std::string final_path, target, dir, temp_name;
    int fd = -1;  ///< unnamed temporary or in-place scratch, still open
    bool in_place = false;
  };
  void adopt(Entry entry);
  void discard() noexcept;
  std::vector<Entry> entries_;
  std::size_t open_fds_ = 0, fd_budget_ = 0;
  bool done_ = false;
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
