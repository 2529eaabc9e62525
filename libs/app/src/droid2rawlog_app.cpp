#include "dbacov/app/droid2rawlog_app.h"

#include <iomanip>
#include <optional>

#include <CLI/CLI.hpp>

#include "cli_common.h"
#include "dbacov/app/run_summary.h"
#include "dbacov/app/snapshot_inputs.h"
#include "dbacov/core/keyframe_times.h"
#include "dbacov/core/reprojection.h"
#include "dbacov/mrpt/bridge.h"
#include "path_checks.h"

namespace dbacov::app {
namespace {

/// One line per snapshot: what it holds and whether its stored state fits its targets.
void printSummary(std::ostream& out, const Snapshot& s) {
  const std::vector<int> kf = s.graphKeyframes();
  out << s.source << ": snapshot " << s.label() << ", " << s.numKeyframes() << " keyframes ("
      << kf.size() << " in the graph: " << kf.front() << ".." << kf.back() << "), " << s.numEdges()
      << " edges, " << s.H << "x" << s.W << ", fx=" << s.intrinsics[0] << " fy=" << s.intrinsics[1]
      << " cx=" << s.intrinsics[2] << " cy=" << s.intrinsics[3];
  if (s.timestamps_s)
    out << ", t=" << std::fixed << std::setprecision(3) << (*s.timestamps_s)[kf.front()] << ".."
        << (*s.timestamps_s)[kf.back()] << " s" << std::defaultfloat;
  else
    out << ", no keyframe times";
  out << ", weighted median reprojection error "
      << weightedMedian(reprojectionErrors(s, DbaOptions::droid())) << " px\n";
}

}  // namespace

int runDroid2RawlogApp(int argc, const char* const* argv, std::ostream& out, std::ostream& err) {
  std::vector<std::string> inputs, info;
  std::string output, label = "DBA_SNAPSHOT";
  std::optional<double> fps;
  bool quiet = false;
  CLI::App cli{"droid2rawlog: DROID-SLAM DBA snapshots (.npz) to an MRPT rawlog", "droid2rawlog"};
  cli.footer(R"TXT(
Writes a gz-compressed, observations-only rawlog with one dbacov::CObservationDbaSnapshot per
snapshot (every array of the .npz, timestamp and sensorLabel). Inputs: .npz files or directories
of them (name order), or rawlogs of snapshots. The observation's timestamp is the time of the
snapshot's newest graph keyframe; keyframe times come from 'timestamps_s' when present, else from
tstamp / --fps (and are then stored in the rawlog). MRPT tools read the class with the plugin:
  rawlog-edit -p libdbacov_mrpt.so --info -i snapshots.rawlog
--info FILE... prints one line per snapshot instead of converting.
Failures: with --keep-going (the default) a snapshot that cannot be read or is invalid is
reported and the others are still converted and written; with --fail-fast the first failure stops
the run and the output rawlog is not written at all (a previous file stays as it was). The last
line on standard error sums up: "N snapshots read, P processed, F failed: K invalid input (...)".
Exit status: 0 success, 1 when any input failed, 2 on bad usage.)TXT");
  auto* in_opt = cli.add_option("-i,--input", inputs,
                                "Snapshot .npz, directory of them, or rawlog; repeatable");
  auto* out_opt = cli.add_option("-o,--output", output, "Output rawlog");
  auto* info_opt =
      cli.add_option("--info", info, "Summarize snapshot files or rawlogs instead of converting");
  double start_time = 0;
  cli.add_option("--start-time", start_time,
                 "With --fps: time of tstamp 0, s since 1970 (default 0; times must be > 0)");
  cli.add_option("--fps", fps,
                 "Camera frame rate: keyframe times = start + tstamp / fps for snapshots without "
                 "'timestamps_s' (needed then: the rawlog's timestamps are keyframe times; finite, "
                 "> 0)");
  cli.add_option("--label", label, "sensorLabel of the snapshot observations");
  cli.add_flag("-q,--quiet", quiet, "No summary line");
  bool fail_fast = false;
  detail::addFailurePolicyOptions(cli, fail_fast);
  in_opt->excludes(info_opt);
  out_opt->excludes(info_opt);
  try {
    cli.parse(argc, argv);
    if (info.empty() && (inputs.empty() || output.empty()))
      throw CLI::ValidationError("give -i INPUT... -o OUTPUT.rawlog, or --info FILE...");
    if (fps) checkFps(*fps);
    io::OutputPlan plan;  // no output onto an input
    detail::addInputs(plan, inputs, "-i", ".npz");
    plan.output(output, "-o");
    plan.check();
  } catch (...) {
    return detail::usageExitStatus(cli, "droid2rawlog", out, err);
  }

  RunSummary sum;
  auto report = [&](FailureKind kind, const std::string& source, const std::string& what) {
    err << "droid2rawlog: error: " << what << '\n';
    sum.fail(kind, source, what);
    return !fail_fast;  // whether the run goes on
  };
  auto on_error = [&](const SnapshotItem& item) {
    ++sum.read;
    return report(item.kind, item.source, item.error);
  };
  try {
    if (!info.empty()) {
      SnapshotInputs(info).forEach(
          [&](Snapshot& s) {
            ++sum.read;
            printSummary(out, s);
            ++sum.processed;
            return true;
          },
          on_error);
      if (!quiet) err << "droid2rawlog: " << sum.line() << '\n';
      return sum.failed() ? 1 : 0;
    }
    const SnapshotInputs in(inputs);
    const auto writer = mrpt_bridge::mrptBridge().createSnapshotRawlog(output);
    in.forEach(
        [&](Snapshot& s) {
          ++sum.read;
          double time = 0;
          try {
            if (fps) deriveKeyframeTimes(s, *fps, start_time);
            time = keyframeTime(s, newestKeyframe(s));
          } catch (const std::exception& e) {
            return report(classifyFailure(e, false), s.source, s.name() + ": " + failureMessage(e));
          }
          // A write error ends the run: the rawlog would be damaged.
          writer->write(std::move(s), time, label);
          ++sum.processed;
          return true;
        },
        on_error);
    // After a --fail-fast stop the writer is destroyed uncommitted: the output does not appear.
    // No snapshot converted: nothing is committed, a previous rawlog stays untouched.
    if (sum.processed > 0 && (!fail_fast || sum.failed() == 0)) writer->commit();
  } catch (const std::exception& e) {
    err << "droid2rawlog: error: " << failureMessage(e) << '\n';
    return 1;
  }
  if (!quiet) {
    err << "droid2rawlog: " << sum.line();
    if (fail_fast && sum.failed())
      err << "; --fail-fast: stopped at the first failure, " << output << " not written";
    else if (sum.processed == 0)
      err << "; nothing converted: " << output << " not written (a previous file stays)";
    else
      err << "; " << sum.processed << " written to " << output;
    err << '\n';
  }
  return sum.failed() ? 1 : 0;
}

}  // namespace dbacov::app
