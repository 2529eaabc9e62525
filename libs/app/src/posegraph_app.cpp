#include "dbacov/app/posegraph_app.h"
#include "dbacov/app/run_summary.h"

#include <filesystem>
#include <fstream>
#include <sstream>

#include <CLI/CLI.hpp>

#include "cli_common.h"
#include "dbacov/app/csv_format.h"
#include "dbacov/app/extra_constraints.h"
#include "dbacov/io/atomic_file.h"
#include "dbacov/mrpt/bridge.h"
#include "engine_cli.h"
#include "graph_input_checks.h"
#include "path_checks.h"

namespace dbacov::app {
namespace {
namespace fs = std::filesystem;

/// Loads the graph and checks it: at least one node, finite node poses, edges between nodes the
/// graph has, finite measurements, information matrices symmetric positive definite. MRPT's
/// optimizer would otherwise stop with an exception (or silently use NaN) deep inside.
PoseGraph loadGraph(const std::string& path) {
  const std::string ext = fs::path(path).extension().string();
  PoseGraph g;
  if (ext == ".graphbin")
    g = mrpt_bridge::mrptBridge().readGraph(path, false);
  else if (ext == ".graph")
    g = mrpt_bridge::mrptBridge().readGraph(path, true);
  else
    throw std::invalid_argument(
        path +
        ": expected a .graphbin (exact) or .graph (MRPT text) file; MRPT's loader would "
        "misread the rotation information of a .g2o: run dba-posegraph -g " +
        fs::path(path).replace_extension(".graphbin").string());
  if (g.nodes.empty()) throw InputError(path + ": the graph has no nodes");
  if (g.nodes.size() < 2 || g.edges.empty())
    throw InputError(path + ": the graph has " + std::to_string(g.nodes.size()) + " node(s) and " +
                     std::to_string(g.edges.size()) +
                     " edge(s): nothing to optimize; give a graph with at least two nodes joined "
                     "by an edge (e.g. dba-covariance --graph over two or more keyframes)");
  for (const auto& [id, T] : g.nodes)
    if (!T.matrix().allFinite())
      throw InputError(path + ": node " + std::to_string(id) + " has a non-finite pose");
  for (const PoseGraphEdge& e : g.edges) {
    const std::string edge =
        path + ": edge " + std::to_string(e.from) + " -> " + std::to_string(e.to);
    for (int node : {e.from, e.to})
      if (!g.nodes.count(node))
        throw InputError(edge + " names node " + std::to_string(node) +
                         ", which the graph does not have");
    if (!e.Z.matrix().allFinite()) throw InputError(edge + " has a non-finite relative pose");
    Matrix6d unused;
    const Matrix6d I = e.information;
    detail::checkSymmetricInformation(I, edge);
    if (!I.allFinite() || !informationOf(0.5 * (I + I.transpose()), &unused)) {
      if (ext == ".graph") {  // the usual cause on real data: say what to run instead
        const std::string bin = fs::path(path).replace_extension(".graphbin").string();
        throw InputError(path + ": MRPT's text loader cannot hold this graph (edge " +
                         std::to_string(e.from) + " -> " + std::to_string(e.to) +
                         ": it drops the rotation-rotation off-diagonal information, which "
                         "leaves it not positive definite); run dba-posegraph -g " +
                         bin + " (written next to it by dba-covariance --graph; exact)");
      }
      throw InputError(edge + " has an information matrix that is not positive definite");
    }
  }
  return g;
}

/// node,tstamp,time_s rows of PREFIX.nodes.csv into graph.node_time / node_tstamp.
void loadNodeTimes(const std::string& path, PoseGraph& g) {
  std::ifstream in(path);
  if (!in) throw InputError(path + ": cannot open the node times file");
  std::string line;
  if (!std::getline(in, line) || line != "node,tstamp,time_s")
    throw InputError(path + ":1: expected the header 'node,tstamp,time_s'");
  for (int n = 2; std::getline(in, line); ++n) {
    std::istringstream ls(line);
    std::string id, tstamp, time;
    std::getline(ls, id, ',');
    std::getline(ls, tstamp, ',');
    std::getline(ls, time, ',');
    try {
      const int node = std::stoi(id);
      g.node_tstamp[node] = std::stod(tstamp);
      if (!time.empty()) g.node_time[node] = std::stod(time);
      detail::checkNodeTimeRow(path, n, node, g.node_tstamp[node],
                               time.empty() ? std::nullopt : std::optional(g.node_time[node]));
    } catch (const InputError&) {
      throw;
    } catch (const std::exception&) {
      throw InputError(path + ":" + std::to_string(n) + ": expected 'node,tstamp,time_s', found '" +
                       line + "'");
    }
  }
}

double nodeTime(const PoseGraph& g, int id, const std::string& nodes_path) {
  const auto t = g.node_time.find(id);
  if (t == g.node_time.end())
    throw InputError("node " + std::to_string(id) + " has no time in " +
                     (nodes_path.empty() ? std::string("(no node times file)") : nodes_path) +
                     ": rawlog and TUM outputs need keyframe times (give --nodes "
                     "PREFIX.nodes.csv written by dba-covariance --graph with --fps F or "
                     "snapshots with 'timestamps_s')");
  return t->second;
}

}  // namespace

int runPoseGraphApp(int argc, const char* const* argv, std::ostream& out, std::ostream& err) {
  std::string graph_path, nodes_path, extra_path, rawlog_path, tum_path, label = "DBA_POSEGRAPH";
  std::size_t max_iterations = 100;
  bool identity = false, quiet = false, no_refine = false;
  CLI::App cli{"dba-posegraph: optimize a DROID-SLAM pose graph with MRPT and recover covariances",
               "dba-posegraph"};
  cli.footer(R"(
Loads GRAPH (.graphbin: MRPT binary CNetworkOfPoses3DInf, exact; .graph: MRPT text, whose 2.5.8
loader drops rotation-rotation off-diagonal information), adds the constraints of --extra, runs
mrpt::graphslam::optimize_graph_spa_levmarq, and writes the optimized poses: a rawlog of
CObservationRobotPose (CPose3DPDFGaussian: mean from the optimizer, covariance = marginal of the
graph's information at the solution, from dbacov's sparse solver, converted to MRPT's
[x y z yaw pitch roll]) and/or a TUM file (t tx ty tz qx qy qz qw, camera-to-world).
Without absolute priors the lowest node is held fixed (zero covariance); with them every node is
free and the priors anchor the graph. Edges joining the same two nodes (e.g. a loop closure beside
a DBA edge) are merged into one equivalent edge first: MRPT's optimizer mishandles parallel edges.
MRPT 2.5.8's levmarq accepts a step only when the *unweighted* squared error decreases and cannot
recover from a rejected step, so with real information matrices it often stops early; dbacov then
continues with its own Levenberg-Marquardt on the same weighted cost and residual convention until
the gradient vanishes (--no-refine keeps MRPT's result). The summary reports both stages.
Extra constraints (one per line, '#' comments; covariances over the tangent [rho; phi]):
  relative FROM TO tx ty tz qx qy qz qw  sigma_t sigma_r | 21 upper-triangular entries
  absolute ID      tx ty tz qx qy qz qw  sigma_t sigma_r | 21 upper-triangular entries
Node times come from PREFIX.nodes.csv beside the graph (written by dba-covariance --graph).
Exit status: 0 success, 1 input/output or numerical failure, 2 bad usage.)");
  cli.add_option("-g,--graph", graph_path, "Pose graph (.graphbin or .graph)")->required();
  cli.add_option("--nodes", nodes_path,
                 "Node times CSV (default: GRAPH with extension .nodes.csv, if present)");
  cli.add_option("--extra", extra_path, "Extra constraints file (loop closures, absolute priors)");
  cli.add_option("-o,--output", rawlog_path,
                 "Write the optimized poses as a rawlog of CObservationRobotPose");
  cli.add_option("--tum", tum_path, "Write the optimized trajectory as a TUM file");
  cli.add_option("--label", label, "sensorLabel of the rawlog observations");
  cli.add_option("--max-iterations", max_iterations, "Levenberg-Marquardt iterations")
      ->check(detail::integerIn(1, 100000));
  cli.add_flag("--identity-information", identity,
               "Replace every information matrix by the identity (what MRPT's graph-slam app does "
               "in 3D), for comparison");
  cli.add_flag("--no-refine", no_refine,
               "Keep MRPT's result as it is (no dbacov Levenberg-Marquardt refinement afterwards)");
  cli.add_flag("-q,--quiet", quiet, "No summary line");
  try {
    cli.parse(argc, argv);
    if (rawlog_path.empty() && tum_path.empty())
      throw CLI::ValidationError("no output requested: give -o OUT.rawlog and/or --tum OUT.tum");
    io::OutputPlan plan;  // no output onto an input or onto another output
    plan.input(graph_path, "-g");
    plan.input(nodes_path, "--nodes");
    plan.input(extra_path, "--extra");
    plan.input(fs::path(graph_path).replace_extension(".nodes.csv").string(), "-g (its nodes)");
    plan.output(rawlog_path, "-o");
    plan.output(tum_path, "--tum");
    plan.check();
  } catch (...) {
    return detail::usageExitStatus(cli, "dba-posegraph", out, err);
  }

  try {
    PoseGraph g;
    try {
      g = loadGraph(graph_path);
    } catch (const std::invalid_argument& e) {
      err << "dba-posegraph: " << e.what() << "\nRun with --help for usage.\n";
      return 2;
    }
    if (nodes_path.empty()) {
      const std::string guess = fs::path(graph_path).replace_extension(".nodes.csv").string();
      if (fs::exists(guess)) nodes_path = guess;
    }
    if (!nodes_path.empty()) loadNodeTimes(nodes_path, g);
    ExtraConstraints extra;
    if (!extra_path.empty()) extra = readExtraConstraints(extra_path, g.nodes);
    g.edges.insert(g.edges.end(), extra.relative.begin(), extra.relative.end());

    // Absolute priors become edges from a fixed anchor node at the world origin.
    const int anchor = g.nodes.rbegin()->first + 1;
    std::set<int> fixed{g.nodes.begin()->first};
    if (!extra.absolute.empty()) {
      g.nodes[anchor] = Eigen::Isometry3d::Identity();
      for (const AbsolutePrior& a : extra.absolute)
        g.edges.push_back({anchor, a.node, a.T_wc, a.information});
      fixed = {anchor};
    }
    if (identity)
      for (PoseGraphEdge& e : g.edges) e.information.setIdentity();
    const std::size_t fused = fuseParallelEdges(g);

    const double initial_cost = poseGraphCostAndGradient(g, fixed).first;
    mrpt_bridge::LevmarqResult info;
    try {
      info = mrpt_bridge::mrptBridge().optimizeLevmarq(g, *fixed.begin(), max_iterations);
    } catch (const NumericalError& e) {
      throw NumericalError(graph_path + ": " + e.what(), {});
    }
    const auto [mrpt_cost, mrpt_gradient] = poseGraphCostAndGradient(g, fixed);
    PoseGraphOptimizerSummary refine;
    if (!no_refine) {
      PoseGraphOptimizerOptions ro;
      ro.max_iterations = static_cast<int>(max_iterations);
      refine = optimizePoseGraph(g, fixed, ro);
    }

    const std::map<int, Matrix6d> cov = poseGraphCovariances(g, fixed);
    if (!extra.absolute.empty()) g.nodes.erase(anchor);

    if (!rawlog_path.empty()) {
      const auto w = mrpt_bridge::mrptBridge().createPoseRawlog(rawlog_path);
      for (const auto& [id, T] : g.nodes) {
        mrpt_bridge::PoseRecord r;
        r.T_wc = T;
        r.Sigma = cov.at(id);
        r.time = nodeTime(g, id, nodes_path);
        r.label = label;
        w->write(r);
      }
      w->commit();
    }
    if (!tum_path.empty()) {
      io::writeFileAtomically(tum_path, [&](std::ostream& os) {
        for (const auto& [id, T] : g.nodes) {
          os << formatDouble(nodeTime(g, id, nodes_path));
          const Eigen::Matrix<double, 7, 1> tq = poseToTQ(T);
          for (int i = 0; i < 7; ++i) os << ' ' << formatDouble(tq[i]);
          os << '\n';
        }
      });
    }
    if (!quiet)
      err << "dba-posegraph: " << g.nodes.size() << " nodes, " << g.edges.size() << " edges ("
          << extra.relative.size() << " extra, " << extra.absolute.size() << " absolute priors, "
          << fused << " merged into parallel edges); weighted cost " << initial_cost
          << " -> MRPT levmarq (" << info.iterations << " iterations) " << mrpt_cost
          << ", max gradient " << mrpt_gradient;
    if (!no_refine)
      err << " -> dbacov refinement (" << refine.iterations << " iterations) " << refine.final_cost
          << ", max gradient " << refine.final_gradient;
    err << '\n';
  } catch (const std::exception& e) {
    err << "dba-posegraph: error: " << failureMessage(e) << '\n';
    return 1;
  }
  return 0;
}

}  // namespace dbacov::app
