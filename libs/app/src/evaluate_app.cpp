#include "dbacov/app/evaluate_app.h"
#include "dbacov/app/run_summary.h"

#include <cmath>
#include <cstdio>
#include <optional>
#include <sstream>

#include <CLI/CLI.hpp>

#include "cli_common.h"
#include "dbacov/app/evaluation_inputs.h"
#include "dbacov/app/evaluation_report.h"
#include "dbacov/app/progress.h"
#include "dbacov/app/scenario_options.h"
#include "dbacov/core/threads.h"
#include "dbacov/io/atomic_file.h"
#include "dbacov/sim/monte_carlo.h"
#include "engine_cli.h"
#include "path_checks.h"
#include "self_calibration_cli.h"

namespace dbacov::app {
namespace {

constexpr const char* kFooter = R"(
What it computes (NEES over the range of Sigma, the ANEES and its 95% region, coverage,
Spearman, relative NEES, the calibration k), the table and ground-truth formats and the Monte
Carlo mode: docs/apps/dba-evaluate.md; the error and tangent conventions: docs/conventions.md §3, §7.
Exit status: 0 success, 1 when an input or output failed or nothing could be evaluated, 2 on bad
usage.)";

/// Checks the combination of options; throws std::invalid_argument with the reason.
/// Refuses a --body-to-camera that would turn every ground-truth pose into NaN (a non-finite
/// entry) or into an arbitrary rotation (a quaternion without a direction, which Eigen's
/// normalized() leaves as it is).
void checkBodyToCamera(const std::vector<double>& v) {
  static const char* const names[7] = {"tx", "ty", "tz", "qx", "qy", "qz", "qw"};
  auto text = [](double x) {
    char buf[32];
    std::snprintf(buf, sizeof buf, "%g", x);
    return std::string(buf);
  };
  for (int i = 0; i < 7; ++i)
    if (!std::isfinite(v[i]))
      throw std::invalid_argument(std::string("--body-to-camera: ") + names[i] + " is " +
                                  text(v[i]) + ", expected a finite number");
  // norm() as poseFromTQ's normalization computes it: it underflows to 0 below ~1e-154 and
  // overflows above ~1e154; stableNorm() is the value to show.
  const Eigen::Vector4d q(v[3], v[4], v[5], v[6]);
  if (!(q.norm() > 1e-9) || !std::isfinite(q.norm()))
    throw std::invalid_argument("--body-to-camera: the quaternion qx qy qz qw = " + text(v[3]) +
                                " " + text(v[4]) + " " + text(v[5]) + " " + text(v[6]) +
                                " is no rotation (norm " + text(q.stableNorm()) +
                                "): give a unit quaternion (0 0 0 1 for none)");
}

void checkUsage(const EvaluateOptions& o) {
  io::OutputPlan plan;  // no output onto an input or onto another output
  plan.input(o.csv, "--csv");
  plan.input(o.relative_csv, "--relative-csv");
  plan.input(o.rawlog, "--rawlog");
  plan.input(o.gt, "--gt");
  plan.input(o.image_times, "--image-times");
  plan.input(o.scenario.config_path, "--config");
  plan.output(o.json, "--json");
  plan.output(o.samples_csv, "--samples-csv");
  plan.check();
  const SelfCalibrationAppOptions& sc = o.self_calibration;
  if ((sc.stated_model || sc.nodes >= 0 || !sc.depth_noise.empty()) && o.monte_carlo == 0)
    throw std::invalid_argument(
        std::string(sc.stated_model ? "--stated-model" : "the self-calibration options") +
        " apply to --monte-carlo only (dba-covariance computes the files' covariances)");
  sc.options();  // refuses a calibration option with --stated-model
  for (const char* flag : {"--fps", "--start-time", "--weight-scale"})
    o.scenario.number(flag);  // a malformed number is bad usage, found before any work
  if (o.calibrate && o.inflation)
    throw std::invalid_argument("give either --calibrate or --inflation");
  if (o.calibration_runs > 0 && o.inflation)
    throw std::invalid_argument("give either --calibration-runs or --inflation");
  const bool files = !o.csv.empty() || !o.relative_csv.empty() || !o.rawlog.empty();
  if (o.monte_carlo > 0) {
    if (files || !o.gt.empty())
      throw std::invalid_argument(
          "--monte-carlo simulates its own data: no --csv, --relative-csv, --rawlog or --gt");
    if (o.calibration_runs >= o.monte_carlo)
      throw std::invalid_argument(
          "--calibration-runs must be smaller than --monte-carlo (runs are held out for "
          "evaluation)");
    return;
  }
  if (o.scenario.anyScenarioSetting())
    throw std::invalid_argument("scenario options apply to --monte-carlo only");
  if (o.calibration_runs > 0)
    throw std::invalid_argument(
        "--calibration-runs applies to --monte-carlo only (use --calibrate)");
  if (!files)
    throw std::invalid_argument(
        "nothing to evaluate: give --csv [--relative-csv], --rawlog, or --monte-carlo N");
  if (o.gt.empty()) throw std::invalid_argument("--gt is required with covariance files");
  if (!o.relative_csv.empty() && o.csv.empty())
    throw std::invalid_argument("--relative-csv needs --csv (it gives the keyframes' times)");
  if (!o.csv.empty() && !o.scenario.number("--fps") && o.image_times.empty())
    throw std::invalid_argument(
        "--csv needs --fps [--start-time] or --image-times to turn tstamp into seconds");
  if (o.align == "sim3" && !o.rawlog.empty())
    throw std::invalid_argument(
        "--align sim3 needs --csv/--relative-csv (a rawlog has no joint covariances)");
  if (!o.body_to_camera.empty() && o.body_to_camera.size() != 7)
    throw std::invalid_argument("--body-to-camera takes 7 numbers: tx ty tz qx qy qz qw");
  if (!o.body_to_camera.empty()) checkBodyToCamera(o.body_to_camera);
}

std::vector<ReportSection> fileSections(const EvaluateOptions& o, std::ostream& err,
                                        bool* any_failed) {
  GroundTruth gt = GroundTruth::load(o.gt, parseGroundTruthFormat(o.gt_format));
  if (!o.body_to_camera.empty()) gt.applyBodyToCamera(poseFromTQ(o.body_to_camera.data()));
  FileSampleOptions fo;
  fo.time_tolerance = o.time_tolerance;
  fo.max_gap = o.max_gap;
  fo.align_sim3 = o.align == "sim3";
  fo.consecutive_only = o.pairs == "consecutive";
  std::vector<ReportSection> sections;
  auto report_skipped = [&](const std::vector<std::string>& skipped) {
    for (std::size_t i = 0; i < skipped.size() && i < 5; ++i)
      err << "dba-evaluate: warning: " << skipped[i] << '\n';
    if (skipped.size() > 5)
      err << "dba-evaluate: warning: ... and " << skipped.size() - 5
          << " more rows without ground truth\n";
  };
  const std::string pair_title = fo.consecutive_only ? "consecutive keyframes" : "co-visible pairs";
  if (!o.csv.empty()) {
    const KeyframeTimes times =
        o.image_times.empty()
            ? KeyframeTimes::fromRate(*o.scenario.number("--fps"),
                                      o.scenario.number("--start-time").value_or(0.0))
            : KeyframeTimes::fromFile(o.image_times);
    const auto kf = readKeyframeCsv(o.csv);
    const auto rel = o.relative_csv.empty() ? std::vector<RelativeCovarianceRow>{}
                                            : readRelativeCsv(o.relative_csv);
    FileSamples fs = samplesFromTables(kf, rel, gt, times, fo);
    report_skipped(fs.skipped);
    if (!fo.align_sim3)
      sections.push_back({"absolute", "absolute NEES (keyframes of " + o.csv + ")", fs.absolute});
    if (!o.relative_csv.empty())
      sections.push_back({"relative",
                          "relative NEES (" + pair_title + " of " + o.relative_csv + ")",
                          fs.relative});
  }
  if (!o.rawlog.empty()) {
    FileSamples fs = samplesFromRawlog(readPoseRawlog(o.rawlog, o.rawlog_label), gt, fo);
    report_skipped(fs.skipped);
    sections.push_back(
        {"rawlog_absolute", "absolute NEES (poses of " + o.rawlog + ")", fs.absolute});
  }
  bool any = false;
  for (const auto& s : sections) any |= !s.samples.empty();
  if (!any) {
    err << "dba-evaluate: error: no sample could be evaluated (no ground truth matched, or every "
           "covariance is singular)\n";
    *any_failed = true;
  }
  return sections;
}

std::vector<NeesSample> fitSet(const std::vector<ReportSection>& sections,
                               const std::string& prefix, std::string* name) {
  for (const char* kind : {"relative", "absolute"})
    for (const auto& s : sections)
      if (s.key == prefix + kind && !s.samples.empty()) {
        *name = std::string(kind) + " NEES";
        return s.samples;
      }
  for (const auto& s : sections)
    if (!s.samples.empty()) {
      *name = s.key;
      return s.samples;
    }
  return {};
}

/// Fits or applies the variance inflation (--calibrate, --calibration-runs, --inflation) on the
/// sections; nothing when none is asked for.
std::optional<Calibration> calibration(const EvaluateOptions& o,
                                       const std::vector<ReportSection>& sections,
                                       double weight_scale, const std::string& fit_prefix,
                                       const std::string& fit_runs) {
  if (!(o.calibrate || o.calibration_runs > 0 || o.inflation)) return std::nullopt;
  Calibration cal;
  cal.weight_scale = weight_scale;
  if (o.inflation) {
    cal.k = *o.inflation;
    cal.fitted = false;
    return cal;
  }
  std::string name;
  const auto set = fitSet(sections, fit_prefix, &name);
  if (set.empty()) throw NumericalError("no sample to fit the variance inflation on", {});
  cal.k = fitInflation(set);
  cal.fit_samples = set.size();
  cal.fitted_on = fit_runs.empty() ? name : name + " of " + fit_runs;
  return cal;
}

/// The Monte Carlo sections: held-out evaluation runs and, with --calibration-runs M, the M
/// calibration runs before them.
std::vector<ReportSection> monteCarloSections(const EvaluateOptions& o,
                                              const sim::ScenarioConfig& config, std::ostream& err,
                                              std::optional<Calibration>* cal) {
  const sim::Scenario sc(config);
  const DbaOptions engine = config.engineOptions();
  const auto pairs =
      o.pairs == "all" ? sim::PairSelection::CoVisible : sim::PairSelection::Consecutive;
  const int total = o.monte_carlo * sc.numSnapshots();
  Progress progress(err, static_cast<std::size_t>(total), !o.quiet);
  auto step = [&](int, int) { progress.step("Monte Carlo"); };
  const std::string gauge = toString(config.gauge.type);
  const int M = o.calibration_runs, first = o.first_run;
  auto describe = [&](int a, int b) {
    return "runs " + std::to_string(a) + ".." + std::to_string(b - 1);
  };
  std::optional<SelfCalibrationOptions> selfcal;
  if (o.self_calibration.calibrated()) selfcal = o.self_calibration.options();
  const SelfCalibrationOptions* sc_options = selfcal ? &*selfcal : nullptr;
  const sim::MonteCarloResult eval =
      sim::runMonteCarlo(sc, first + M, o.monte_carlo - M, engine, pairs, step, sc_options);
  std::optional<sim::MonteCarloResult> fit;
  if (M > 0) fit = sim::runMonteCarlo(sc, first, M, engine, pairs, step, sc_options);
  progress.clear();
  const int bad = eval.not_converged + (fit ? fit->not_converged : 0);
  if (bad) err << "dba-evaluate: warning: " << bad << " DBA solves did not converge\n";
  const std::string held = M > 0 ? "held-out " : "";
  const std::string what =
      " (" + describe(first + M, first + o.monte_carlo) + ", gauge " + gauge + " at the truth)";
  std::vector<ReportSection> sections;
  if (fit)
    sections.push_back({"calibration_relative",
                        "calibration set: relative NEES (" + describe(first, first + M) + ")",
                        fit->samples.relative});
  sections.push_back({"absolute", held + "absolute NEES" + what, eval.samples.absolute});
  sections.push_back({"relative",
                      held + "relative NEES, " +
                          (pairs == sim::PairSelection::Consecutive ? "consecutive keyframes"
                                                                    : "co-visible pairs") +
                          what,
                      eval.samples.relative});
  *cal = calibration(o, sections, config.weight_scale, M > 0 ? "calibration_" : "",
                     M > 0 ? describe(first, first + M) : describe(first, first + o.monte_carlo));
  return sections;
}

/// Stage 1: the command line into `o` (and the scenario of --monte-carlo into `config`).
/// Returns the exit status when the run is over (--help, bad usage).
std::optional<int> parse(int argc, const char* const* argv, std::ostream& out, std::ostream& err,
                         EvaluateOptions& o) {
  CLI::App cli{
      "dba-evaluate: consistency of DBA pose covariances against ground truth (NEES, coverage, "
      "calibration)",
      "dba-evaluate"};
  cli.footer(kFooter);
  cli.add_option("--csv", o.csv, "Keyframe table of dba-covariance --csv");
  cli.add_option("--relative-csv", o.relative_csv,
                 "Pair table of dba-covariance --relative-csv (relative NEES)");
  cli.add_option("--rawlog", o.rawlog, "Pose rawlog of dba-covariance -o (absolute NEES only)");
  cli.add_option("--rawlog-label", o.rawlog_label,
                 "Only observations with this sensorLabel (default: all)");
  cli.add_option("--gt", o.gt, "Ground truth: TUM trajectory or EuRoC ground-truth CSV");
  cli.add_option("--gt-format", o.gt_format, "auto (EuRoC when comma-separated), tum or euroc")
      ->check(CLI::IsMember({"auto", "tum", "euroc"}));
  cli.add_option("--body-to-camera", o.body_to_camera,
                 "T_body_cam as tx ty tz qx qy qz qw (EuRoC: cam0's T_BS)")
      ->expected(7);
  cli.add_option("--image-times", o.image_times,
                 "Image times: tstamp k is line k (seconds, or EuRoC cam0/data.csv in ns)");
  cli.add_option("--time-tolerance", o.time_tolerance,
                 "Seconds within which a ground-truth sample matches (default 1e-3)")
      ->check(detail::positiveNumber(true));
  cli.add_option(
         "--max-gap", o.max_gap,
         "Interpolate ground truth between samples at most this many seconds apart (default 0.1)")
      ->check(detail::positiveNumber(true));
  cli.add_option("--align", o.align,
                 "none (estimate in the truth's frame: absolute + relative NEES) or sim3 (per "
                 "snapshot; relative only)")
      ->check(CLI::IsMember({"none", "sim3"}));
  cli.add_option("--pairs", o.pairs,
                 "Relative NEES over consecutive keyframes (default) or all co-visible pairs")
      ->check(CLI::IsMember({"consecutive", "all"}));
  cli.add_option("--monte-carlo", o.monte_carlo,
                 "Monte Carlo: N noise draws of the simulated scenario")
      ->check(detail::integerIn(1, 1000000));
  cli.add_option("--first-run", o.first_run,
                 "Monte Carlo: index of the first noise draw (default 0)")
      ->check(detail::positiveNumber(true));
  cli.add_option("--calibration-runs", o.calibration_runs,
                 "Monte Carlo: fit k on the first M runs, evaluate the others")
      ->check(detail::positiveNumber(true));
  cli.add_flag("--calibrate", o.calibrate,
               "Fit the variance inflation k on the evaluated samples and report before/after");
  cli.add_option("--inflation", o.inflation,
                 "Apply a given variance inflation k (fitted elsewhere)")
      ->check(detail::positiveNumber());
  cli.add_option("--json", o.json, "Write the statistics as JSON");
  cli.add_option("--samples-csv", o.samples_csv,
                 "Write every sample: section,run,group,dof,nees,e_0..e_5,sigma_0..sigma_5");
  cli.add_flag("-q,--quiet", o.quiet, "No progress display");
  o.scenario.add(cli);
  detail::addSelfCalibrationOptions(cli, o.self_calibration, false);  // Monte Carlo only
  cli.get_option("--weight-scale")
      ->description(
          "Weight scale of the covariances: Monte Carlo, the simulation's (default 4); files, the "
          "one dba-covariance used (default 0.001 = preset droid), for the calibrated value");
  try {
    cli.parse(argc, argv);
    checkUsage(o);
  } catch (...) {
    return detail::usageExitStatus(cli, "dba-evaluate", out, err);
  }
  return std::nullopt;
}

}  // namespace

int runEvaluate(const EvaluateOptions& o, std::ostream& out, std::ostream& err) {
  std::optional<sim::ScenarioConfig> config;
  try {
    checkUsage(o);
    checkEngineEnvironment();  // DBACOV_KERNEL_ISA
    if (o.monte_carlo > 0) config = o.scenario.resolve();
    if (config && config->gauge_hold == sim::GaugeHold::Estimate)
      throw std::invalid_argument(sim::kMonteCarloNeedsTruthGauge);
  } catch (const std::exception& e) {
    err << "dba-evaluate: " << e.what() << "\nRun with --help for usage.\n";
    return 2;
  }
  bool failed = false;
  std::vector<ReportSection> sections;
  std::optional<Calibration> cal;
  try {
    if (config) {
      sections = monteCarloSections(o, *config, err, &cal);
    } else {
      sections = fileSections(o, err, &failed);
      if (!failed)
        cal = calibration(
            o, sections,
            o.scenario.number("--weight-scale").value_or(DbaOptions::kDroidWeightScale), "", "");
    }
    if (!failed) {
      printReport(out, sections, cal);
      if (!o.json.empty())
        io::writeFileAtomically(o.json, [&](std::ostream& os) { os << reportJson(sections, cal); });
      if (!o.samples_csv.empty())
        io::writeFileAtomically(o.samples_csv,
                                [&](std::ostream& os) { os << samplesCsv(sections); });
    }
  } catch (const std::exception& e) {
    err << "dba-evaluate: error: " << failureMessage(e) << '\n';
    return 1;
  }
  return failed ? 1 : 0;
}

int runEvaluateApp(int argc, const char* const* argv, std::ostream& out, std::ostream& err) {
  EvaluateOptions o;
  if (const auto status = parse(argc, argv, out, err, o)) return *status;
  return runEvaluate(o, out, err);
}

}  // namespace dbacov::app
