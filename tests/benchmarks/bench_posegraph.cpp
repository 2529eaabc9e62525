// Cost of dba-posegraph on long chains with loop closures.
//   bench_posegraph [NODES...]   (default 10000 20000 50000 100000; the smoke test runs 600)
// For each size, writes PREFIX.graphbin and PREFIX.nodes.csv of a synthetic trajectory into a
// temporary directory: a chain of odometry edges (σ 1 cm, 0.2°) along a square loop walked over
// and over, whose initial poses are the noisy odometry integrated (drift), and a loop closure
// every 10 nodes to the node one lap earlier. Then runs dba-posegraph (the app class, in this
// process) and prints the wall time of the whole run; its own summary line shows the stages.
#include <algorithm>
#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <random>
#include <sstream>
#include <string>
#include <vector>

#include <unistd.h>

#include "dbacov/app/posegraph_app.h"
#include "dbacov/core/pose_graph.h"
#include "dbacov/core/se3.h"
#include "dbacov/mrpt/bridge.h"

using namespace dbacov;
using Clock = std::chrono::steady_clock;
namespace fs = std::filesystem;

namespace {

constexpr int kLap = 400;  // nodes per lap of the square loop
int closure_every = 10;    // a loop closure from every 10th node to one lap earlier

/// The true pose of node i: a square of side 10 m walked at 0.1 m per node.
Eigen::Isometry3d truePose(int i) {
  const int side = kLap / 4;
  const int k = i % kLap, edge = k / side;
  const double s = 10.0 * (k % side) / side;
  const double x[4] = {s, 10.0, 10.0 - s, 0.0}, y[4] = {0.0, s, 10.0, 10.0 - s};
  Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
  T.linear() = Eigen::AngleAxisd(edge * M_PI / 2, Eigen::Vector3d::UnitZ()).toRotationMatrix();
  T.translation() = Eigen::Vector3d(x[edge], y[edge], 0.05 * (i / kLap));
  return T;
}

PoseGraph makeGraph(int n, std::mt19937& rng) {
  std::normal_distribution<double> noise(0.0, 1.0);
  const double sigma_t = 0.01, sigma_r = 0.2 * M_PI / 180;
  Matrix6d info = Matrix6d::Zero();
  info.diagonal() << Eigen::Vector3d::Constant(1 / (sigma_t * sigma_t)),
      Eigen::Vector3d::Constant(1 / (sigma_r * sigma_r));
  auto measured = [&](int a, int b) {
    Vector6d xi;
    for (int k = 0; k < 6; ++k) xi[k] = noise(rng) * (k < 3 ? sigma_t : sigma_r);
    return truePose(a).inverse() * truePose(b) * expSE3(xi);
  };
  PoseGraph g;
  g.nodes[0] = truePose(0);
  for (int i = 1; i < n; ++i) {
    const Eigen::Isometry3d Z = measured(i - 1, i);
    g.nodes[i] = g.nodes[i - 1] * Z;  // the drifting odometry is the initial estimate
    g.edges.push_back({i - 1, i, Z, info});
  }
  for (int i = kLap; i < n; i += closure_every)
    g.edges.push_back({i - kLap, i, measured(i - kLap, i), info});
  for (int i = 0; i < n; ++i) g.node_time[i] = 1.0 + 0.1 * i;
  return g;
}

}  // namespace

int main(int argc, char** argv) {
  std::vector<int> sizes;
  for (int a = 1; a < argc; ++a) {
    if (std::string(argv[a]) == "--closure-every" && a + 1 < argc)
      closure_every = std::max(1, std::atoi(argv[++a]));
    else
      sizes.push_back(std::atoi(argv[a]));
  }
  if (sizes.empty()) sizes = {10000, 20000, 50000, 100000};
  const fs::path dir = fs::temp_directory_path() / ("bench_posegraph." + std::to_string(getpid()));
  fs::create_directories(dir);
  std::mt19937 rng(7);
  int status = 0;
  for (int n : sizes) {
    if (n < 2) {
      std::fprintf(stderr, "bench_posegraph: %d nodes: give at least 2\n", n);
      return 2;
    }
    const PoseGraph g = makeGraph(n, rng);
    const std::string prefix = (dir / ("chain" + std::to_string(n))).string();
    mrpt_bridge::mrptBridge().writeGraphFiles(prefix, g);
    {
      std::ofstream nodes(prefix + ".nodes.csv");
      nodes << "node,tstamp,time_s\n";
      for (const auto& [id, t] : g.node_time) nodes << id << ',' << id << ',' << t << '\n';
    }
    const std::string graph = prefix + ".graphbin", tum = prefix + ".tum";
    const char* args[] = {"dba-posegraph", "-g", graph.c_str(), "--tum", tum.c_str()};
    std::ostringstream out, err;
    const auto t0 = Clock::now();
    const int rc = dbacov::app::runPoseGraphApp(5, args, out, err);
    const double seconds = std::chrono::duration<double>(Clock::now() - t0).count();
    std::printf("%7d nodes, %7zu edges: %8.2f s (exit %d)\n  %s", n, g.edges.size(), seconds, rc,
                err.str().c_str());
    std::fflush(stdout);
    if (rc != 0) status = 1;
  }
  fs::remove_all(dir);
  return status;
}
