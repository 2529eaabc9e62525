#include "self_calibration_cli.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <limits>
#include <sstream>
#include <stdexcept>

#include "dbacov/io/atomic_file.h"
#include "dbacov/sim/bootstrap.h"
#include "dbacov/sim/calibrated_solve.h"
#include "dbacov/sim/dba_solver.h"
#include "engine_cli.h"

namespace dbacov::app {

SelfCalibrationOptions SelfCalibrationAppOptions::options() const {
  SelfCalibrationOptions o;
  if (!method.empty()) o.method = parseSelfCalibrationMethod(method);
  if (iterations > 0) {
    // nuisance, sandwich and bootstrap take one pass: a number of them would be ignored.
    if (o.method != SelfCalibrationMethod::Vce && o.method != SelfCalibrationMethod::Score &&
        o.method != SelfCalibrationMethod::Autocorr)
      throw std::invalid_argument(std::string("self-calibration iterations apply to the vce, ") +
                                  "score and autocorr methods only, not " + toString(o.method));
    o.iterations = iterations;
  }
  if (nodes >= 0) {
    if (o.method != SelfCalibrationMethod::Nuisance && o.method != SelfCalibrationMethod::Bootstrap)
      throw std::invalid_argument(std::string("self-calibration nodes apply to the nuisance ") +
                                  "and bootstrap methods only, not " + toString(o.method));
    o.nuisance_nodes = nodes;
  }
  if (replicates >= 0) {
    if (o.method != SelfCalibrationMethod::Bootstrap)
      throw std::invalid_argument(std::string("self-calibration replicates apply to the ") +
                                  "bootstrap method only, not " + toString(o.method));
    o.bootstrap_replicates = replicates;
  }
  if (!resampling.empty()) {
    if (o.method != SelfCalibrationMethod::Bootstrap)
      throw std::invalid_argument(std::string("self-calibration resampling applies to the ") +
                                  "bootstrap method only, not " + toString(o.method));
    o.bootstrap_resampling = parseEnum<BootstrapResampling>(resampling);
  }
  if (!depth_noise.empty()) {
    if (depth_noise != "on" && depth_noise != "off")
      throw std::invalid_argument("self-calibration depth noise is on or off, not '" + depth_noise +
                                  "'");
    if (depth_noise == "on" && o.method == SelfCalibrationMethod::Bootstrap)
      throw std::invalid_argument(std::string("the depths' noise term applies to the residual ") +
                                  "methods, not bootstrap (which re-solves instead)");
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
  cli.add_flag("--self-calibrate", o.enabled,
               "Estimate each edge's noise (scale and correlation) from the snapshot's residuals "
               "and inflate its pixel information accordingly (no ground truth)");
  cli.add_option("--self-calibrate-method", o.method,
                 enumNameList<SelfCalibrationMethod>() + " (default " +
                     toString(SelfCalibrationOptions{}.method) + "); implies --self-calibrate")
      ->check(enumValidator<SelfCalibrationMethod>())
      ->each([&o](const std::string&) { o.enabled = true; });
  cli.add_option("--self-calibrate-iterations", o.iterations,
                 "Reweighting passes of vce/score/autocorr (default 1); implies --self-calibrate")
      ->check(integerIn(1, 20))
      ->each([&o](const std::string&) { o.enabled = true; });
  cli.add_option("--self-calibrate-nodes", o.nodes,
                 "nuisance: the per-edge flow error field, 0 = affine, G = affine + G x G "
                 "bilinear spline per channel (default " +
                     std::to_string(SelfCalibrationOptions{}.nuisance_nodes) +
                     "); implies --self-calibrate")
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
          "INT in {0, 2..8}"))
      ->each([&o](const std::string&) { o.enabled = true; });
  cli.add_option("--self-calibrate-replicates", o.replicates,
                 "bootstrap: re-solved replicates of each snapshot (default " +
                     std::to_string(SelfCalibrationOptions{}.bootstrap_replicates) +
                     "); implies --self-calibrate")
      ->check(integerIn(4, 100000))
      ->each([&o](const std::string&) { o.enabled = true; });
  cli.add_option("--self-calibrate-resampling", o.resampling,
                 "bootstrap: the replicates' white noise, " + enumNameList<BootstrapResampling>() +
                     " (default " + toString(SelfCalibrationOptions{}.bootstrap_resampling) +
                     "; wild = each row's own residual with a random sign); implies "
                     "--self-calibrate")
      ->check(enumValidator<BootstrapResampling>())
      ->each([&o](const std::string&) { o.enabled = true; });
  cli.add_option("--self-calibrate-depth-noise", o.depth_noise,
                 std::string("on|off: add the depths' second-order noise term, what the "
                             "linearization misses where depths are poorly determined (default ") +
                     (SelfCalibrationOptions{}.depth_noise ? "on" : "off") +
                     "; not with bootstrap); implies --self-calibrate")
      ->check(CLI::IsMember({"on", "off"}))
      ->each([&o](const std::string&) { o.enabled = true; });
  if (!outputs) return;
  cli.add_option("--edge-csv", o.edge_csv,
                 "With --self-calibrate: one row per (snapshot, edge): pixels, residual RMS, "
                 "inflation, effective pixels, method");
  cli.add_flag("--converge", o.converge,
               "Solve each snapshot's DBA to the optimum of its own factors (project's solver) "
               "before computing covariances; outputs then hold the solved poses. With "
               "--self-calibrate, stereo edges and RGB-D readings are re-weighted at their "
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
    : cli_(cli), options_(cli.options()) {
  if (!cli_.edge_csv.empty() && !cli_.enabled)
    throw std::invalid_argument("--edge-csv needs --self-calibrate");
}

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
  // With --self-calibrate, --converge solves at the calibrated weights of the factors on the
  // depths alone (stereo edges, RGB-D readings): at the claimed ones the estimate is biased when
  // they are mis-weighted against the flow (calibrated_solve.h). The covariance then belongs to
  // those weights.
  DbaOptions oc = o;
  std::optional<CalibratedSolve> reweighted;
  if (cli_.converge) {
    DbaSolverSummary sum;
    if (cli_.enabled) {
      reweighted = solveDbaAtCalibratedWeights(s, o, kCalibratedMaxSolves,
                                               kCalibratedRatioTolerance, cli_.convergeSolver());
      oc = reweighted->options;
      sum = reweighted->solver;
    } else {
      sum = solveDba(s, o, cli_.convergeSolver());
    }
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
  if (!cli_.enabled) {
    std::lock_guard<std::mutex> lock(mutex_);
    converged_ += converged;
    if (!text.empty()) warnings_[s.index] = text;
    return std::make_unique<DbaCovariance>(s, o, solver);
  }
  const SelfCalibration cal = runSelfCalibration(s, oc, options_);
  auto cov = std::make_unique<DbaCovariance>(selfCalibratedCovariance(s, oc, solver, cal));
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
  std::ostringstream rows;
  for (const EdgeCalibration& e : cal.edges)
    rows << s.label() << ',' << e.i << ',' << e.j << ',' << e.pixels << ','
         << number(e.residual_rms) << ',' << number(e.inflation) << ','
         << number(e.effective_pixels) << ',' << toString(cal.method) << ',' << number(e.redundancy)
         << ',' << number(e.vce_scale) << ',' << number(e.correlation) << '\n';
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
  if (cal.method == SelfCalibrationMethod::Nuisance ||
      cal.method == SelfCalibrationMethod::Bootstrap) {
    field_sigmas_.push_back(cal.nuisance_sigma);
    fine_sigmas_.push_back(cal.nuisance_fine_sigma);
  }
  if (cal.method == SelfCalibrationMethod::Bootstrap) {
    boot_scales_.push_back(cal.bootstrap_scale);
    boot_failed_ += cal.bootstrap_failed;
  }
  if (cal.depth_noise && cal.method != SelfCalibrationMethod::Bootstrap) {
    depth_shares_.push_back(cov->summary().self_calibration.depth_noise_share);
    kurtoses_.push_back(cov->summary().self_calibration.depth_noise_kurtosis);
    cross_kurtoses_.push_back(cov->summary().self_calibration.depth_noise_cross_kurtosis);
  }
  steps_.push_back(cal.optimum.step_sigma / std::sqrt(std::max(1, cal.optimum.free_dof)));
  gradients_.push_back(cal.optimum.gradient_norm);
  ++snapshots_;
  unreliable_ += unreliable;
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
  if (!cli_.enabled) return os.str();
  if (cli_.converge) os << "; ";
  os << "self-calibration " << toString(options_.method) << ": " << snapshots_ << " snapshots";
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
  if (!boot_scales_.empty()) {
    const auto [lo, hi] = std::minmax_element(boot_scales_.begin(), boot_scales_.end());
    os << ", bootstrap scale median " << number(median(boot_scales_)) << " (" << number(*lo)
       << " to " << number(*hi) << ", " << options_.bootstrap_replicates
       << " replicates per snapshot";
    if (options_.bootstrap_resampling != BootstrapResampling::Parametric)
      os << ", " << toString(options_.bootstrap_resampling) << " resampling";
    if (boot_failed_) os << ", " << boot_failed_ << " unconverged left out";
    os << ")";
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
  return os.str();
}

}  // namespace detail
}  // namespace dbacov::app
