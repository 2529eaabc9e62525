// Inputs that used to be read silently wrong or crash, each refused naming the file,
// line, node, edge or option, with no output written: pose graphs (node ids beyond 32 bits, text
// edges whose information MRPT would replace by the identity, non-symmetric information in a
// .graphbin, a single node, bad node times), .npz archives with two members of one name, and
// correlation lengths beyond the simulated grid.
#include <algorithm>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <regex>

#include <gtest/gtest.h>

#include "app_runner.h"
#include "bad_inputs.h"
#include "dbacov/app/covariance_app.h"
#include "dbacov/app/evaluate_app.h"
#include "dbacov/app/posegraph_app.h"
#include "dbacov/app/simul_app.h"
#include "dbacov/core/pose_graph.h"
#include "dbacov/io/snapshot_npz.h"
#include "dbacov/mrpt/pose_graph_io.h"
#include "fixtures.h"
#include "temp_dir.h"

namespace dbacov {
namespace refused_inputs {  // not anonymous: the suite is compiled as a unity build

using testing::AppResult;

AppResult posegraph(const std::vector<std::string>& args) {
  return testing::runApp(app::runPoseGraphApp, "dba-posegraph", args);
}

PoseGraph lineGraph() {
  PoseGraph g;
  for (int k = 0; k < 3; ++k) {
    Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
    T.translation() = Eigen::Vector3d(k, 0, 0);
    g.nodes[k] = T;
  }
  for (int k = 0; k + 1 < 3; ++k)
    g.edges.push_back({k, k + 1, g.nodes[k].inverse() * g.nodes[k + 1], Matrix6d::Identity()});
  return g;
}

TEST(RefusedInputs, TextGraphEdgesThatMrptWouldMisread) {
  testing::TempDir dir;
  mrpt_bridge::writeGraphText(dir.file("g.graph"), lineGraph(),
                              mrpt_bridge::GraphTextLayout::Mrpt258);
  const auto lines = testing::splitLines(testing::readFile(dir.file("g.graph")));
  // Line 5 is the first edge (3 vertices, FIX): "EDGE_SE3:QUAT 0 1 <7 pose> <21 information>".
  ASSERT_EQ(lines[4].rfind("EDGE_SE3:QUAT 0 1 ", 0), 0u);
  struct Case {
    std::string name;
    std::function<std::string(const std::string&)> edit;
    std::string error;
  };
  auto lastReplaced = [](const std::string& v) {
    return [v](const std::string& l) { return l.substr(0, l.rfind(' ') + 1) + v; };
  };
  const std::string edge = dir.file("bad.graph") + ":5: edge 0 -> 1: ";
  for (const Case& c : std::vector<Case>{
           {"nan", lastReplaced("nan"),
            edge + "information entry 21 is 'nan', expected a finite number"},
           {"inf", lastReplaced("inf"),
            edge + "information entry 21 is 'inf', expected a finite number"},
           {"word", lastReplaced("one"),
            edge + "information entry 21 is 'one', expected a finite number"},
           {"1e999", lastReplaced("1e999"),
            edge + "information entry 21 is '1e999', expected a finite number"},
           {"short", [](const std::string& l) { return l.substr(0, l.rfind(' ')); },
            edge + "expected 30 values after EDGE_SE3:QUAT (from, to, 7 pose values, 21 "
                   "information entries), found 29"},
           {"no information",
            [](const std::string&) { return std::string("EDGE_SE3:QUAT 0 1 1 0 0 0 0 0 1"); },
            edge + "expected 30 values after EDGE_SE3:QUAT (from, to, 7 pose values, 21 "
                   "information entries), found 9"},
           {"33-bit node id",
            [](const std::string& l) {
              return std::regex_replace(l, std::regex("^EDGE_SE3:QUAT 0 1 "),
                                        "EDGE_SE3:QUAT 0 4294967297 ");
            },
            dir.file("bad.graph") + ":5: edge 0 -> 4294967297: node id 4294967297 is beyond the "
                                    "ids dbacov handles (0 to 2147483647): it would alias "
                                    "another node; renumber the graph's nodes"},
           {"self-edge",
            [](const std::string& l) {
              return std::regex_replace(l, std::regex("^EDGE_SE3:QUAT 0 1 "),
                                        "EDGE_SE3:QUAT 1 01 ");
            },
            dir.file("bad.graph") + ":5: edge 1 -> 01: joins node 1 to itself; an edge needs two "
                                    "nodes (MRPT's loader drops it silently)"},
           {"NUL byte", [](const std::string& l) { return l.substr(0, 20) + '\0' + l.substr(20); },
            dir.file("bad.graph") + ":5: a NUL byte at column 21: a text graph holds no NUL; "
                                    "MRPT's loader would drop the rest of the line"},
       }) {
    SCOPED_TRACE(c.name);
    std::ofstream out(dir.file("bad.graph"));
    for (std::size_t i = 0; i < lines.size(); ++i)
      out << (i == 4 ? c.edit(lines[i]) : lines[i]) << '\n';
    out.close();
    const AppResult r = posegraph({"-g", dir.file("bad.graph"), "--tum", dir.file("t.tum")});
    EXPECT_EQ(r.code, 1);
    EXPECT_EQ(r.err, "dba-posegraph: error: " + c.error + "\n");
    EXPECT_FALSE(std::filesystem::exists(dir.file("t.tum")));
  }
}

TEST(RefusedInputs, ExtraConstraintsThatWouldBeReadSilentlyWrong) {
  testing::TempDir dir;
  mrpt_bridge::writeGraphBinary(dir.file("g.graphbin"), lineGraph());
  std::ofstream(dir.file("g.nodes.csv")) << "node,tstamp,time_s\n0,0,1000\n1,1,1001\n2,2,1002\n";
  std::ofstream(dir.file("t.tum")) << "previous\n";
  const std::string prior = " 1 0 0 0 0 0 1 0.1 0.01";
  const std::string graph_before = testing::readFile(dir.file("g.graphbin"));
  for (const auto& [text, error] : std::vector<std::pair<std::string, std::string>>{
           {"absolute 4294967299" + prior,
            ":1: node id 4294967299 is beyond the ids dbacov handles (0 to 2147483647): it would "
            "alias another node"},
           {"relative 0 4294967298" + prior,
            ":1: node id 4294967298 is beyond the ids dbacov handles (0 to 2147483647): it would "
            "alias another node"},
           {"absolute 1" + prior + "\n# a comment\nabsolute 1 1.5 0 0 0 0 0 1 0.1 0.01",
            ":3: node 1 already has an absolute prior (line 1): give one prior per node (two "
            "would be merged silently into their information-weighted mean)"},
           {"absolute 1" + prior + "\nabsolute 01" + prior,
            ":2: node 01 already has an absolute prior (line 1): give one prior per node (two "
            "would be merged silently into their information-weighted mean)"},
           {"absolute 1" + prior + std::string("\0relative 0 2", 13) + prior,
            ":1: a NUL byte at column 34: a constraints file is text; the rest of the line would "
            "be lost"},
       }) {
    SCOPED_TRACE(text);
    std::ofstream(dir.file("extra.txt")) << text << '\n';
    const AppResult r = posegraph({"-g", dir.file("g.graphbin"), "--extra", dir.file("extra.txt"),
                                   "--tum", dir.file("t.tum")});
    EXPECT_EQ(r.code, 1);
    EXPECT_EQ(r.err, "dba-posegraph: error: " + dir.file("extra.txt") + error + "\n");
    EXPECT_EQ(testing::readFile(dir.file("t.tum")), "previous\n");  // the previous output stays
    EXPECT_EQ(testing::readFile(dir.file("g.graphbin")), graph_before);
  }
  // One prior per node, on two nodes, is taken.
  std::ofstream(dir.file("extra.txt")) << "absolute 0" << prior << "\nabsolute 2 2 0 0 0 0 0 1 "
                                       << "0.1 0.01\n";
  const AppResult r = posegraph({"-g", dir.file("g.graphbin"), "--extra", dir.file("extra.txt"),
                                 "--tum", dir.file("t.tum"), "-q"});
  EXPECT_EQ(r.code, 0) << r.err;
  EXPECT_EQ(testing::splitLines(testing::readFile(dir.file("t.tum"))).size(), 3u);
}

TEST(RefusedInputs, BinaryGraphsWithAliasingIdsAsymmetricInformationOrOneNode) {
  testing::TempDir dir;
  struct Case {
    std::string name;
    std::function<void(PoseGraph&)> edit;
    std::string error;
  };
  for (const Case& c : std::vector<Case>{
           {"single node",
            [](PoseGraph& g) {
              g.nodes.erase(1);
              g.nodes.erase(2);
              g.edges.clear();
            },
            "the graph has 1 node(s) and 0 edge(s): nothing to optimize; give a graph with at "
            "least two nodes joined by an edge (e.g. dba-covariance --graph over two or more "
            "keyframes)"},
       }) {
    SCOPED_TRACE(c.name);
    PoseGraph g = lineGraph();
    c.edit(g);
    mrpt_bridge::writeGraphBinary(dir.file("g.graphbin"), g);
    const AppResult r = posegraph({"-g", dir.file("g.graphbin"), "--tum", dir.file("t.tum")});
    EXPECT_EQ(r.code, 1);
    EXPECT_EQ(r.err, "dba-posegraph: error: " + dir.file("g.graphbin") + ": " + c.error + "\n");
    EXPECT_FALSE(std::filesystem::exists(dir.file("t.tum")));
  }
  // A node id beyond 32 bits in MRPT's network (its ids are 64-bit).
  auto net = mrpt_bridge::toNetwork(lineGraph());
  net.nodes[(1ull << 32) + 3] = net.nodes[2];
  EXPECT_THROW(
      {
        try {
          mrpt_bridge::fromNetwork(net, "g.graphbin");
        } catch (const InputError& e) {
          EXPECT_STREQ(e.what(),
                       "g.graphbin: node id 4294967299 is beyond the ids dbacov handles (0 to "
                       "2147483647): it would alias another node; renumber the graph's nodes");
          throw;
        }
      },
      InputError);
}

TEST(RefusedInputs, NodeTimesThatAreNotTimes) {
  testing::TempDir dir;
  mrpt_bridge::writeGraphBinary(dir.file("g.graphbin"), lineGraph());
  for (const auto& [row, error] : std::vector<std::pair<std::string, std::string>>{
           {"1,3,-1", ":3: node 1 has the time -1 s, which MRPT cannot represent"},
           {"1,3,nan", ":3: node 1 has the time nan s, which MRPT cannot represent"},
           {"1,3,0",
            ":3: node 1 has the time 0 s, which MRPT reads as \"no time\" (INVALID_TIMESTAMP): "
            "expected 0 < t <= 1e10 s since 1970; write the graph with dba-covariance "
            "--start-time T (T > 0) or give times > 0"},
           {"1,nan,5", ":3: node 1: tstamp is not a finite number"}}) {
    SCOPED_TRACE(row);
    std::ofstream(dir.file("g.nodes.csv")) << "node,tstamp,time_s\n0,0,1000\n"
                                           << row << "\n2,6,1002\n";
    const AppResult r = posegraph({"-g", dir.file("g.graphbin"), "--tum", dir.file("t.tum")});
    EXPECT_EQ(r.code, 1);
    EXPECT_EQ(r.err.rfind("dba-posegraph: error: " + dir.file("g.nodes.csv") + error, 0), 0u)
        << r.err;
    EXPECT_FALSE(std::filesystem::exists(dir.file("t.tum")));
  }
}

TEST(RefusedInputs, NpzWithTwoMembersOfOneName) {
  testing::TempDir dir;
  const auto arrays = testing::snapshotArrays(testing::tinySnapshot(1, 1).snapshot);
  auto members = testing::npyMembers(arrays);
  members.push_back(members[7]);  // a second "tstamp.npy"
  ASSERT_EQ(members[7].name, "tstamp.npy");
  testing::writeBytes(dir.file("dup.npz"), testing::storedZip(members));
  try {
    io::loadSnapshotNpz(dir.file("dup.npz"), 0);
    ADD_FAILURE() << "accepted";
  } catch (const InputError& e) {
    EXPECT_EQ(std::string(e.what()),
              dir.file("dup.npz") +
                  ": the archive holds two members named 'tstamp.npy' (NumPy "
                  "would read the last, others the first): rewrite the file "
                  "with each key once");
  }
}

TEST(RefusedInputs, CorrelationLengthBeyondTheGrid) {
  testing::TempDir dir;
  std::ofstream(dir.file("c.json"))
      << R"({"camera": {"width": 16, "height": 12}, "noise": {"model": "correlated", "correlation_length_px": 1e9}})";
  const std::string message =
      "scenario: noise: correlation length 1e+09 px (--correlation-length, "
      "noise.correlation_length_px) exceeds the grid (16x12 px): expected at most 16 px\nRun "
      "with --help for usage.\n";
  for (const auto& [app, name, args] :
       std::vector<std::tuple<testing::AppMain, std::string, std::vector<std::string>>>{
           {app::runSimulApp,
            "simul-dba",
            {"-o", dir.file("out"), "--width", "16", "--height", "12", "--noise", "correlated",
             "--correlation-length", "1e9"}},
           {app::runSimulApp, "simul-dba", {"-o", dir.file("out"), "--config", dir.file("c.json")}},
           {app::runEvaluateApp,
            "dba-evaluate",
            {"--monte-carlo", "2", "--config", dir.file("c.json")}},
       }) {
    SCOPED_TRACE(args.back());
    const AppResult r = testing::runApp(app, name, args);
    EXPECT_EQ(r.code, 2);
    EXPECT_EQ(r.err, name + ": " + message);
    EXPECT_FALSE(std::filesystem::exists(dir.file("out")));
  }
}

TEST(RefusedInputs, EvaluationInputsThatWouldBeScoredWrong) {
  testing::TempDir dir;
  testing::writeTinySnapshot(dir.file("v.npz"), 1, 1);
  ASSERT_EQ(testing::runApp(
                app::runCovarianceApp, "dba-covariance",
                {"-i", dir.file("v.npz"), "--csv", dir.file("k.csv"), "-q", "--weight-scale", "4"})
                .code,
            0);
  const auto lines = testing::splitLines(testing::readFile(dir.file("k.csv")));
  const auto header = testing::splitCsv(lines[0]);
  const std::size_t cov33 = std::find(header.begin(), header.end(), "cov_33") - header.begin(),
                    cov01 = std::find(header.begin(), header.end(), "cov_01") - header.begin();
  auto withValue = [&](std::size_t column, const std::string& v) {
    std::ofstream out(dir.file("bad.csv"));
    for (std::size_t i = 0; i < lines.size(); ++i) {
      auto f = testing::splitCsv(lines[i]);
      if (i == 2) f[column] = v;
      for (std::size_t j = 0; j < f.size(); ++j) out << (j ? "," : "") << f[j];
      out << '\n';
    }
  };
  std::ofstream(dir.file("gt.tum")) << "1000 0 0 0 0 0 0 1\n1001 0 0 0 0 0 0 1\n";
  auto evaluate = [&](const std::string& csv, const std::string& gt) {
    return testing::runApp(app::runEvaluateApp, "dba-evaluate",
                           {"--csv", csv, "--gt", gt, "--fps", "20", "--start-time", "1000"});
  };
  withValue(cov33, "-0.0001");
  AppResult r = evaluate(dir.file("bad.csv"), dir.file("gt.tum"));
  EXPECT_EQ(r.code, 1);
  EXPECT_NE(r.err.find(dir.file("bad.csv") + ":3: cov_33 = -0.0001 is a negative variance: "
                                             "expected a positive semidefinite covariance"),
            std::string::npos)
      << r.err;
  withValue(cov01, "1e300");
  r = evaluate(dir.file("bad.csv"), dir.file("gt.tum"));
  EXPECT_EQ(r.code, 1);
  EXPECT_NE(r.err.find(dir.file("bad.csv") + ":3: cov_01 = 1.0000000000000001e+300 is beyond any "
                                             "pose covariance (|entry| <= 1e100)"),
            std::string::npos)
      << r.err;
  // An infinite quaternion entry passed the norm check and became a NaN rotation; an infinite
  // image time was accepted (found by fuzz_ground_truth).
  std::ofstream(dir.file("inf.tum")) << "1000 0 0 0 inf 0 0 1\n1001 0 0 0 0 0 0 1\n";
  r = evaluate(dir.file("k.csv"), dir.file("inf.tum"));
  EXPECT_EQ(r.code, 1);
  EXPECT_NE(r.err.find(dir.file("inf.tum") +
                       ":1: column 'field 5': expected a finite number, found 'inf'"),
            std::string::npos)
      << r.err;
  std::ofstream(dir.file("times.txt")) << "-inf\n1000\n";
  r = testing::runApp(app::runEvaluateApp, "dba-evaluate",
                      {"--csv", dir.file("k.csv"), "--gt", dir.file("gt.tum"), "--image-times",
                       dir.file("times.txt")});
  EXPECT_EQ(r.code, 1);
  EXPECT_NE(r.err.find(dir.file("times.txt") +
                       ":1: column 'time': expected a finite number, found '-inf'"),
            std::string::npos)
      << r.err;
  std::ofstream(dir.file("dup.tum")) << "1000 0 0 0 0 0 0 1\n1000 1 0 0 0 0 0 1\n";
  r = evaluate(dir.file("k.csv"), dir.file("dup.tum"));
  EXPECT_EQ(r.code, 1);
  EXPECT_NE(r.err.find(dir.file("dup.tum") + ": two different poses at time 1000 s: expected one "
                                             "ground-truth pose per timestamp"),
            std::string::npos)
      << r.err;
}

}  // namespace refused_inputs
}  // namespace dbacov
