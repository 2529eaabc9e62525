// Private parts of the figures (--plots): a batch of gnuplot figures and the depth-map figure.
#pragma once

#include <map>
#include <memory>
#include <sstream>
#include <string>
#include <vector>

#include "dbacov/app/plots.h"
#include "dbacov/io/atomic_file.h"
#include "gnuplot.h"

namespace dbacov::app::detail {

/// Figures drawn by one gnuplot run: data files and script in memory (MemFile), and the PNGs in
/// the unnamed temporaries of AtomicOutputFiles, committed together after gnuplot succeeded.
/// Every figure holds a few descriptors until run(): keep a batch to about a hundred figures.
class FigureBatch {
 public:
  /// Path of the data file `name` (created empty at the first call), for std::ofstream and for
  /// gnuplot's script.
  std::string data(const std::string& name);
  std::ostream& script() { return script_; }
  /// Creates the temporary for `final_path`; returns it quoted for gnuplot's `set output`.
  std::string output(const std::string& final_path);
  std::size_t numOutputs() const { return outputs_.size(); }
  /// Descriptors the batch holds open until run(): its data files and outputs.
  std::size_t numDescriptors() const { return data_.size() + outputs_.size(); }
  /// Runs gnuplot (if there is any figure) and commits every output. Throws InputError naming
  /// `what` on failure; then no output is committed.
  void run(const std::string& what);

 private:
  std::map<std::string, std::unique_ptr<MemFile>> data_;
  std::ostringstream script_;
  std::vector<std::unique_ptr<io::AtomicOutputFile>> outputs_;
};

/// Checks that the data written to `os` (a figure's data file `name`) all arrived; InputError
/// otherwise (e.g. no descriptor left to open the in-memory file).
void finishData(std::ostream& os, const std::string& name);

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
