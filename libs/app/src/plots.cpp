#include "dbacov/app/plots.h"

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <set>

#include "dbacov/app/csv_format.h"
#include "dbacov/core/criteria.h"
#include "dbacov/io/atomic_file.h"
#include "plots_internal.h"

namespace dbacov::app {
namespace {

using detail::gnuplotQuote;

constexpr double kRadToDeg = 180.0 / M_PI;
constexpr std::size_t kFiguresPerBatch = 100;  ///< figures per gnuplot run

/// One keyframe's plotted values.
struct Row {
  const KeyframeRecord* r;
  double x;  // abscissa: seconds since the first keyframe, or tstamp
  UncertaintyCriteria c;
  double sigma[6];  // ρx ρy ρz (length), φx φy φz (degrees)
};

std::vector<Row> plotRows(const std::vector<KeyframeRecord>& kfs, bool times) {
  std::vector<Row> rows;
  for (const auto& r : kfs) {
    Row row{&r, times ? *r.time_s - *kfs.front().time_s : r.tstamp, computeCriteria(r.Sigma), {}};
    for (int i = 0; i < 6; ++i)
      row.sigma[i] = std::sqrt(std::max(r.Sigma(i, i), 0.0)) * (i < 3 ? 1.0 : kRadToDeg);
    rows.push_back(row);
  }
  return rows;
}

/// gnuplot's `set xrange` over the rows' abscissae (explicit: a figure whose values are all
/// missing must still have a valid range).
std::string xrange(const std::vector<Row>& rows) {
  double lo = INFINITY, hi = -INFINITY;
  for (const Row& w : rows) {
    lo = std::min(lo, w.x);
    hi = std::max(hi, w.x);
  }
  const double pad = hi > lo ? 0.03 * (hi - lo) : 0.5 * (std::abs(lo) + 1);
  return "set xrange [" + detail::num(lo - pad) + ":" + detail::num(hi + pad) + "]\n";
}

void writeKeyframesCsv(const std::vector<Row>& rows, const std::string& path) {
  io::writeFileAtomically(path, [&](std::ostream& os) {
    os << plotKeyframesCsvHeader() << '\n';
    for (std::size_t n = 0; n < rows.size(); ++n) {
      const Row& w = rows[n];
      os << n << ',' << formatDouble(w.r->tstamp) << ','
         << (w.r->time_s ? formatDouble(*w.r->time_s) : std::string()) << ',' << w.r->snapshot
         << ',' << w.r->keyframe << ',' << (w.r->gauge ? 1 : 0);
      for (double v : {w.c.log10_det, w.c.log10_det_trans, w.c.log10_det_rot})
        os << ',' << formatDouble(v);
      for (double v : w.sigma) os << ',' << formatDouble(v);
      os << '\n';
    }
  });
}

/// The paper's figure: log10 det Σ over time next to the co-visibility matrix.
void covarianceFigure(detail::FigureBatch& batch, const SequenceHistory& h,
                      const std::vector<Row>& rows, bool times, const std::string& path) {
  std::ofstream det(batch.data("det.dat"));
  const int n = static_cast<int>(rows.size());
  // Integer tics of the matrix, about a dozen: 1, 2, 5, 10, 20, ...
  int tics = 1;
  for (int decade = 1; n > 12 * tics; decade *= 10)
    for (int m : {1, 2, 5})
      if (n > 12 * tics) tics = m * decade;
  int fixed = 0, gauge = 0;
  for (const Row& w : rows) {
    if (!std::isfinite(w.c.log10_det)) {
      ++fixed;
      continue;
    }
    gauge += w.r->gauge ? 1 : 0;
    det << detail::num(w.x) << ' ' << detail::num(w.c.log10_det) << ' ' << (w.r->gauge ? 1 : 0)
        << '\n';
  }
  // Edges only in earlier snapshots (blue) and those of the last snapshot (orange); with a single
  // snapshot there is no such distinction and every edge is blue.
  const auto last = h.lastSnapshotEdges();
  const std::set<std::pair<int, int>> last_set(last.begin(), last.end());
  const bool split = h.numSnapshots() > 1;
  std::ofstream earlier(batch.data("edges_earlier.dat")), current(batch.data("edges_last.dat"));
  for (const auto& [i, j] : h.edges())
    (split && last_set.count({i, j}) ? current : earlier) << j << ' ' << i << '\n';
  earlier << "NaN NaN\n";  // keeps gnuplot quiet about empty files
  current << "NaN NaN\n";
  det << "NaN NaN 0\n";
  detail::finishData(earlier, "edges_earlier.dat");
  detail::finishData(current, "edges_last.dat");
  detail::finishData(det, "det.dat");
  std::ostream& g = batch.script();
  g << "set terminal pngcairo size 1500,640 font 'DejaVu Sans,12' noenhanced\n"
    << "set output " << batch.output(path) << "\n"
    << "set multiplot title " << gnuplotQuote(detail::sequenceTitle(h)) << " font ',13'\n"
    << "set origin 0,0\nset size 0.6,0.94\nset grid\nset key top left box opaque\n"
    << "set title "
    << gnuplotQuote(fixed ? "log10 det Σ per keyframe (" + std::to_string(fixed) +
                                " hard-fixed gauge keyframes, det Σ = 0, not shown)"
                          : "log10 det Σ per keyframe")
    << "\nset xlabel " << gnuplotQuote(detail::timeLabel(times)) << "\n"
    << xrange(rows)
    << (fixed == n ? "set yrange [0:1]\nset label 1 'no keyframe with a non-singular covariance' "
                     "at graph 0.5, graph 0.5 center\n"
                   : "")
    << "set ylabel 'log10 det Σ   (Σ: 6×6 tangent covariance [ρ; φ], unit² and rad²)'\n"
    << "plot " << gnuplotQuote(batch.data("det.dat"))
    << " using 1:($3 == 0 ? $2 : NaN) with linespoints lw 2 pt 7 ps 1.1 lc rgb '#1f4e9c'"
       " title 'keyframe'"
    << (gauge ? ", '' using 1:($3 == 1 ? $2 : NaN) with points pt 6 ps 1.4 lc rgb '#888888'"
                " title 'gauge keyframe (prior)'"
              : "")
    << "\n"
    << "set origin 0.6,0\nset size 0.4,0.94\nunset grid\nunset label 1\nset size ratio -1\n"
    << "set title 'co-visibility (adjacency) matrix'\n"
    << "set xlabel 'target keyframe j (sequence number)'\nset ylabel 'source keyframe i'\n"
    << "set xrange [-0.5:" << n - 0.5 << "]\nset yrange [" << n - 0.5 << ":-0.5]\n"
    << "set xtics out " << tics << "\nset ytics out " << tics
    << "\nset bmargin 7\nset key at graph 0.5, graph -0.16 center top box\n"
    << "plot " << gnuplotQuote(batch.data("edges_earlier.dat"))
    << " using 1:2:(0.5):(0.5) with boxxyerror fs solid 1.0 noborder lc rgb '#1f4e9c'"
    << (split ? " title 'edge i→j in an earlier snapshot', " +
                    gnuplotQuote(batch.data("edges_last.dat")) +
                    " using 1:2:(0.5):(0.5) with boxxyerror fs solid 1.0 noborder lc rgb '#e66101'"
                    " title 'edge in the last snapshot'"
              : std::string(" title 'edge i→j'"))
    << "\n"
    << "unset multiplot\nreset\n";
}

/// Standard deviations of the translation and rotation over time (log scale when they span more
/// than a factor of 20).
void sigmaFigure(detail::FigureBatch& batch, const SequenceHistory& h, const std::vector<Row>& rows,
                 bool times, const std::string& path) {
  std::ofstream sig(batch.data("sigma.dat"));
  for (const Row& w : rows) {
    sig << detail::num(w.x);
    for (double v : w.sigma) sig << ' ' << (v > 0 ? detail::num(v) : "NaN");
    sig << '\n';
  }
  detail::finishData(sig, "sigma.dat");
  const std::string data = gnuplotQuote(batch.data("sigma.dat"));
  // Log scale only when a panel's values span more than a factor of 20 (else a linear axis from
  // 0 is easier to read).
  auto scale = [&](int first) {
    double lo = INFINITY, hi = 0;
    for (const Row& w : rows)
      for (int i = first; i < first + 3; ++i)
        if (w.sigma[i] > 0) {
          lo = std::min(lo, w.sigma[i]);
          hi = std::max(hi, w.sigma[i]);
        }
    if (!(hi > 0)) return std::string("unset logscale y\nset yrange [0:1]\n");  // all fixed
    return hi > 20 * lo ? std::string("set logscale y\nset format y '%g'\nset yrange [*:*]\n")
                        : std::string("unset logscale y\nset format y '%g'\nset yrange [0:*]\n");
  };
  const bool any_zero = std::any_of(rows.begin(), rows.end(), [](const Row& w) {
    return std::any_of(w.sigma, w.sigma + 6, [](double v) { return !(v > 0); });
  });
  const std::string zeros = any_zero ? "; zero (hard-fixed) values not shown" : "";
  std::ostream& g = batch.script();
  g << "set terminal pngcairo size 1200,860 font 'DejaVu Sans,12' noenhanced\n"
    << "set output " << batch.output(path) << "\n"
    << "set multiplot layout 2,1 title " << gnuplotQuote(detail::sequenceTitle(h))
    << " font ',13'\n"
    << "set grid\nset key outside right top\n"
    << xrange(rows) << "set lmargin 12\nset rmargin 20\n"
    << "set xlabel " << gnuplotQuote(detail::timeLabel(times)) << "\n"
    << "set title "
    << gnuplotQuote("translation standard deviation (tangent ρ, camera axes)" + zeros) << "\n"
    << "set ylabel 'σ [length unit]'\n"
    << scale(0) << "plot " << data
    << " using 1:2 with linespoints pt 7 lw 2 lc rgb '#d62728' title 'x (right)', "
    << "'' using 1:3 with linespoints pt 7 lw 2 lc rgb '#2ca02c' title 'y (down)', "
    << "'' using 1:4 with linespoints pt 7 lw 2 lc rgb '#1f77b4' title 'z (forward)'\n"
    << "set title "
    << gnuplotQuote("rotation standard deviation (tangent φ, about the camera axes)" + zeros)
    << "\n"
    << "set ylabel 'σ [deg]'\n"
    << scale(3) << "plot " << data
    << " using 1:5 with linespoints pt 7 lw 2 lc rgb '#d62728' title 'about x', "
    << "'' using 1:6 with linespoints pt 7 lw 2 lc rgb '#2ca02c' title 'about y', "
    << "'' using 1:7 with linespoints pt 7 lw 2 lc rgb '#1f77b4' title 'about z'\n"
    << "unset multiplot\nreset\n";
}

}  // namespace

std::string plotKeyframesCsvHeader() {
  return "sequence,tstamp,time_s,snapshot,keyframe,gauge,log10_det,log10_det_trans,log10_det_rot,"
         "sigma_tx,sigma_ty,sigma_tz,sigma_rx_deg,sigma_ry_deg,sigma_rz_deg";
}

void writeSequencePlots(const SequenceHistory& h, const std::map<double, DepthMaps>& maps,
                        const std::string& dir) {
  std::error_code ec;
  std::filesystem::create_directories(dir, ec);
  if (ec || !std::filesystem::is_directory(dir))
    throw InputError(dir + ": cannot create the plots directory" + (ec ? ": " + ec.message() : ""));
  const std::vector<KeyframeRecord> kfs = h.keyframes();
  const bool times = h.hasTimes();
  const std::vector<Row> rows = plotRows(kfs, times);

  auto batch = std::make_unique<detail::FigureBatch>();
  if (!rows.empty()) {
    covarianceFigure(*batch, h, rows, times, dir + "/covariance_covisibility.png");
    sigmaFigure(*batch, h, rows, times, dir + "/pose_sigmas.png");
  }
  if (!maps.empty()) {
    const std::string maps_dir = dir + "/depth_sigma";
    std::filesystem::create_directories(maps_dir, ec);
    if (ec) throw InputError(maps_dir + ": cannot create the directory: " + ec.message());
    int n = 0;
    for (const auto& [tstamp, m] : maps) {
      detail::depthFigure(
          *batch, m, tstamp, n++,
          maps_dir + "/" + std::to_string(m.snapshot) + "_" + std::to_string(m.keyframe) + ".png");
      // A figure holds three descriptors until its batch runs (two data files, the picture; a
      // map without finite values only its data files): stay far below the usual 1024.
      if (batch->numDescriptors() >= 3 * kFiguresPerBatch) {
        batch->run("--plots " + dir);
        batch = std::make_unique<detail::FigureBatch>();
      }
    }
  }
  batch->run("--plots " + dir);
  writeKeyframesCsv(rows, dir + "/keyframes.csv");
}

}  // namespace dbacov::app
