#include "dbacov/app/simul_app.h"
#include "dbacov/app/run_summary.h"

#include <cstdio>
#include <filesystem>
#include <memory>
#include <optional>

#include <CLI/CLI.hpp>

#include "cli_common.h"
#include "dbacov/app/csv_format.h"
#include "dbacov/app/progress.h"
#include "dbacov/app/scenario_options.h"
#include "dbacov/core/threads.h"
#include "dbacov/io/atomic_file.h"
#include "dbacov/io/memory_budget.h"
#include "dbacov/io/snapshot_npz.h"
#include "dbacov/mrpt/bridge.h"
#include "dbacov/sim/scenario.h"
#include "dbacov/sim/scenario_json.h"
#include "path_checks.h"

namespace dbacov::app {
namespace {

constexpr const char* kFooter = R"(
Outputs (all written atomically):
  DIR/snapshot_NNNN.npz  one DROID snapshot per DBA (conventions §1 format: poses T_cw, disps, targets,
                         weights, tstamp = 3 k, timestamps_s = start + tstamp / fps, id = N);
                         not with --no-npz
  DIR/groundtruth.tum    every keyframe of the sequence: t tx ty tz qx qy qz qw, camera-to-world,
                         t in seconds, full precision
  DIR/scenario.json      the effective configuration (reproduces the run with --config)
  --rawlog FILE          the snapshots as a rawlog of dbacov::CObservationDbaSnapshot (as
                         droid2rawlog writes it; read it with dba-covariance -i FILE)
Model: a camera moves through a room (walls and boxes, depths by ray casting); edges link temporal
neighbours and keyframes whose views overlap (both directions). Confidences w per pixel and axis
come from the weight distribution; pixels that are hidden or leave the other view get w = 0.
Targets are the true projections plus noise of variance amplitude^2 / (weight_scale w): white, or
a Gaussian random field per edge and axis with the given correlation length (then the
independent-pixel covariances are over-confident).
State: the truth perturbed, then solved by Levenberg-Marquardt (depth Schur complement) to the
optimum of the snapshot's own measurements, with DROID's pixel filter (z_j d >= 0.25) and the gauge
held AT THE TRUTH (two-pose: the two lowest keyframes of ii stay at their true poses; minimal: the
first one and the true distance to the second). So the estimate lives in the true frame and scale,
and `dba-covariance --weight-scale X [--gauge G]` with the same X and gauge gives covariances that
are consistent for white noise (absolute NEES is meaningful).
Sliding window: snapshot s holds keyframes 0..s+W-1 and edges among the last W. Whole: one snapshot.
Every snapshot redraws its confidences and noise (--noise-persistence snapshot, the default), or an
edge's are drawn once and shared by every snapshot that holds it (--noise-persistence edge: DROID
predicts the same flow again for the same pair of images, so its overlapping windows share their
measurements). --run selects the noise draw (Monte Carlo runs of one scenario share the geometry
and confidences). Seeded and reproducible.
Exit status: 0 success, 1 when a snapshot or output failed (the others are still written), 2 on
bad usage.)";

}  // namespace

namespace {

/// Throws InputError, before the simulation, when a snapshot of `sc` would hold more arrays than a
/// reader accepts (io::memoryBudget): a whole trajectory of thousands of keyframes or the largest
/// grids.
void checkSnapshotSizes(const sim::Scenario& sc) {
  const sim::ScenarioConfig& c = sc.config();
  const std::uint64_t plane = static_cast<std::uint64_t>(c.camera.H) * c.camera.W * 4;
  const io::MemoryBudget budget = io::memoryBudget();
  for (int s = 0; s < sc.numSnapshots(); ++s) {
    const std::uint64_t edges = sc.edges(s).size();
    const std::uint64_t keyframes = c.mode == sim::SimulationMode::WholeTrajectory
                                        ? static_cast<std::uint64_t>(sc.numKeyframes())
                                        : static_cast<std::uint64_t>(s + c.window);
    const std::uint64_t bytes = edges * 4 * plane + keyframes * 2 * plane;
    if (bytes > budget.bytes)
      throw InputError("snapshot " + std::to_string(s) + " would hold " + io::sizeText(bytes) +
                       " of arrays (" + std::to_string(keyframes) + " keyframes, " +
                       std::to_string(edges) + " edges on a " + std::to_string(c.camera.H) + "x" +
                       std::to_string(c.camera.W) + " grid), more than the memory budget of " +
                       io::sizeText(budget.bytes) + " (" + budget.source +
                       "): ask for fewer keyframes, a smaller grid or --mode sliding-window");
  }
}

}  // namespace

int runSimulApp(int argc, const char* const* argv, std::ostream& out, std::ostream& err) {
  std::string out_dir, rawlog_path, label = "DBA_SNAPSHOT";
  std::uint64_t run = 0;
  bool no_npz = false, quiet = false;
  ScenarioOptions scenario;
  CLI::App cli{"simul-dba: simulated DROID-SLAM DBA snapshots with ground truth", "simul-dba"};
  cli.footer(kFooter);
  cli.add_option("-o,--out-dir", out_dir, "Output directory (created if missing)")->required();
  cli.add_option("--rawlog", rawlog_path,
                 "Also write the snapshots as a rawlog of CObservationDbaSnapshot");
  cli.add_option("--label", label, "sensorLabel of the rawlog's snapshot observations");
  cli.add_flag("--no-npz", no_npz, "Do not write the .npz snapshots (use with --rawlog)");
  cli.add_option("--run", run, "Noise draw (Monte Carlo run) of the scenario, default 0");
  cli.add_flag("-q,--quiet", quiet, "No progress display, warnings only");
  scenario.add(cli);
  sim::ScenarioConfig config;
  try {
    cli.parse(argc, argv);
    io::OutputPlan plan;  // no output onto the configuration or onto another output
    plan.input(scenario.config_path, "--config");
    plan.output(rawlog_path, "--rawlog");
    plan.output(out_dir + "/groundtruth.tum", "-o (groundtruth.tum)");
    plan.output(out_dir + "/scenario.json", "-o (scenario.json)");
    plan.check();
    checkEngineEnvironment();  // DBACOV_KERNEL_ISA
    config = scenario.resolve();
    if (no_npz && rawlog_path.empty())
      throw std::invalid_argument("--no-npz leaves no snapshot output: add --rawlog");
  } catch (...) {
    return detail::usageExitStatus(cli, "simul-dba", out, err);
  }

  int written = 0, failed = 0, not_converged = 0, max_iterations = 0;
  try {
    // A long solve (a whole trajectory of thousands of keyframes) shows its iterations.
    Progress* shown = nullptr;
    std::string current;
    config.solver.on_iteration = [&](const DbaSolverSummary& it) {
      char text[96];
      std::snprintf(text, sizeof text, ": DBA solve, iteration %d, cost %.4g", it.iterations,
                    it.final_cost);
      if (shown) shown->status(current + text);
    };
    const sim::Scenario sc(config);
    checkSnapshotSizes(sc);
    std::error_code ec;
    std::filesystem::create_directories(out_dir, ec);
    if (ec || !std::filesystem::is_directory(out_dir))
      throw InputError(out_dir + ": cannot create the output directory" +
                       (ec ? ": " + ec.message() : ""));
    std::unique_ptr<mrpt_bridge::SnapshotRawlogWriter> rawlog;
    if (!rawlog_path.empty()) rawlog = mrpt_bridge::mrptBridge().createSnapshotRawlog(rawlog_path);
    Progress progress(err, sc.numSnapshots(), !quiet);
    // --gauge-hold estimate: each snapshot is held where the last one that succeeded left it.
    std::optional<Snapshot> previous;
    for (int s = 0; s < sc.numSnapshots(); ++s) {
      char name[64];
      std::snprintf(name, sizeof name, "snapshot_%04d.npz", s);
      progress.step(name);
      current = name;
      shown = &progress;
      try {
        sim::SimulatedSnapshot sim = sc.simulate(s, run, previous ? &*previous : nullptr);
        max_iterations = std::max(max_iterations, sim.solver.iterations);
        if (config.solve && !sim.solver.converged()) {
          ++not_converged;
          progress.clear();
          err << "simul-dba: warning: snapshot " << s << ": the DBA solve did not converge ("
              << sim.solver.brief() << ")\n";
        }
        if (config.gauge_hold == sim::GaugeHold::Estimate) previous = sim.snapshot;
        if (!no_npz) io::saveSnapshotNpz(out_dir + "/" + name, sim.snapshot);
        if (rawlog) {
          const double time = keyframeTime(sim.snapshot, newestKeyframe(sim.snapshot));
          rawlog->write(std::move(sim.snapshot), time, label);
        }
        ++written;
      } catch (const std::exception& e) {
        progress.clear();
        err << "simul-dba: error: snapshot " << s << ": " << failureMessage(e) << '\n';
        ++failed;
      }
    }
    shown = nullptr;
    progress.clear();
    if (rawlog) rawlog->commit();
    io::writeFileAtomically(out_dir + "/groundtruth.tum", [&](std::ostream& os) {
      for (int k = 0; k < sc.numKeyframes(); ++k) {
        const auto tq = poseToTQ(sc.groundTruth()[k]);
        os << formatDouble(sc.keyframeTime(k));
        for (int i = 0; i < 7; ++i) os << ' ' << formatDouble(tq[i]);
        os << '\n';
      }
    });
    io::writeFileAtomically(out_dir + "/scenario.json",
                            [&](std::ostream& os) { os << sim::scenarioConfigToJson(config); });
  } catch (const std::exception& e) {
    err << "simul-dba: error: " << failureMessage(e) << '\n';
    return 1;
  }
  if (!quiet) {
    out << "simul-dba: wrote " << written << " snapshots";
    if (!no_npz) out << " (" << out_dir << "/snapshot_NNNN.npz)";
    if (!rawlog_path.empty()) out << ", rawlog " << rawlog_path;
    out << ", groundtruth.tum and scenario.json to " << out_dir;
    if (config.solve)
      out << "; DBA solves: " << (written - not_converged) << " converged, at most "
          << max_iterations << " iterations";
    out << '\n';
  }
  return failed ? 1 : 0;
}

}  // namespace dbacov::app
