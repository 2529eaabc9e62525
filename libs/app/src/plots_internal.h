// Private parts of the figures (--plots): a batch of gnuplot figures and the depth-map figure.
#pragma once

#include <memory>
#include <sstream>
#include <string>
#include <vector>

#include "dbacov/app/plots.h"
#include "dbacov/io/atomic_file.h"
#include "gnuplot.h"

namespace dbacov::app::detail {

/// Figures drawn by one gnuplot run: data files in a scratch directory, one script, and the PNGs
/// as named temporaries beside their final paths, committed together after gnuplot succeeded.
class FigureBatch {
 public:
  /// Path of a data file in the scratch directory.
  std::string data(const std::string& name) const { return scratch_.file(name); }
  std::ostream& script() { return script_; }
  /// Creates the temporary for `final_path`; returns it quoted for gnuplot's `set output`.
  std::string output(const std::string& final_path);
  /// Runs gnuplot (if there is any figure) and commits every output. Throws InputError naming
  /// `what` on failure; then no output is committed.
  void run(const std::string& what);

 private:
  ScratchDir scratch_;
  std::ostringstream script_;
  std::vector<std::unique_ptr<io::AtomicOutputFile>> outputs_;
};

/// A number for gnuplot's data files (%.9g; "NaN" = missing).
std::string num(double v);
/// "1 keyframe", "2 keyframes".
std::string plural(std::size_t n, const std::string& what);
/// Figure title naming the sequence and the choice of snapshot per keyframe.
std::string sequenceTitle(const SequenceHistory& h);
/// Abscissa label: seconds since the first keyframe, or DROID's tstamp.
std::string timeLabel(bool times);

/// Inverse depth and its standard deviation of one keyframe, side by side with colour bars.
/// `n` makes the data file names unique. Does nothing when no pixel has a finite sigma.
void depthFigure(FigureBatch& batch, const DepthMaps& maps, double tstamp, int n,
                 const std::string& path);

}  // namespace dbacov::app::detail
