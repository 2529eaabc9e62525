// Self-calibration study (docs/studies/self-calibration.md): noise sources × {raw, calibrated
// against ground truth, the product's self-calibration and its variants, the bootstrap}, Monte
// Carlo over held-out runs.
//
//   build-study/bin/self_calibration_study [--help] [--runs N] [--calibration-runs M]
//       [--first-run R] [--sources a,b,...] [--methods raw,gt,nuisance,...]
//
// Scene: explore-and-return in the box room, 13 keyframes, 24×32 grid, one whole-trajectory
// snapshot per run, DBA solved to the optimum, first two keyframes held at the truth, weight
// scale 100 (the issue's test bed); `lowsnr` is the default scenario (48×64, sliding window of 8,
// weight scale 4). "gt" fits one variance factor k = Σ NEES / Σ DoF (absolute samples) on the
// calibration runs (as dba-evaluate --calibrate) and applies it to the held-out runs. Runs used:
// calibration [R, R+M), evaluation [R+M, R+M+N). Methods: nuisance (the product's) and bootstrap
// (dbacov/study/bootstrap.h). Suffixes: -g<G> (the spline nodes), -wild (the bootstrap's wild
// resampling), -k0 (the depths' term without its fourth-cumulant share), -d0 (without the depths'
// second-order noise term, on by default), -solved (the
// state re-solved at the claimed weights first, as DROID solves: solveDba), -calsolved (solved at
// the calibrated weights of the depth-only factors first: solveDbaAtCalibratedWeights, as
// --self-calibrate --converge). Without either the state is the scenario's, the optimum of the
// true noise model.
#include <CLI/CLI.hpp>
#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <exception>
#include <map>
#include <sstream>
#include <string>
#include <vector>

#include "dbacov/core/calibrated_solve.h"
#include "dbacov/core/errors.h"
#include "dbacov/core/self_calibration.h"
#include "dbacov/sim/consistency.h"
#include "dbacov/sim/monte_carlo.h"
#include "dbacov/sim/scenario.h"
#include "dbacov/study/bootstrap.h"

using namespace dbacov;

namespace {

struct Source {
  std::string name, description;
  sim::ScenarioConfig config;
  double claimed_scale_factor = 1.0;   ///< covariances computed with weight_scale × this
  double claimed_sensor_factor = 1.0;  ///< RGB-D: and with the sensor depths' α × this
  double claimed_stereo_factor = 1.0;  ///< stereo: the stereo edges' confidences × this
};

sim::ScenarioConfig issueScene() {
  sim::ScenarioConfig c;
  c.camera.H = 24;
  c.camera.W = 32;
  c.trajectory.type = sim::TrajectoryType::ExploreReturn;
  c.trajectory.num_keyframes = 13;
  c.mode = sim::SimulationMode::WholeTrajectory;
  c.weight_scale = 100.0;
  c.seed = 7;
  return c;
}

/// The issue's scene in one of DROID's other modes, one held pose (metric scale).
sim::ScenarioConfig droidScene(sim::SensorMode mode) {
  sim::ScenarioConfig c = issueScene();
  c.sensor.mode = mode;
  c.gauge.type = GaugeOptions::Type::Droid;
  return c;
}

std::vector<Source> allSources() {
  std::vector<Source> v;
  {
    Source s{"white", "white, as claimed", issueScene()};
    v.push_back(s);
  }
  {
    Source s{"white2x", "white, 2x the claimed sigma", issueScene()};
    s.config.noise.amplitude = 2.0;
    v.push_back(s);
  }
  {
    Source s{"wrongscale", "white as claimed, --weight-scale 4x too high", issueScene()};
    s.claimed_scale_factor = 4.0;
    v.push_back(s);
  }
  {
    Source s{"field", "random field (4 px, 0.15 px) + white 1.5x", issueScene()};
    s.config.noise.field_px = 0.15;
    s.config.noise.field_length_px = 4.0;
    s.config.noise.amplitude = 1.5;
    v.push_back(s);
  }
  {
    Source s{"affine", "per-edge affine flow error 0.1 px", issueScene()};
    s.config.noise.affine_px = 0.1;
    v.push_back(s);
  }
  {
    // The same kind of error 5x weaker: what of "affine" is the size of the error (nonlinearity)
    Source s{"affine-weak", "per-edge affine flow error 0.02 px", issueScene()};
    s.config.noise.affine_px = 0.02;
    v.push_back(s);
  }
  {
    Source s{"affine+outliers", "affine 0.05 px + 2 % outlier pixels (10x)", issueScene()};
    s.config.noise.affine_px = 0.05;
    s.config.noise.outlier_fraction = 0.02;
    s.config.noise.outlier_factor = 10.0;
    v.push_back(s);
  }
  {
    Source s{"outliers", "white + 2 % outlier pixels (10x)", issueScene()};
    s.config.noise.outlier_fraction = 0.02;
    s.config.noise.outlier_factor = 10.0;
    v.push_back(s);
  }
  {
    Source s{"edge-spread", "white as claimed, each edge's sigma x exp(0.4 z)", issueScene()};
    s.config.noise.edge_scale_spread = 0.4;
    v.push_back(s);
  }
  {
    Source s{"student-t", "white as claimed, Student-t with 4 degrees of freedom", issueScene()};
    s.config.noise.student_t_dof = 4;
    v.push_back(s);
  }
  {
    Source s{"lowsnr", "default scene at weight scale 4 (white)", sim::ScenarioConfig()};
    v.push_back(s);
  }
  // DROID's other modes, one held pose (metric scale): the factors on the depths alone with the
  // wrong claimed noise too (stereo edges: the flow's noise; RGB-D: α claimed 4x too high).
  {
    Source s{"stereo", "stereo, white as claimed", droidScene(sim::SensorMode::Stereo)};
    v.push_back(s);
  }
  {
    Source s{"stereo-white2x", "stereo, white 2x the claimed sigma (flow and stereo)",
             droidScene(sim::SensorMode::Stereo)};
    s.config.noise.amplitude = 2.0;
    v.push_back(s);
  }
  {
    Source s{"rgbd", "RGB-D, white and sensor depths as claimed",
             droidScene(sim::SensorMode::Rgbd)};
    v.push_back(s);
  }
  {
    Source s{"rgbd-alpha4x", "RGB-D, white as claimed, sensor depths' alpha claimed 4x too high",
             droidScene(sim::SensorMode::Rgbd)};
    s.claimed_sensor_factor = 4.0;
    v.push_back(s);
  }
  {
    Source s{"stereo-weights4x", "stereo, white as claimed, stereo edges' confidences 4x too high",
             droidScene(sim::SensorMode::Stereo)};
    s.claimed_stereo_factor = 4.0;
    v.push_back(s);
  }
  return v;
}

std::vector<std::string> split(const std::string& s) {
  std::vector<std::string> out;
  std::stringstream ss(s);
  std::string item;
  while (std::getline(ss, item, ',')) out.push_back(item);
  return out;
}

struct Row {
  sim::EvaluationSamples samples;
  double seconds = 0;
  int snapshots = 0;
  /// What each snapshot's self-calibration reported (methods that calibrate).
  std::vector<SelfCalibrationSummary> calibrations;
  int failed = 0;  ///< snapshots whose covariance failed (a NumericalError: not positive definite)
};

}  // namespace

/// A --methods entry: raw, gt, or a method with suffixes (the header above), parsed.
struct MethodSpec {
  enum class State { Scenario, Solved, CalSolved } state = State::Scenario;
  bool covariance_only = false;  ///< raw or gt (gt: the raw covariances, scaled by k)
  bool bootstrap = false;
  SelfCalibrationOptions options;
  BootstrapOptions bootstrap_options;
};

/// Throws std::invalid_argument naming the entry when it is not one.
MethodSpec parseMethod(const std::string& entry) {
  MethodSpec spec;
  std::string name = entry;
  const auto take = [&name](const std::string& suffix) {
    const std::size_t at = name.find(suffix);
    if (at == std::string::npos) return false;
    name.erase(at, suffix.size());
    return true;
  };
  // "-solved" / "-calsolved": the state solved at the claimed / calibrated weights.
  if (take("-calsolved"))
    spec.state = MethodSpec::State::CalSolved;
  else if (take("-solved"))
    spec.state = MethodSpec::State::Solved;
  if (name == "raw" || name == "gt") {
    if (name == "gt" && spec.state != MethodSpec::State::Scenario)
      // k is fitted on the scenario's states, not on solved ones
      throw std::invalid_argument(entry + ": gt takes no suffix");
    spec.covariance_only = true;
    return spec;
  }
  SelfCalibrationOptions& c = spec.options;
  // "-wild": the bootstrap's wild resampling; "-k0": the depths' term without its
  // fourth-cumulant share; "-d0": without the depths' second-order noise term (on by default).
  if (take("-wild")) spec.bootstrap_options.resampling = BootstrapResampling::Wild;
  if (take("-k0")) c.depth_noise_kurtosis = false;
  if (take("-d0")) c.depth_noise = false;
  // "-g<G>": the affine field + a G × G tent spline (G = 0: affine only). Last in the name.
  const auto number = [&](const std::string& suffix, int* out) {
    const std::size_t at = name.find(suffix);
    if (at == std::string::npos) return;
    const std::string digits = name.substr(at + suffix.size());
    std::size_t used = 0;
    try {
      *out = std::stoi(digits, &used);
    } catch (const std::logic_error&) {
      used = std::string::npos;
    }
    if (used != digits.size())
      throw std::invalid_argument(entry + ": '" + suffix + digits + "' needs an integer");
    name.erase(at);
  };
  number("-g", &c.nuisance_nodes);
  if (name == "bootstrap")
    spec.bootstrap = true;
  else if (name != "nuisance")
    throw std::invalid_argument(entry + ": unknown method '" + name +
                                "', expected raw, gt, nuisance or bootstrap (the methods that "
                                "lost, vce, autocorr, score and sandwich, are in the history: "
                                "docs/studies/self-calibration.md)");
  c.validate();
  return spec;
}

namespace {

struct StudyPlan {
  int runs = 20, calibration_runs = 10, first_run = 1000;
  std::vector<std::string> methods;
  std::map<std::string, MethodSpec> specs;
};

/// The held-out rows of one source, one per method (gt's NEES already scaled by its k).
std::map<std::string, Row> evaluateSource(const Source& src, const StudyPlan& plan, double* k,
                                          int* simulation_failures) {
  const sim::Scenario sc(src.config);
  DbaOptions o = src.config.engineOptions();
  o.weight_scale *= src.claimed_scale_factor;
  o.sensor_depth_weight *= src.claimed_sensor_factor;
  std::map<std::string, Row> rows;
  sim::EvaluationSamples calib;
  const auto run_all = [&](int run, bool evaluation) {
    for (int s = 0; s < sc.numSnapshots(); ++s) {
      sim::SimulatedSnapshot snap;
      try {
        snap = sc.simulate(s, static_cast<std::uint64_t>(run));
      } catch (const NumericalError& e) {  // the scenario's own solve broke down: no estimate
        std::fprintf(stderr, "self_calibration_study: %s: run %d skipped: %s\n", src.name.c_str(),
                     run, e.what());
        ++*simulation_failures;
        continue;
      }
      if (src.claimed_stereo_factor != 1.0)
        for (int e = 0; e < snap.snapshot.numEdges(); ++e)
          if (snap.snapshot.ii[e] == snap.snapshot.jj[e])
            divideEdgeWeights(snap.snapshot, e, 1.0 / src.claimed_stereo_factor);
      const std::int64_t label = static_cast<std::int64_t>(run) * sc.numSnapshots() + s;
      if (!evaluation) {
        calib.append(sim::evaluateSnapshot(snap, o, label));
        continue;
      }
      for (const std::string& m : plan.methods) {
        const auto t0 = std::chrono::steady_clock::now();
        const MethodSpec& spec = plan.specs.at(m);
        sim::SimulatedSnapshot solved;
        const sim::SimulatedSnapshot* at = &snap;
        DbaOptions oc = o;
        // The solves' errors name the snapshot and the entry, as evaluateSnapshot's do.
        try {
          if (spec.state == MethodSpec::State::CalSolved) {
            solved = snap;
            oc = solveDbaAtCalibratedWeights(solved.snapshot, o).options;
            at = &solved;
          } else if (spec.state == MethodSpec::State::Solved) {
            solved = snap;
            solveDba(solved.snapshot, o);
            at = &solved;
          }
        } catch (const NumericalError& e) {
          throw NumericalError(snap.snapshot.name() + ": " + m + ": " + e.what(), e.keyframes());
        } catch (const std::exception& e) {
          throw std::runtime_error(snap.snapshot.name() + ": " + m + ": " + e.what());
        }
        // The bootstrap re-solves (dbacov_study); nuisance is the product's pipeline.
        Row& r = rows[m];
        const sim::CovarianceFunction covariance =
            spec.covariance_only ? sim::pipelineCovariance(nullptr)
            : spec.bootstrap
                ? sim::CovarianceFunction([&spec](const Snapshot& one, const DbaOptions& opt) {
                    return selfCalibratedCovariance(
                        one, opt, {},
                        bootstrapSelfCalibration(one, opt, spec.options, spec.bootstrap_options)
                            .calibration);
                  })
                : sim::CovarianceFunction([&spec, &r](const Snapshot& one, const DbaOptions& opt) {
                    DbaCovariance cov = sim::pipelineCovariance(&spec.options)(one, opt);
                    r.calibrations.push_back(cov.summary().self_calibration);
                    return cov;
                  });
        sim::EvaluationSamples x;
        try {
          x = sim::evaluateSnapshot(*at, oc, label, sim::PairSelection::Consecutive, covariance);
        } catch (const NumericalError& e) {  // counted: a method that cannot answer fails here
          std::fprintf(stderr, "self_calibration_study: %s: %s: %s\n", src.name.c_str(), m.c_str(),
                       e.what());
          ++r.failed;
          continue;
        }
        r.seconds += std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
        ++r.snapshots;
        r.samples.append(x);
      }
    }
  };
  const int first = plan.first_run, held_out = first + plan.calibration_runs;
  for (int run = first; run < held_out; ++run) run_all(run, false);
  for (int run = held_out; run < held_out + plan.runs; ++run) run_all(run, true);
  *k = plan.calibration_runs > 0 ? fitInflation(calib.absolute) : 1.0;
  if (rows.count("gt")) {
    rows["gt"].samples.absolute = inflate(rows["gt"].samples.absolute, *k);
    rows["gt"].samples.relative = inflate(rows["gt"].samples.relative, *k);
  }
  return rows;
}

void printRow(const std::string& source, const std::string& method, const Row& r) {
  const ConsistencyStats a = summarize(r.samples.absolute), rel = summarize(r.samples.relative);
  std::printf(
      "| %s | %s | %.2f%s | [%.2f, %.2f] | %.2f%s | [%.2f, %.2f] | %.1f %% | %.1f %% | %.1f %% "
      "| %.3f |\n",
      source.c_str(), method.c_str(), a.anees, a.inside ? "" : " ✗", a.region.lower, a.region.upper,
      rel.anees, rel.inside ? "" : " ✗", rel.region.lower, rel.region.upper,
      100 * a.coverage_all[0], 100 * a.coverage_all[1], 100 * a.tail_95, r.seconds / r.snapshots);
  if (r.failed) std::printf("  failed snapshots: %d\n", r.failed);
  std::fflush(stdout);
}

double quantile(std::vector<double> x, double q) {
  std::sort(x.begin(), x.end());
  const double at = q * static_cast<double>(x.size() - 1);
  const std::size_t lo = static_cast<std::size_t>(at);
  const std::size_t hi = std::min(lo + 1, x.size() - 1);
  return x[lo] + (at - static_cast<double>(lo)) * (x[hi] - x[lo]);
}

/// The family's summary of one method over its drawn models (absolute NEES): the fraction of
/// models above and below their χ² region, the median ANEES / DoF, the 1σ coverage's median and
/// the quantiles of the NEES tail beyond χ²(0.95).
void printFamilySummary(const std::string& method, const std::vector<ConsistencyStats>& stats) {
  std::vector<double> ratio, coverage, tail;
  int above = 0, below = 0;
  for (const ConsistencyStats& a : stats) {
    above += a.anees > a.region.upper;
    below += a.anees < a.region.lower;
    ratio.push_back(a.anees / a.dof);
    coverage.push_back(a.coverage_all[0]);
    tail.push_back(a.tail_95);
  }
  const double n = static_cast<double>(stats.size());
  std::printf(
      "| %s | %zu | %.1f %% | %.1f %% | %.2f | %.2f | %.1f %% [%.1f, %.1f] | %.1f %% | %.1f %% | "
      "%.1f %% |\n",
      method.c_str(), stats.size(), 100 * above / n, 100 * below / n, quantile(ratio, 0.5),
      quantile(ratio, 0.9), 100 * quantile(coverage, 0.5), 100 * quantile(coverage, 0.1),
      100 * quantile(coverage, 0.9), 100 * quantile(tail, 0.5), 100 * quantile(tail, 0.9),
      100 * quantile(tail, 0.99));
  std::fflush(stdout);
}

/// The medians over a row's snapshots of what its self-calibration reported, one line: the
/// depths' term's share of the trace, its largest direction share ρ, the residuals' excess
/// kurtosis, the spread of the edges' white scales (SelfCalibrationSummary::edge_scale_spread)
/// and the fraction of snapshots whose fit check failed (poor_fit).
void printCalibrationMedians(const Row& r) {
  if (r.calibrations.empty()) return;
  std::vector<double> share, rho, kurtosis, spread;
  double poor = 0;
  for (const SelfCalibrationSummary& c : r.calibrations) {
    share.push_back(c.depth_noise_share);
    rho.push_back(c.depth_noise_max_rho);
    kurtosis.push_back(c.depth_noise_kurtosis);
    spread.push_back(c.edge_scale_spread);
    poor += c.poor_fit ? 1.0 / static_cast<double>(r.calibrations.size()) : 0.0;
  }
  std::printf(
      "  calibration medians: depth term %.4f, max rho %.3f, kurtosis %.3f, scale spread %.3f, "
      "poor fit %.2f\n",
      quantile(share, 0.5), quantile(rho, 0.5), quantile(kurtosis, 0.5), quantile(spread, 0.5),
      poor);
}

/// `count` error models drawn from the open family (pixel_models.h), model m on the study's
/// scene in mode m mod 3 (monocular, stereo, RGB-D): one row per model and method, then the
/// family's summary per method.
int familyStudy(int first, int count, std::uint64_t seed, const StudyPlan& plan) {
  const sim::SensorMode modes[3] = {sim::SensorMode::Mono, sim::SensorMode::Stereo,
                                    sim::SensorMode::Rgbd};
  std::map<std::string, std::vector<ConsistencyStats>> stats;
  for (int m = first; m < first + count; ++m) {
    const sim::SensorMode mode = modes[m % 3];
    Source src{"", "", mode == sim::SensorMode::Mono ? issueScene() : droidScene(mode)};
    src.config.noise = sim::drawNoiseModel(src.config.noise, sim::mixSeed(seed, m, 0),
                                           src.config.camera.H, src.config.camera.W);
    src.name = std::string(mode == sim::SensorMode::Mono     ? "mono"
                           : mode == sim::SensorMode::Stereo ? "stereo"
                                                             : "rgbd") +
               " #" + std::to_string(m) + ": " + sim::describe(src.config.noise);
    double k = 1;
    int simulation_failures = 0;
    const std::map<std::string, Row> rows = evaluateSource(src, plan, &k, &simulation_failures);
    if (simulation_failures) std::printf("  simulation failures: %d\n", simulation_failures);
    for (const std::string& method : plan.methods) {
      if (!rows.count(method) || rows.at(method).samples.absolute.empty()) {
        std::printf("| %s | %s | every snapshot failed |\n", src.name.c_str(), method.c_str());
        continue;
      }
      printRow(src.name, method, rows.at(method));
      stats[method].push_back(summarize(rows.at(method).samples.absolute));
      printCalibrationMedians(rows.at(method));
    }
  }
  std::printf(
      "\n| method | models | above region | below region | ANEES/DoF median | 90 %% | 1σ median "
      "[10 %%, 90 %%] | tail median | 90 %% | 99 %% "
      "|\n|---|---|---|---|---|---|---|---|---|---|\n");
  for (const std::string& method : plan.methods) printFamilySummary(method, stats[method]);
  return 0;
}

int study(int argc, char** argv) {
  StudyPlan plan;
  int family = 0, family_first = 0;
  std::uint64_t family_seed = 48;
  std::string sources_arg = "white,white2x,wrongscale,field,affine,affine+outliers",
              methods_arg = "raw,gt,nuisance";
  std::string source_names;
  for (const Source& src : allSources())
    source_names += (source_names.empty() ? "" : ", ") + src.name;
  CLI::App cli{
      "Self-calibration study (docs/studies/self-calibration.md): noise sources x {raw, calibrated "
      "against ground truth (gt), the self-calibration (nuisance) and its variants, the "
      "bootstrap}, Monte Carlo over held-out runs; prints one Markdown table row per (source, "
      "method).",
      "self_calibration_study"};
  cli.add_option("--runs", plan.runs, "held-out (evaluation) runs per source")
      ->check(CLI::Range(1, 100000))
      ->capture_default_str();
  cli.add_option("--calibration-runs", plan.calibration_runs,
                 "runs that gt's variance factor is fitted on")
      ->check(CLI::Range(0, 100000))
      ->capture_default_str();
  cli.add_option("--first-run", plan.first_run, "seed of the first calibration run")
      ->check(CLI::NonNegativeNumber)
      ->capture_default_str();
  cli.add_option("--sources", sources_arg, "comma-separated, of: " + source_names)
      ->capture_default_str();
  cli.add_option("--methods", methods_arg,
                 "comma-separated: raw, gt, nuisance or bootstrap, with suffixes -g<G>, -wild, "
                 "-k0, -d0, -solved, -calsolved (see the source's header)")
      ->capture_default_str();
  cli.add_option("--family", family,
                 "instead of --sources: this many error models drawn from the open family "
                 "(simul-dba --noise-family open), on the monocular, stereo and RGB-D scenes in "
                 "turn, then the family's summary per method")
      ->check(CLI::Range(0, 100000));
  cli.add_option("--family-seed", family_seed, "seed of the family's draws")->capture_default_str();
  cli.add_option("--family-first", family_first,
                 "index of the first model drawn (to split a study)")
      ->check(CLI::NonNegativeNumber)
      ->capture_default_str();
  try {
    cli.parse(argc, argv);
  } catch (const CLI::ParseError& e) {
    return cli.exit(e) == 0 ? 0 : 2;  // --help; a usage error exits 2, as the apps' do
  }
  for (const std::string& w : split(sources_arg)) {
    bool known = false;
    for (const Source& src : allSources()) known |= w == src.name;
    if (!known) {
      std::fprintf(stderr, "self_calibration_study: unknown source '%s', expected %s\n", w.c_str(),
                   source_names.c_str());
      return 2;
    }
  }
  const std::vector<std::string> want_sources = split(sources_arg);
  plan.methods = split(methods_arg);
  for (const std::string& m : plan.methods) {  // every entry checked before any run
    try {
      plan.specs[m] = parseMethod(m);
    } catch (const std::invalid_argument& e) {
      std::fprintf(stderr, "self_calibration_study: --methods: %s\n", e.what());
      return 2;
    }
  }
  std::printf(
      "| source | method | ANEES abs | region | ANEES rel | region | 1σ | 2σ | NEES > χ²(0.95) "
      "| s/snapshot |\n|---|---|---|---|---|---|---|---|---|---|\n");
  if (family > 0) return familyStudy(family_first, family, family_seed, plan);
  for (const Source& src : allSources()) {
    bool wanted = false;
    for (const std::string& w : want_sources) wanted |= w == src.name;
    if (!wanted) continue;
    double k = 1;
    int simulation_failures = 0;
    const std::map<std::string, Row> rows = evaluateSource(src, plan, &k, &simulation_failures);
    for (const std::string& m : plan.methods)
      printRow(src.name, m == "gt" ? "gt (k=" + std::to_string(k).substr(0, 6) + ")" : m,
               rows.at(m));
  }
  return 0;
}

}  // namespace

int main(int argc, char** argv) {
  // An error (a snapshot's numerical breakdown, a bad option value) is a line naming it and exit 1,
  // not an abort.
  try {
    return study(argc, argv);
  } catch (const std::exception& e) {
    std::fprintf(stderr, "self_calibration_study: %s\n", e.what());
    return 1;
  }
}
