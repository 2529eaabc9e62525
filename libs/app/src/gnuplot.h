// Private helpers of the figures (--plots): gnuplot as a subprocess and its scratch directory.
//
// gnuplot (Debian: gnuplot-nox) draws with its pngcairo terminal, which needs no X server. The
// figures' data and scripts go to a scratch directory under the system's temporary directory; the
// PNGs are written by gnuplot straight into named temporaries beside their final paths
// (io::AtomicOutputFile, TempKind::kNamed) and committed only when gnuplot succeeded.
#pragma once

#include <string>

namespace dbacov::app::detail {

/// A fresh directory under std::filesystem::temp_directory_path(), removed with its contents.
class ScratchDir {
 public:
  ScratchDir();  ///< throws InputError when it cannot be created
  ~ScratchDir();
  ScratchDir(const ScratchDir&) = delete;
  ScratchDir& operator=(const ScratchDir&) = delete;
  const std::string& path() const { return path_; }
  std::string file(const std::string& name) const { return path_ + "/" + name; }

 private:
  std::string path_;
};

/// Runs `gnuplot <script>` (found on PATH) with its output and errors in `log`. Throws InputError
/// with the end of the log when gnuplot cannot be started or fails (`what` names the figures).
void runGnuplot(const std::string& script, const std::string& log, const std::string& what);

/// Checks that gnuplot runs and has the pngcairo terminal; throws InputError naming the Debian
/// package otherwise.
void requireGnuplot();

/// `s` as a gnuplot single-quoted string ('' stands for a quote inside).
std::string gnuplotQuote(const std::string& s);

}  // namespace dbacov::app::detail
