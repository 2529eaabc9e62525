#include "self_calibration_cli.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <limits>
#include <sstream>
#include <stdexcept>

#include "dbacov/core/calibrated_solve.h"
#include "dbacov/core/dba_solver.h"
#include "dbacov/io/atomic_file.h"
#include "engine_cli.h"

namespace dbacov::app {

PipelineOptions SelfCalibrationAppOptions::pipeline(const DbaOptions& engine,
                                                    const CovarianceOptions& solver) const {
  PipelineOptions p;
  p.engine = engine;
  p.solver = solver;
  p.stated_model = stated_model;
  p.calibration = options();
  p.converge = converge;
  p.converge_solver = convergeSolver();
  return p;
}

SelfCalibrationOptions SelfCalibrationAppOptions::options() const {
  if (stated_model && (nodes >= 0 || !depth_noise.empty() || !edge_csv.empty()))
    throw std::invalid_argument(
        std::string(nodes >= 0             ? "--self-calibrate-nodes"
                    : !depth_noise.empty() ? "--self-calibrate-depth-noise"
                                           : "--edge-csv") +
        " applies to the self-calibrated covariance, not with --stated-model");
  SelfCalibrationOptions o;
  if (nodes >= 0) o.nuisance_nodes = nodes;
  if (!depth_noise.empty()) {
    if (depth_noise != "on" && depth_noise != "off")
      throw std::invalid_argument("self-calibration depth noise is on or off, not '" + depth_noise +
                                  "'");
    o.depth_noise = depth_noise == "on";
  }
  o.validate();
  return o;
}

DbaSolverOptions SelfCalibrationAppOptions::convergeSolver() const {
  DbaSolverOptions o;
  o.max_iterations = converge_iterations > 0 ? converge_iterations : kOptimumSolveIterations;
  return o;
}

namespace detail {

void addSelfCalibrationOptions(CLI::App& cli, SelfCalibrationCli& o, bool outputs) {
  cli.add_flag("--stated-model", o.stated_model,
               "Covariances of the noise the snapshot states (confidences x weight scale, an "
               "arbitrary solver scale in DROID) instead of the default: the noise model "
               "self-calibrated from each snapshot's residuals (a per-edge flow-error field, "
               "white scale and the depths' second-order term)");
  cli.add_option("--self-calibrate-nodes", o.nodes,
                 "The per-edge flow-error field: 0 = affine, G = affine + G x G bilinear spline "
                 "per channel (default " +
                     std::to_string(SelfCalibrationOptions{}.nuisance_nodes) + ")")
      ->check(CLI::Validator(
          [](std::string& text) -> std::string {
            // The core's own check and message (SelfCalibrationOptions::validate).
            const std::optional<long long> v = parseInteger(text);
            if (!v || *v < std::numeric_limits<int>::min() || *v > std::numeric_limits<int>::max())
              return "'" + text + "' is not an integer";
            SelfCalibrationOptions c;
            c.nuisance_nodes = static_cast<int>(*v);
            try {
              c.validate();
            } catch (const std::invalid_argument& e) {
              return e.what();
            }
            return {};
          },
          "INT in {0, 2..8}"));
  cli.add_option("--self-calibrate-depth-noise", o.depth_noise,
                 std::string("on|off: add the depths' second-order noise term, what the "
                             "linearization misses where depths are poorly determined (default ") +
                     (SelfCalibrationOptions{}.depth_noise ? "on" : "off") + ")")
      ->check(CLI::IsMember({"on", "off"}));
  if (!outputs) return;
  cli.add_option("--edge-csv", o.edge_csv,
                 "One row per (snapshot, edge) of the self-calibration: pixels, residual RMS, "
                 "white-noise variance factor, effective pixels");
  cli.add_flag("--converge", o.converge,
               "Solve each snapshot's DBA to the optimum of its own factors (project's solver) "
               "before computing covariances; outputs then hold the solved poses. Unless "
               "--stated-model, stereo edges and RGB-D readings are re-weighted at their "
               "calibrated variance ratio to the flow and the DBA re-solved until it settles "
               "(at mis-claimed weights the solved state is biased)");
  cli.add_option("--converge-iterations", o.converge_iterations,
                 "The --converge solve's iteration cap (default " +
                     std::to_string(kOptimumSolveIterations) +
                     "); a solve that reaches it is reported and its state kept; implies "
                     "--converge")
      ->check(integerIn(1, 100000))
      ->each([&o](const std::string&) { o.converge = true; });
}

SelfCalibrationRun::SelfCalibrationRun(const SelfCalibrationCli& cli)
    : cli_(cli), options_(cli.options()) {}

namespace {
std::string number(double x) {
  char buf[32];
  std::snprintf(buf, sizeof buf, "%.6g", x);
  return buf;
}
double median(std::vector<double> v) {
  if (v.empty()) return 0;
  std::nth_element(v.begin(), v.begin() + v.size() / 2, v.end());
  return v[v.size() / 2];
}
}  // namespace

std::unique_ptr<DbaCovariance> SelfCalibrationRun::covariance(Snapshot& s, const DbaOptions& o,
                                                              const CovarianceOptions& solver) {
  std::string text;
  std::string* warning = &text;
  const auto t0 = std::chrono::steady_clock::now();
  bool converged = false;
  const std::string name = s.name();
  PipelineResult result = computeCovariance(s, cli_.pipeline(o, solver));
  const std::optional<CalibratedSolve>& reweighted = result.reweighted;
  if (result.solve) {
    const DbaSolverSummary& sum = *result.solve;
    converged = sum.converged();
    // A solve stopped by the cap says which cap and how to raise it.
    const auto cap = [&](const DbaSolverSummary& solve) {
      const int n = cli_.convergeSolver().max_iterations;
      return solve.termination == DbaTermination::MaxIterations
                 ? "; it reached the cap of " + std::to_string(n) +
                       (n == 1 ? " iteration" : " iterations") +
                       " (--converge-iterations raises it)"
                 : std::string();
    };
    if (!converged && warning)
      *warning =
          name + ": --converge: the DBA solve did not converge (" + sum.brief() + cap(sum) + ")";
    else if (reweighted && !reweighted->settled && warning)
      *warning =
          name + ": --converge: the depth-only factors' variance ratios did not settle in " +
          std::to_string(reweighted->solves) + " solves (still " +
          (reweighted->unmeasured ? "over-weighted beyond measure, at least " +
                                        number(reweighted->last_ratio) + "x off"
                                  : number(reweighted->last_ratio) + "x off") +
          (reweighted->failed_solve
               ? "; the last re-solve did not converge (" + reweighted->failed_solve->brief() +
                     cap(*reweighted->failed_solve) + "): the last converged state is kept"
               : std::string()) +
          ")";
  }
  if (!result.calibration) {
    std::lock_guard<std::mutex> lock(mutex_);
    converged_ += converged;
    if (!text.empty()) warnings_[s.index] = text;
    return std::move(result.cov);
  }
  const SelfCalibration& cal = *result.calibration;
  std::unique_ptr<DbaCovariance> cov = std::move(result.cov);
  const double seconds =
      std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  const bool unreliable = cal.optimum.unreliable();
  if (unreliable && warning && warning->empty())
    *warning =
        name + ": the state is far from the optimum of its factors (one Gauss-Newton step is " +
        number(cal.optimum.step_sigma) + " sigma for " + std::to_string(cal.optimum.free_dof) +
        " free DoF): the self-calibration may be biased; consider --converge";
  // Without --converge the state is the input's, solved at the claimed weights: a depth-only
  // factor far off the flow's variance factor means that state is biased (over-weighted) or
  // wastes their information (under-weighted). The ratios are a single pass's (vce scales at the
  // snapshot's weights); an iterated method's last pass is at re-weighted ones: no check.
  if (!cli_.converge && warning && warning->empty() && cal.passes == 1) {
    const DepthOnlyRatios r = depthOnlyRatios(cal, s.numEdges());
    const double stereo = r.stereoMedian();
    const auto off = [](double x) { return x > 1.5 || x < 1 / 1.5; };
    std::string what;
    double ratio = 1;
    if (r.readings_unmeasured) {
      what =
          "sensor depths fit their readings exactly (no redundancy: alpha over-weighted "
          "beyond measure)";
      ratio = kUnmeasuredStep;
    } else if (!r.unmeasured_edges.empty()) {
      what = "stereo edge " + std::to_string(r.unmeasured_edges.front()) +
             " fits its targets exactly (no redundancy: over-weighted beyond measure)";
      ratio = kUnmeasuredStep;
    } else if (off(r.sensor)) {
      what = "sensor depths' variance factor is " + number(r.sensor) + "x the flow's";
      ratio = r.sensor;
    } else if (off(stereo)) {
      what = "stereo edges' median variance factor is " + number(stereo) + "x the flow's";
      ratio = stereo;
    }
    if (!what.empty())
      *warning = name + ": the " + what +
                 (ratio > 1 ? ": a state solved at the claimed weights is biased (errors in "
                              "variables: over-weighted depths shrink the translation)"
                            : ": under-weighted, the state solved at the claimed weights does "
                              "not use their information") +
                 "; --converge re-solves at the calibrated weights";
  }
  // The noise model's fit check (summary.h): where it fails, the study's open family of error
  // sources found the calibrated covariance over-confident.
  const SelfCalibrationSummary& fit = cov->summary().self_calibration;
  if (fit.poor_fit && warning && warning->empty())
    *warning = name + ": the noise model fits the residuals poorly (edge white-scale spread " +
               number(fit.edge_scale_spread) + ", limit " + number(kPoorFitScaleSpread) +
               "; residual excess kurtosis " + number(fit.depth_noise_kurtosis) + ", limit " +
               number(kPoorFitKurtosis) +
               "): on simulated errors like these the calibrated covariance was over-confident; "
               "treat its sigmas as lower bounds";
  std::ostringstream rows;
  for (const EdgeCalibration& e : cal.edges)
    rows << s.label() << ',' << e.i << ',' << e.j << ',' << e.pixels << ','
         << number(e.residual_rms) << ',' << number(e.inflation) << ','
         << number(e.effective_pixels) << ',' << cal.method << ',' << number(e.redundancy) << ','
         << number(e.vce_scale) << ',' << number(e.correlation) << '\n';
  std::lock_guard<std::mutex> lock(mutex_);
  if (!text.empty()) warnings_[s.index] = text;
  rows_[s.index] += rows.str();
  for (const EdgeCalibration& e : cal.edges)
    if (e.rows > 0) inflations_.push_back(e.inflation);
  scales_.push_back(cal.global_scale);
  if (cal.sensor_depth_rows > 0) sensor_scales_.push_back(cal.sensor_depth_scale);
  if (reweighted && reweighted->solves > 1) {
    ++reweighted_;
    solves_.push_back(reweighted->solves);
    if (s.disps_sens && o.sensor_depth_weight > 0)
      sensor_factors_.push_back(reweighted->sensor_depth_factor);
    for (int e = 0; e < s.numEdges(); ++e)
      if (s.ii[e] == s.jj[e]) stereo_factors_.push_back(reweighted->edge_factors[e]);
  }
  field_sigmas_.push_back(cal.nuisance_sigma);
  fine_sigmas_.push_back(cal.nuisance_fine_sigma);
  if (cal.depth_noise) {
    depth_shares_.push_back(cov->summary().self_calibration.depth_noise_share);
    kurtoses_.push_back(cov->summary().self_calibration.depth_noise_kurtosis);
    cross_kurtoses_.push_back(cov->summary().self_calibration.depth_noise_cross_kurtosis);
  }
  steps_.push_back(cal.optimum.step_sigma / std::sqrt(std::max(1, cal.optimum.free_dof)));
  gradients_.push_back(cal.optimum.gradient_norm);
  ++snapshots_;
  unreliable_ += unreliable;
  poor_fits_ += fit.poor_fit;
  scale_spreads_.push_back(fit.edge_scale_spread);
  converged_ += converged;
  seconds_ += seconds;
  return cov;
}

std::vector<std::string> SelfCalibrationRun::warnings() const {
  std::lock_guard<std::mutex> lock(mutex_);
  std::vector<std::string> w;
  for (const auto& [index, text] : warnings_) w.push_back(text);
  return w;
}

void SelfCalibrationRun::commit() const {
  if (cli_.edge_csv.empty()) return;
  std::lock_guard<std::mutex> lock(mutex_);
  io::writeFileAtomically(cli_.edge_csv, [&](std::ostream& os) {
    os << "snapshot,i,j,pixels,residual_rms,inflation,effective_pixels,method,redundancy,"
          "vce_scale,correlation\n";
    for (const auto& [index, rows] : rows_) os << rows;
  });
}

std::string SelfCalibrationRun::summaryLine() const {
  std::lock_guard<std::mutex> lock(mutex_);
  std::ostringstream os;
  if (cli_.converge) os << "--converge: " << converged_ << " snapshots solved to convergence";
  if (reweighted_) {
    os << " (" << reweighted_ << " re-solved at the calibrated weights of their depth-only "
       << "factors, median " << number(median(solves_)) << " solves";
    if (!sensor_factors_.empty())
      os << ", sensor depths' alpha divided by " << number(median(sensor_factors_));
    if (!stereo_factors_.empty())
      os << ", stereo edges' weights divided by " << number(median(stereo_factors_));
    os << ")";
  }
  if (cli_.converge) os << "; ";
  if (!cli_.calibrated()) {
    os << "noise model: stated (--stated-model: the snapshots' confidences times the weight "
          "scale, not calibrated)";
    return os.str();
  }
  os << "noise model: self-calibrated from the residuals (per-edge flow-error field): "
     << snapshots_ << " snapshots";
  if (!inflations_.empty()) {
    const auto [lo, hi] = std::minmax_element(inflations_.begin(), inflations_.end());
    os << ", edge inflation median " << number(median(inflations_)) << " (" << number(*lo) << " to "
       << number(*hi) << "), global residual scale " << number(median(scales_));
  }
  if (!sensor_scales_.empty())
    os << ", sensor depths' variance factor median " << number(median(sensor_scales_));
  if (!field_sigmas_.empty()) {
    os << ", field sigma median " << number(median(field_sigmas_)) << " px (affine)";
    if (options_.nuisance_nodes >= 2)
      os << ", " << number(median(fine_sigmas_)) << " px (" << options_.nuisance_nodes << "x"
         << options_.nuisance_nodes << " spline)";
  }
  if (!depth_shares_.empty())
    os << ", depths' second-order term median +" << number(100 * median(depth_shares_))
       << " % on the calibrated trace (residual excess kurtosis median "
       << number(median(kurtoses_)) << ", joint across the flow axes "
       << number(median(cross_kurtoses_)) << ")";
  if (snapshots_ > 0) os << ", " << number(seconds_ / snapshots_) << " s per snapshot";
  if (!steps_.empty())
    os << ", Gauss-Newton step to the optimum median " << number(median(steps_))
       << " sigma per sqrt(DoF) (gauge-reduced gradient norm median " << number(median(gradients_))
       << ")";
  if (unreliable_) os << ", " << unreliable_ << " far from their optimum";
  if (!scale_spreads_.empty()) {
    os << ", noise-model fit: "
       << (poor_fits_ ? "poor on " + std::to_string(poor_fits_) + " of " +
                            std::to_string(snapshots_) + " snapshots"
                      : std::string("no sign of misfit"))
       << ", edge white-scale spread median " << number(median(scale_spreads_));
    if (poor_fits_) os << " (their sigmas are lower bounds)";
  }
  return os.str();
}

}  // namespace detail
}  // namespace dbacov::app
