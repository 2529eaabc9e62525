#include "dbacov/app/covariance_app.h"

#include <fstream>
#include <memory>

#include <CLI/CLI.hpp>

#include "cli_common.h"
#include "dbacov/app/outputs.h"
#include "dbacov/app/pipeline.h"
#include "dbacov/app/progress.h"
#include "dbacov/app/run_summary.h"
#include "dbacov/app/snapshot_inputs.h"
#include "dbacov/core/covariance.h"
#include "dbacov/core/parallel.h"
#include "dbacov/mrpt/rawlog_io.h"
#include "visual_cli.h"

namespace dbacov::app {
namespace {

constexpr const char* kConventions = R"(
Conventions (README.md has the details):
  Input snapshots are DROID-SLAM DBA dumps (.npz): poses T_cw [tx ty tz qx qy qz qw], inverse
  depths, targets (x = column, y = row) and confidences per edge and pixel.
  Output poses are camera-to-world T_wc [tx ty tz qx qy qz qw]. Covariances are 6x6 over the
  tangent xi = [rho; phi] (translation first) of the right perturbation T_wc * Exp(xi), in the
  snapshot's (scale-free) length units and radians. A pixel factor's information is
  weight_scale * diag(w_x, w_y) px^-2.
  Presets: droid = weight scale 0.001, drop pixels with depth ratio z_j*d < 0.25, gauge two-pose
  hard-fixed; paper = weight scale 0.1, near 0.25 / far 2, gauge two-pose with sigmas 1 deg and
  0.05. Options given explicitly override the preset.
  Gauge keyframes are the two lowest-indexed keyframes in 'ii'. A hard-fixed keyframe has zero
  covariance and log10_det = -inf.
  --relative-csv pairs: every co-visible pair (from the lower to the higher keyframe index) and
  every pair of consecutive graph keyframes; pose T_wc_from^-1 * T_wc_to, same tangent.
  --depth-sigma files: DIR/<snapshot>_<keyframe>.npy, float32 HxW standard deviation of the
  inverse depth of each pixel of each source keyframe; NaN where a pixel carries no information.
  -o rawlog: gz-compressed, observations-only; one CObservationRobotPose per emitted keyframe,
  pose = CPose3DPDFGaussian with mean T_wc and covariance over MRPT's [x y z yaw pitch roll]
  converted exactly (to first order) from the tangent one; timestamp = the keyframe's time
  ('timestamps_s', or tstamp / --fps). --emit final identifies keyframes by their tstamp and
  writes them in time order. Inputs may be rawlogs of DBA snapshots (droid2rawlog).
  --graph: the whole sequence as one DBA problem (each edge's final flows, each keyframe's final
  depths and pose; node id = keyframe number in tstamp order), re-solved, its depth-reduced pose
  information exported onto the co-visible and consecutive pairs (--graph-edges covisibility) or
  the chain of consecutive keyframes (chain), never exceeding the true information: the edges
  may be fused with independent loop closures and priors. --graph-edges
  snapshot-marginals-not-fusable keeps the old graph (inverse per-snapshot marginal relative
  covariances: the same pixels counted in many edges, over-confident when optimized). .graphbin keeps everything; .graph is laid out for MRPT 2.5.8's
  text loader (which drops rotation-rotation off-diagonal information); .g2o uses g2o's order
  and its quaternion-vector error (rotation information x4). dba-posegraph optimizes it.
  All outputs are written atomically (temporary file, then rename).)";
constexpr const char* kExitStatus = R"TXT(
Failures: a snapshot that cannot be read, is invalid, has no covariances (numerical) or whose
results cannot be written is reported with its file, snapshot, key, keyframe or edge. With
--keep-going (the default) the other snapshots are still processed and every output is written;
with --fail-fast the first failure stops the run and no output is written at all (previous files
stay as they were). The last line on standard error sums up: "N snapshots read, P processed,
F failed: K invalid input (files...), K numerical (file: reason), K output (...)", and
"; K outputs not written" when an output file could not be committed at the end.
Exit status: 0 success, 1 when any snapshot or output failed, 2 on bad usage.)TXT";

}  // namespace

DbaOptions CovarianceAppOptions::engineOptions() const {
  DbaOptions o = DbaOptions::preset(preset);
  if (weight_scale) o.weight_scale = *weight_scale;
  if (gauge) {
    if (*gauge == "two-pose")
      o.gauge.type = GaugeOptions::Type::TwoPose;
    else if (*gauge == "minimal")
      o.gauge.type = GaugeOptions::Type::Minimal;
    else
      throw std::invalid_argument("unknown gauge '" + *gauge + "', expected two-pose or minimal");
  }
  if (o.gauge.type == GaugeOptions::Type::Minimal) {
    if (gauge_sigma_rot || gauge_sigma_trans)
      throw std::invalid_argument(
          "--gauge-sigma-rot/--gauge-sigma-trans apply to --gauge two-pose only");
    o.gauge.sigma_rot = o.gauge.sigma_trans = 0;
  }
  if (gauge_sigma_rot) o.gauge.sigma_rot = *gauge_sigma_rot;
  if (gauge_sigma_trans) o.gauge.sigma_trans = *gauge_sigma_trans;
  if (near) o.near = *near;
  if (far) o.far = *far;
  if (min_depth_ratio) {
    if (*min_depth_ratio == 0)
      o.min_depth_ratio.reset();
    else
      o.min_depth_ratio = *min_depth_ratio;
  }
  o.validate();
  return o;
}

SolverOptions CovarianceAppOptions::solverOptions() const {
  SolverOptions so;
  so.kind = solver == "dense" ? SolverKind::Dense : SolverKind::Sparse;
  if (ordering == "amd") so.ordering = Ordering::Amd;
  if (ordering == "metis") so.ordering = Ordering::Metis;
  if (ordering == "nesdis") so.ordering = Ordering::Nesdis;
  if (ordering == "natural") so.ordering = Ordering::Natural;
  return so;
}

int runCovarianceApp(int argc, const char* const* argv, std::ostream& out, std::ostream& err) {
  CovarianceAppOptions opt;
  CLI::App cli{"dba-covariance: marginal pose covariances from DROID-SLAM DBA snapshots",
               "dba-covariance"};
  detail::VisualCli visual;  // pictures: --scene, --snapshot, --plots (visual_cli.h)
  cli.footer(std::string(kConventions) + detail::kVisualHelp + kExitStatus);
  cli.add_option("-i,--input", opt.inputs,
                 "Snapshot .npz file or directory of them (name order); repeatable")
      ->required();
  cli.add_option("--csv", opt.csv_path,
                 "Write one row per (snapshot, graph keyframe): pose, criteria, covariance");
  cli.add_option(
      "-o,--output", opt.rawlog_path,
      "Write a rawlog of CObservationRobotPose (CPose3DPDFGaussian) per emitted keyframe");
  cli.add_option("--emit", opt.emit,
                 "Keyframes in the rawlog: latest (newest of each snapshot), all, final (each "
                 "once, from its last snapshot)")
      ->check(CLI::IsMember({"latest", "all", "final"}));
  cli.add_option("--label", opt.label, "sensorLabel of the rawlog observations");
  cli.add_option("--fps", opt.fps,
                 "Keyframe times = tstamp / fps for snapshots without 'timestamps_s'")
      ->check(CLI::PositiveNumber);
  cli.add_option(
      "--graph", opt.graph_prefix,
      "Write the pose graph: PREFIX.graphbin, PREFIX.graph, PREFIX.g2o, PREFIX.nodes.csv");
  cli.add_option("--graph-edges", opt.graph_edges,
                 "covisibility (default) or chain: the whole-sequence information counted once, "
                 "exported conservatively (fusable); snapshot-marginals-not-fusable: the old "
                 "per-snapshot marginal edges (the same pixels counted many times)")
      ->check(CLI::IsMember({"chain", "covisibility", "snapshot-marginals-not-fusable"}));
  cli.add_option("--relative-csv", opt.relative_csv_path,
                 "Write one row per (snapshot, keyframe pair): relative pose and covariance");
  cli.add_option("--depth-sigma", opt.depth_sigma_dir,
                 "Write per-pixel inverse-depth sigma maps (.npy) into this directory");
  cli.add_option("--solver", opt.solver,
                 "sparse (CHOLMOD, default) or dense (reference, small graphs)")
      ->check(CLI::IsMember({"sparse", "dense"}));
  cli.add_option("--ordering", opt.ordering,
                 "Fill-reducing ordering of the sparse solver: auto, amd, metis, nesdis, natural")
      ->check(CLI::IsMember({"auto", "amd", "metis", "nesdis", "natural"}));
  cli.add_option("--preset", opt.preset, "Engine preset: droid (default) or paper")
      ->check(CLI::IsMember({"droid", "paper"}));
  cli.add_option("--weight-scale", opt.weight_scale,
                 "Information per unit confidence, px^-2 (droid 0.001, paper 0.1)");
  cli.add_option(
         "--gauge", opt.gauge,
         "two-pose (priors on the first two keyframes of ii) or minimal (first fixed + scale)")
      ->check(CLI::IsMember({"two-pose", "minimal"}));
  cli.add_option("--gauge-sigma-rot", opt.gauge_sigma_rot,
                 "two-pose prior sigma of rotation, rad (0 = hard fix)");
  cli.add_option("--gauge-sigma-trans", opt.gauge_sigma_trans,
                 "two-pose prior sigma of translation (0 = hard fix)");
  cli.add_option("--near", opt.near,
                 "Keep a pixel only if d < 1/near and its depth in frame j > near");
  cli.add_option("--far", opt.far, "Keep a pixel only if d > 1/far");
  cli.add_option("--min-depth-ratio", opt.min_depth_ratio,
                 "Drop a pixel when z_j*d is below this (droid 0.25; 0 = off)");
  cli.add_option(
         "--threads", opt.threads,
         "Threads for independent snapshots and for each snapshot's linearization (0 = all cores)")
      ->check(CLI::Range(0, 4096));
  cli.add_flag("-q,--quiet", opt.quiet, "No progress display and no summary line");
  bool fail_fast = false;
  detail::addFailurePolicyOptions(cli, fail_fast);
  detail::addVisualOptions(cli, visual);

  DbaOptions engine;
  try {
    cli.parse(argc, argv);
    engine = opt.engineOptions();
    detail::finishVisualOptions(visual);
    if (opt.csv_path.empty() && opt.relative_csv_path.empty() && opt.depth_sigma_dir.empty() &&
        opt.rawlog_path.empty() && opt.graph_prefix.empty() && !visual.any())
      throw std::invalid_argument(
          "no output requested: give -o, --csv, --relative-csv, "
          "--depth-sigma, --graph, --scene, --snapshot or --plots");
  } catch (...) {
    return detail::usageExitStatus(cli, "dba-covariance", out, err);
  }

  RunSummary sum;
  const FailurePolicy policy = fail_fast ? FailurePolicy::FailFast : FailurePolicy::KeepGoing;
  const ThreadLimit thread_limit(opt.threads);
  try {
    const SnapshotInputs inputs(opt.inputs);
    std::vector<std::unique_ptr<OutputSink>> sinks;
    if (!opt.csv_path.empty()) sinks.push_back(std::make_unique<KeyframeCsvSink>(opt.csv_path));
    if (!opt.relative_csv_path.empty())
      sinks.push_back(std::make_unique<RelativeCsvSink>(opt.relative_csv_path));
    if (!opt.depth_sigma_dir.empty())
      sinks.push_back(std::make_unique<DepthSigmaSink>(opt.depth_sigma_dir));
    GraphSink* graph = nullptr;
    if (!opt.graph_prefix.empty()) {
      auto g = std::make_unique<GraphSink>(opt.graph_prefix, opt.graph_edges, engine);
      graph = g.get();
      sinks.push_back(std::move(g));
    }
    if (!opt.rawlog_path.empty())
      sinks.push_back(
          std::make_unique<PoseRawlogSink>(opt.rawlog_path, opt.label, parseEmitMode(opt.emit)));
    detail::appendVisualSinks(sinks, visual);  // last: their commit renders (slowest)
    SolverOptions solver = opt.solverOptions();
    for (const auto& sink : sinks) solver.depth_variances |= sink->needsDepthVariances();
    std::vector<bool> broken(sinks.size(), false);  ///< outputs given up after a write failure

    Progress progress(err, inputs.knownCount(), !opt.quiet);
    // `what` is the whole message (it names the file/snapshot), `reason` the error alone.
    // Returns whether the run goes on (false under --fail-fast).
    auto report = [&](FailureKind kind, const std::string& source, const std::string& what,
                      const std::string& reason) {
      progress.clear();
      err << "dba-covariance: error: " << what << '\n';
      sum.fail(kind, source, reason);
      return policy == FailurePolicy::KeepGoing;
    };
    // Snapshots are independent: compute them in parallel, hand the results to the sinks in order.
    SnapshotStream stream(inputs);
    auto name = [](const Snapshot& s) {
      return s.source + " (snapshot " + std::to_string(s.label()) + ")";
    };
    {
      runSnapshotPipeline(
          stream, 2 * std::max<std::size_t>(1, currentThreadLimit()),
          [&](PipelineItem& item) {
            Snapshot& s = item.input.snapshot;
            try {
              if (opt.fps) deriveKeyframeTimes(s, *opt.fps);
              for (const auto& sink : sinks) sink->check(s);
              auto cov = std::make_unique<DbaCovariance>(s, engine, solver);
              for (const auto& sink : sinks) sink->verify(s, *cov);
              item.cov = std::move(cov);
            } catch (const std::exception& e) {
              item.error = e.what();
              item.error_kind = classifyFailure(e, false);
            }
          },
          [&](PipelineItem& item) {
            ++sum.read;
            if (!item.input.ok())
              return report(item.input.kind, item.input.source, item.input.error, item.input.error);
            const Snapshot& s = item.input.snapshot;
            progress.step(s.source);
            if (!item.cov)
              return report(item.error_kind, s.source, name(s) + ": " + item.error, item.error);
            // Results are verified, so add() fails only when an output cannot be written (disk
            // full): that output is given up (reported once, not committed) and the others go on.
            bool added = true;
            for (std::size_t i = 0; i < sinks.size(); ++i) {
              if (broken[i]) continue;
              try {
                sinks[i]->add(s, *item.cov);
              } catch (const std::exception& e) {
                broken[i] = true;
                added = false;
                if (!report(classifyFailure(e, true), s.source, name(s) + ": " + e.what(),
                            e.what()))
                  return false;
              }
            }
            if (added) ++sum.processed;
            return true;
          });
    }
    progress.clear();
    // After a --fail-fast stop nothing is committed: the sinks are destroyed uncommitted and no
    // output appears. Otherwise every output is committed, even when another one fails (under
    // --fail-fast the first failed output stops the others).
    if (policy == FailurePolicy::KeepGoing || sum.failed() == 0) {
      for (std::size_t i = 0; i < sinks.size(); ++i) {
        if (broken[i]) {  // reported when it failed
          sum.outputNotWritten();
          continue;
        }
        try {
          sinks[i]->commit();
        } catch (const std::exception& e) {
          err << "dba-covariance: error: " << e.what() << '\n';
          sum.outputNotWritten();
          if (policy == FailurePolicy::FailFast) break;
        }
      }
      if (graph && !graph->summary().empty() && !opt.quiet)
        err << "dba-covariance: " << graph->summary() << '\n';
      if (graph && graph->uninformativePairs() && !opt.quiet)
        err << "dba-covariance: note: " << graph->uninformativePairs()
            << " keyframe pairs got no graph edge: every snapshot's gauge fixed their relative "
               "pose\n";
    }
  } catch (const std::exception& e) {
    err << "dba-covariance: error: " << e.what() << '\n';
    return 1;
  }
  if (!opt.quiet) {
    err << "dba-covariance: " << sum.line();
    if (policy == FailurePolicy::FailFast && sum.failed())
      err << "; --fail-fast: stopped at the first failure, no output written";
    err << '\n';
  }
  return sum.failed() || sum.outputsNotWritten() ? 1 : 0;
}

}  // namespace dbacov::app
