// The per-keyframe depth figure and the gnuplot batch shared by every figure of --plots.
#include <sys/stat.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <fstream>
#include <limits>

#include "dbacov/app/csv_format.h"
#include "plots_internal.h"

namespace dbacov::app::detail {
namespace {

/// Perceptually ordered palette (viridis-like), for both maps.
constexpr const char* kPalette =
    "set palette defined (0 '#440154', 0.25 '#3b528b', 0.5 '#21918c', 0.75 '#5ec962', 1 "
    "'#fde725')\n";

struct Range {
  double lo = std::numeric_limits<double>::infinity(), hi = -lo;
  bool empty() const { return !(lo <= hi); }
};

/// Writes an H×W map as a gnuplot matrix (non-finite → NaN, drawn grey) and returns the range of
/// the finite values.
Range writeMatrix(const std::string& path, const std::vector<float>& v, int H, int W) {
  std::ofstream os(path);
  Range r;
  for (int y = 0; y < H; ++y) {
    for (int x = 0; x < W; ++x) {
      const double value = v[static_cast<std::size_t>(y) * W + x];
      const bool ok = std::isfinite(value);
      if (ok) {
        r.lo = std::min(r.lo, value);
        r.hi = std::max(r.hi, value);
      }
      os << (x ? " " : "") << (ok ? num(value) : "NaN");
    }
    os << '\n';
  }
  finishData(os, path);
  return r;
}

std::string cbrange(Range r) {
  if (r.lo == r.hi) {  // a constant map: a range around it
    r.lo -= 0.5 * (std::abs(r.lo) + 1e-12);
    r.hi += 0.5 * (std::abs(r.hi) + 1e-12);
  }
  return "set cbrange [" + num(r.lo) + ":" + num(r.hi) + "]\n";
}

}  // namespace

std::string num(double v) {
  if (!std::isfinite(v)) return "NaN";
  char buf[32];
  std::snprintf(buf, sizeof buf, "%.9g", v);
  return buf;
}

std::string plural(std::size_t n, const std::string& what) {
  return std::to_string(n) + " " + what + (n == 1 ? "" : "s");
}

std::string sequenceTitle(const SequenceHistory& h) {
  return plural(h.numKeyframes(), "keyframe") + " from " + plural(h.numSnapshots(), "snapshot") +
         " (each keyframe from the last snapshot in which it is not a gauge keyframe)";
}

std::string timeLabel(bool times) {
  return times ? "time since the first keyframe [s]"
               : "keyframe time stamp (DROID tstamp: image index)";
}

void finishData(std::ostream& os, const std::string& name) {
  if (!os.flush()) throw InputError("cannot write the figure data " + name + " (in memory)");
}

std::string FigureBatch::data(const std::string& name) {
  auto& file = data_[name];
  if (!file) file = std::make_unique<MemFile>(name);
  return file->path();
}

std::string FigureBatch::output(const std::string& final_path) {
  outputs_.push_back(std::make_unique<io::AtomicOutputFile>(final_path));
  return gnuplotQuote(outputs_.back()->writePath());
}

void FigureBatch::run(const std::string& what) {
  if (outputs_.empty()) return;
  const MemFile script("figures.gp"), log("gnuplot.log");
  {
    std::ofstream os(script.path());
    os << "set encoding utf8\n" << script_.str();
    if (!os.flush()) throw InputError(what + ": cannot write the gnuplot script");
  }
  std::vector<int> inherit{script.fd()};
  for (const auto& [name, file] : data_) inherit.push_back(file->fd());
  for (const auto& out : outputs_) inherit.push_back(out->fd());
  runGnuplot(script.path(), log, inherit, what);
  for (const auto& out : outputs_) {
    struct stat st {};
    if (::fstat(out->fd(), &st) != 0 || st.st_size == 0)
      throw InputError(out->finalPath() + ": gnuplot wrote no picture");
  }
  for (const auto& out : outputs_) out->commit();
}

void depthFigure(FigureBatch& batch, const DepthMaps& m, double tstamp, int n,
                 const std::string& path) {
  const std::string d_file = batch.data("disp_" + std::to_string(n) + ".dat");
  const std::string s_file = batch.data("log_sigma_" + std::to_string(n) + ".dat");
  std::vector<float> log_sigma(m.sigma.size());
  std::transform(m.sigma.begin(), m.sigma.end(), log_sigma.begin(), [](float v) {
    return v > 0 && std::isfinite(v) ? std::log10(v) : std::numeric_limits<float>::quiet_NaN();
  });
  const Range d = writeMatrix(d_file, m.disp, m.H, m.W);
  const Range s = writeMatrix(s_file, log_sigma, m.H, m.W);
  if (s.empty() || d.empty()) return;
  // Two panels side by side, each about 300 px wide for the map plus margins and colour bar; the
  // height follows the grid's aspect ratio.
  const int map_w = 300, map_h = std::clamp(map_w * m.H / std::max(m.W, 1), 80, 1200);
  std::ostream& g = batch.script();
  g << "set terminal pngcairo size 1200," << map_h + 200 << " font 'DejaVu Sans,11' noenhanced\n"
    << "set output " << batch.output(path) << "\n"
    << "set multiplot title "
    << gnuplotQuote("keyframe " + std::to_string(m.keyframe) + " of snapshot " +
                    std::to_string(m.snapshot) + " (tstamp " + formatDouble(tstamp) + ")")
    << " font ',13'\n"
    << kPalette << "set size ratio -1\nset xrange [-0.5:" << m.W - 0.5 << "]\nset yrange ["
    << m.H - 0.5 << ":-0.5]\nset xlabel 'x [px]'\nset ylabel 'y [px]'\nset tics out\n"
    << "set lmargin 9\nset rmargin 17\nset tmargin 4\nset bmargin 4\n"
    << "set object 1 rectangle from graph 0,0 to graph 1,1 behind fillcolor rgb '#c8c8c8' fs solid "
       "noborder\n"
    << "set origin 0,0\nset size 0.5,1\n"
    << "set title 'inverse depth d'\nset cblabel 'd  [1 / length unit]'\n"
    << cbrange(d) << "plot " << gnuplotQuote(d_file) << " matrix with image notitle\n"
    << "set origin 0.5,0\nset size 0.5,1\n"
    << "set title 'standard deviation of d (grey: no information)'\n"
    << "set cblabel 'log10 σ(d)  [σ in 1 / length unit]'\n"
    << cbrange(s) << "plot " << gnuplotQuote(s_file) << " matrix with image notitle\n"
    << "unset multiplot\nreset\n";
}

}  // namespace dbacov::app::detail
