// Private helpers of the figures (--plots): gnuplot as a subprocess, fed through in-memory files.
//
// gnuplot (Debian: gnuplot-nox) draws with its pngcairo terminal, which needs no X server. Its
// script, data files and log are anonymous in-memory files (memfd) and each PNG goes into the
// unnamed temporary of an io::AtomicOutputFile; gnuplot inherits their descriptors and opens them
// as /proc/self/fd/N. Nothing has a name on disk before the PNGs are committed, so a run that is
// killed at any moment (even SIGKILL) leaves no scratch directory and no temporary behind.
#pragma once

#include <string>
#include <vector>

namespace dbacov::app::detail {

/// An anonymous in-memory file, removed with its last descriptor.
class MemFile {
 public:
  explicit MemFile(const std::string& name);  ///< throws InputError when it cannot be created
  ~MemFile();
  MemFile(const MemFile&) = delete;
  MemFile& operator=(const MemFile&) = delete;
  int fd() const { return fd_; }
  /// "/proc/self/fd/N": opens the file in this process and in a child that inherits fd().
  std::string path() const;
  /// The whole contents.
  std::string contents() const;

 private:
  int fd_ = -1;
};

/// Runs `gnuplot <script>` (found on PATH) with the descriptors `inherit` passed on (script,
/// data and output files) and its output and errors in `log`. Throws InputError with the end of
/// the log when gnuplot cannot be started or fails (`what` names the figures).
void runGnuplot(const std::string& script, const MemFile& log, const std::vector<int>& inherit,
                const std::string& what);

/// Checks that gnuplot runs and has the pngcairo terminal; throws InputError naming the Debian
/// package otherwise.
void requireGnuplot();

/// `s` as a gnuplot single-quoted string ('' stands for a quote inside).
std::string gnuplotQuote(const std::string& s);

}  // namespace dbacov::app::detail
