#include "dbacov/app/covariance_app.h"
#include "dbacov/app/run_summary.h"

#include <memory>

#include <CLI/CLI.hpp>

#include "cli_common.h"
#include "dbacov/app/pipeline.h"
#include "dbacov/app/progress.h"
#include "dbacov/app/snapshot_inputs.h"
#include "dbacov/core/covariance.h"
#include "dbacov/core/keyframe_times.h"
#include "dbacov/core/threads.h"
#include "engine_cli.h"
#include "path_checks.h"
#include "self_calibration_cli.h"
#include "visual_cli.h"

namespace dbacov::app {
namespace {

constexpr const char* kConventions = R"(
Conventions (docs/conventions.md): input snapshots are DROID-SLAM DBA dumps (.npz, or rawlogs of
them from droid2rawlog); output poses are camera-to-world T_wc [tx ty tz qx qy qz qw];
covariances are 6x6 over the tangent xi = [rho; phi] (translation first) of the right
perturbation T_wc * Exp(xi), in the snapshot's length units and radians. A pixel factor's stated
information is weight_scale * diag(w_x, w_y) px^-2; the noise model is self-calibrated from the
residuals unless --stated-model. Presets: droid = weight scale 0.001, drop pixels with
z_j*d < 0.25, gauge two-pose hard-fixed; paper = weight scale 0.1, near 0.25 / far 2, gauge
sigmas 1 deg and 0.05; explicit options override the preset. Gauge keyframes are the two
lowest-indexed in 'ii' (hard-fixed: zero covariance, log10_det = -inf). --graph exports the
whole sequence's information counted once (fusable). Every output is written atomically.)";
constexpr const char* kExitStatus = R"TXT(
Failures name the file, snapshot, key, keyframe or edge; with --keep-going (the default) the
other snapshots are processed and every output is written, with --fail-fast no output is
written. The last line on standard error sums up:
"N snapshots read, P processed, F failed: K invalid input (...), K numerical (...), K output (...)".
Environment: DBACOV_PROGRESS_PERIOD=SECONDS (progress period off
a terminal, default 5), DBACOV_KERNEL_ISA=baseline|avx2 (the pixel kernel's variant).
Exit status: 0 success, 1 when any snapshot or output failed, 2 on bad usage.
Every output, picture and message in full: docs/apps/dba-covariance.md.)TXT";

using Sinks = std::vector<std::unique_ptr<OutputSink>>;

/// Stage 1: the command line into `opt`. Returns the exit status when the run is over (--help,
/// bad usage), nothing when it goes on.
std::optional<int> parse(int argc, const char* const* argv, std::ostream& out, std::ostream& err,
                         CovarianceAppOptions& opt) {
  CLI::App cli{"dba-covariance: marginal pose covariances from DROID-SLAM DBA snapshots",
               "dba-covariance"};
  detail::VisualCli visual;  // pictures: --scene, --snapshot, --plots (visual_cli.h)
  cli.footer(std::string(kConventions) + detail::kVisualHelp + kExitStatus);
  cli.add_option("-i,--input", opt.inputs,
                 "Snapshots: a .npz file, a directory of them (name order) or a rawlog of "
                 "snapshots (droid2rawlog); repeatable")
      ->required();
  cli.add_option("--csv", opt.csv_path,
                 "Write one row per (snapshot, graph keyframe): pose, criteria, covariance");
  cli.add_option(
      "-o,--output", opt.rawlog_path,
      "Write a rawlog of CObservationRobotPose (CPose3DPDFGaussian) per emitted keyframe; "
      "needs keyframe times: 'timestamps_s' in the snapshots, or --fps");
  detail::addEnumOption(cli, "--emit", opt.emit,
                        "Keyframes in the rawlog: latest (newest of each snapshot), all, final "
                        "(each once, from its last snapshot)");
  cli.add_option("--label", opt.label,
                 "sensorLabel of the rawlog observations (default DBA_COVARIANCE_CALIBRATED, "
                 "with --stated-model DBA_COVARIANCE)");
  cli.add_option("--fps", opt.fps,
                 "Camera frame rate: keyframe times = start + tstamp / fps for snapshots without "
                 "'timestamps_s' (older DROID dumps, the shared snapshot); finite, > 0; -o needs "
                 "times");
  cli.add_option("--start-time", opt.start_time,
                 "With --fps: time of tstamp 0, s since 1970 (default 0; -o and --graph need "
                 "times > 0)");
  cli.add_option(
      "--graph", opt.graph_prefix,
      "Write the pose graph: PREFIX.graphbin, PREFIX.graph, PREFIX.g2o, PREFIX.nodes.csv");
  detail::addEnumOption(cli, "--graph-edges", opt.graph_edges,
                        "covisibility (default) or chain: the whole-sequence information counted "
                        "once, exported conservatively (fusable); snapshot-marginals-not-fusable: "
                        "the old per-snapshot marginal edges (the same pixels counted many times)");
  cli.add_option("--relative-csv", opt.relative_csv_path,
                 "Write one row per (snapshot, keyframe pair): relative pose and covariance");
  cli.add_option("--depth-sigma", opt.depth_sigma_dir,
                 "Write per-pixel inverse-depth sigma maps (.npy) into this directory");
  detail::addCovarianceOptions(cli, opt.covariance);
  detail::addEngineOptions(cli, opt.engine);
  cli.add_option(
         "--threads", opt.threads,
         "Threads for independent snapshots and for each snapshot's linearization (0 = all cores)")
      ->check(detail::integerIn(0, 4096));
  cli.add_flag("-q,--quiet", opt.quiet, "No progress display and no summary line");
  bool fail_fast = false;
  detail::addFailurePolicyOptions(cli, fail_fast);
  detail::addVisualOptions(cli, visual);
  detail::addSelfCalibrationOptions(cli, opt.self_calibration, true);
  try {
    cli.parse(argc, argv);
    opt.engine.resolve();  // refuses invalid and contradicting engine options as bad usage
    detail::finishVisualOptions(visual);
    opt.scene = visual.scene;
    opt.plots_dir = visual.plots_dir;
    opt.policy = fail_fast ? FailurePolicy::FailFast : FailurePolicy::KeepGoing;
    detail::SelfCalibrationRun check(opt.self_calibration);  // bad method, --edge-csv alone
    if (opt.fps) checkFps(*opt.fps);
    detail::checkCovariancePaths(opt);  // no output onto an input or onto another output
    if (!opt.anyOutput())
      throw std::invalid_argument(
          "no output requested: give -o, --csv, --relative-csv, "
          "--depth-sigma, --graph, --scene, --snapshot, --plots or --edge-csv");
  } catch (...) {
    return detail::usageExitStatus(cli, "dba-covariance", out, err);
  }
  return std::nullopt;
}

/// Stage 2: one sink per requested output, the slowest (pictures) last. Throws InputError when an
/// output cannot be created.
Sinks makeSinks(const CovarianceAppOptions& opt, const DbaOptions& engine, GraphSink** graph) {
  Sinks sinks;
  if (!opt.csv_path.empty()) sinks.push_back(std::make_unique<KeyframeCsvSink>(opt.csv_path));
  if (!opt.relative_csv_path.empty())
    sinks.push_back(std::make_unique<RelativeCsvSink>(opt.relative_csv_path));
  if (!opt.depth_sigma_dir.empty())
    sinks.push_back(std::make_unique<DepthSigmaSink>(opt.depth_sigma_dir));
  if (!opt.graph_prefix.empty()) {
    auto g = std::make_unique<GraphSink>(opt.graph_prefix, opt.graph_edges, engine);
    *graph = g.get();
    sinks.push_back(std::move(g));
  }
  if (!opt.rawlog_path.empty())
    sinks.push_back(std::make_unique<PoseRawlogSink>(opt.rawlog_path, opt.rawlogLabel(), opt.emit));
  detail::VisualCli visual;
  visual.scene = opt.scene;
  visual.plots_dir = opt.plots_dir;
  detail::appendVisualSinks(sinks, visual);  // last: their commit renders (slowest)
  return sinks;
}

/// Stages 3 and 4 with their shared state: the summary, the outputs given up after a write
/// failure and the failure reports.
class Run {
 public:
  Run(const CovarianceAppOptions& opt, Sinks sinks, std::ostream& err)
      : opt_(opt),
        sinks_(std::move(sinks)),
        broken_(sinks_.size(), false),
        err_(err),
        selfcal_(opt.self_calibration) {}

  /// Stage 3: snapshots are independent: computed in parallel, handed to the sinks in order.
  void pipeline(const SnapshotInputs& inputs, const DbaOptions& engine) {
    CovarianceOptions covariance = opt_.covariance;
    for (const auto& sink : sinks_) covariance.depth_variances |= sink->needsDepthVariances();
    Progress progress(err_, inputs.knownCount(), !opt_.quiet);
    progress_ = &progress;
    SnapshotStream stream(inputs, /*defer_npz=*/true);  // .npz files load on the workers
    runSnapshotPipeline(
        stream, 2 * std::max<std::size_t>(1, currentThreadLimit()),
        [&](PipelineItem& item) { compute(item, engine, covariance); },
        [&](PipelineItem& item) { return consume(item); });
    progress.clear();
    progress_ = nullptr;
  }

  /// Stage 4: after a --fail-fast stop nothing is committed: the sinks are destroyed uncommitted
  /// and no output appears. Otherwise every output is committed, even when another one fails
  /// (under --fail-fast the first failed output stops the others).
  void commit(const GraphSink* graph) {
    if (opt_.policy == FailurePolicy::FailFast && sum_.failed() != 0) return;
    // A run that processed no snapshot commits nothing: the previous files stay untouched.
    if (sum_.processed == 0) {
      if (!opt_.quiet)
        err_ << "dba-covariance: no snapshot was processed: no output written, previous files "
                "untouched\n";
      return;
    }
    io::CommitGroup group;  // the outputs change together (docs/reference/reliability.md)
    for (std::size_t i = 0; i < sinks_.size(); ++i) {
      if (broken_[i]) {  // reported when it failed
        sum_.outputNotWritten();
        continue;
      }
      try {
        sinks_[i]->commit();
      } catch (const std::exception& e) {
        err_ << "dba-covariance: error: " << failureMessage(e) << '\n';
        sum_.outputNotWritten();
        if (opt_.policy == FailurePolicy::FailFast) break;
      }
    }
    try {
      selfcal_.commit();  // --edge-csv
    } catch (const std::exception& e) {
      err_ << "dba-covariance: error: " << failureMessage(e) << '\n';
      sum_.outputNotWritten();
    }
    try {
      group.publish();
    } catch (const std::exception& e) {
      err_ << "dba-covariance: error: " << failureMessage(e) << '\n';
      sum_.outputNotWritten();
    }
    if (graph && !graph->summary().empty() && !opt_.quiet)
      err_ << "dba-covariance: " << graph->summary() << '\n';
    if (graph && graph->uninformativePairs() && !opt_.quiet)
      err_ << "dba-covariance: note: " << graph->uninformativePairs()
           << " keyframe pairs got no graph edge: every snapshot's gauge fixed their relative "
              "pose\n";
  }

  /// The summary line and the exit status.
  int finish() {
    if (!opt_.quiet) {
      for (const std::string& w : selfcal_.warnings())
        err_ << "dba-covariance: warning: " << w << '\n';
      err_ << "dba-covariance: " << selfcal_.summaryLine() << '\n';
    }
    if (!opt_.quiet) {
      err_ << "dba-covariance: " << sum_.line();
      if (opt_.policy == FailurePolicy::FailFast && sum_.failed())
        err_ << "; --fail-fast: stopped at the first failure, no output written";
      err_ << '\n';
    }
    return sum_.failed() || sum_.outputsNotWritten() ? 1 : 0;
  }

 private:
  /// On a worker thread: the covariances, checked by every sink before any sink takes them.
  void compute(PipelineItem& item, const DbaOptions& engine, const CovarianceOptions& covariance) {
    Snapshot& s = item.input.snapshot;
    try {
      if (opt_.fps) deriveKeyframeTimes(s, *opt_.fps, opt_.start_time);
      for (const auto& sink : sinks_) sink->check(s);
      auto cov = selfcal_.covariance(s, engine, covariance);  // computeCovariance, either model
      for (const auto& sink : sinks_) sink->verify(s, *cov);
      item.cov = std::move(cov);
    } catch (const std::exception& e) {
      item.error = failureMessage(e);
      item.error_kind = classifyFailure(e, false);
    }
  }

  /// In input order: the results into every sink. Returns whether the run goes on.
  bool consume(PipelineItem& item) {
    ++sum_.read;
    if (!item.input.ok())
      return report(item.input.kind, item.input.source, item.input.error, item.input.error);
    const Snapshot& s = item.input.snapshot;
    progress_->step(s.source);
    if (!item.cov)
      return report(item.error_kind, s.source, s.name() + ": " + item.error, item.error);
    try {
      labels_.claim(s);  // a rawlog's label that an earlier snapshot holds
    } catch (const InputError& e) {
      return report(FailureKind::InvalidInput, s.source, e.what(), e.what());
    }
    // Results are verified, so add() fails only when an output cannot be written (disk full):
    // that output is given up (reported once, not committed) and the others go on.
    bool added = true;
    for (std::size_t i = 0; i < sinks_.size(); ++i) {
      if (broken_[i]) continue;
      try {
        sinks_[i]->add(s, *item.cov);
      } catch (const std::exception& e) {
        broken_[i] = true;
        added = false;
        if (!report(classifyFailure(e, true), s.source, s.name() + ": " + failureMessage(e),
                    failureMessage(e)))
          return false;
      }
    }
    if (added) ++sum_.processed;
    return true;
  }

  /// `what` is the whole message (it names the file/snapshot), `reason` the error alone. Returns
  /// whether the run goes on (false under --fail-fast).
  bool report(FailureKind kind, const std::string& source, const std::string& what,
              const std::string& reason) {
    if (progress_) progress_->clear();
    err_ << "dba-covariance: error: " << what << '\n';
    sum_.fail(kind, source, reason);
    return opt_.policy == FailurePolicy::KeepGoing;
  }

  const CovarianceAppOptions& opt_;
  Sinks sinks_;
  std::vector<bool> broken_;  ///< outputs given up after a write failure
  std::ostream& err_;
  Progress* progress_ = nullptr;
  RunSummary sum_;
  detail::SelfCalibrationRun selfcal_;  ///< --self-calibrate, --converge, --edge-csv
  SnapshotLabels labels_;               ///< of the snapshots processed so far
};

}  // namespace

bool CovarianceAppOptions::anyOutput() const {
  return !csv_path.empty() || !self_calibration.edge_csv.empty() || !relative_csv_path.empty() ||
         !depth_sigma_dir.empty() || !rawlog_path.empty() || !graph_prefix.empty() ||
         scene.enabled() || !plots_dir.empty();
}

int runCovariance(const CovarianceAppOptions& opt, std::ostream& err) {
  DbaOptions engine;
  try {
    engine = opt.engine.resolve();
    checkEngineEnvironment();  // DBACOV_KERNEL_ISA
    opt.scene.validate();
    if (!opt.anyOutput()) throw std::invalid_argument("no output requested");
    if (!opt.graph_prefix.empty() && engine.gauge.type == GaugeOptions::Type::Droid)
      throw std::invalid_argument(
          "--graph cannot take --gauge droid: DROID's t0 holds poses of one window, and the "
          "sequence graph joins every window into one problem that has no t0 (it is anchored at "
          "its two lowest keyframes); give --gauge two-pose or minimal with --graph, or run "
          "--gauge droid without --graph");
    detail::SelfCalibrationRun check(opt.self_calibration);
    if (opt.fps) checkFps(*opt.fps);
    detail::checkCovariancePaths(opt);
  } catch (const std::exception& e) {
    err << "dba-covariance: " << e.what() << '\n';
    return 2;
  }
  const ThreadLimit thread_limit(opt.threads);
  try {
    const SnapshotInputs inputs(opt.inputs);
    inputs.checkDistinctLabels();
    GraphSink* graph = nullptr;
    Run run(opt, makeSinks(opt, engine, &graph), err);
    run.pipeline(inputs, engine);
    run.commit(graph);
    return run.finish();
  } catch (const std::exception& e) {
    err << "dba-covariance: error: " << failureMessage(e) << '\n';
    return 1;
  }
}

int runCovarianceApp(int argc, const char* const* argv, std::ostream& out, std::ostream& err) {
  CovarianceAppOptions opt;
  if (const auto status = parse(argc, argv, out, err, opt)) return *status;
  return runCovariance(opt, err);
}

}  // namespace dbacov::app
