// dba-posegraph on graphs that cannot be optimized: each is refused with the file, node or edge
// and what was wrong (exit 1), before MRPT's optimizer sees it, and no output file appears.
// The graphs are written with MRPT's binary serialization (writeGraphBinary), so the values
// reach the app exactly as a damaged or hand-made .graphbin would carry them.
#include <cmath>
#include <filesystem>
#include <fstream>
#include <functional>
#include <limits>

#include <gtest/gtest.h>

#include "app_runner.h"
#include "dbacov/app/posegraph_app.h"
#include "dbacov/core/pose_graph.h"
#include "dbacov/mrpt/pose_graph_io.h"
#include "temp_dir.h"

namespace dbacov {
namespace bad_pose_graphs {  // not anonymous: the suite is compiled as a unity build

constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();

/// Four nodes 1 m apart along x, an edge between each consecutive pair and one 0 -> 2, each with
/// the exact relative pose and identity information: a graph the app optimizes (checked below).
PoseGraph goodGraph() {
  PoseGraph g;
  for (int k = 0; k < 4; ++k) {
    Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
    T.translation() = Eigen::Vector3d(k, 0, 0);
    g.nodes[k] = T;
  }
  for (const auto& [a, b] : std::vector<std::pair<int, int>>{{0, 1}, {0, 2}, {1, 2}, {2, 3}})
    g.edges.push_back({a, b, g.nodes[a].inverse() * g.nodes[b], Matrix6d::Identity()});
  return g;
}

struct BadGraph {
  std::string name;
  std::function<void(PoseGraph&)> edit;
  std::string error;  ///< after "<file>: "
};

std::vector<BadGraph> badGraphs() {
  return {
      {"no_nodes", [](PoseGraph& g) { g = PoseGraph{}; }, "the graph has no nodes"},
      {"nan_node", [](PoseGraph& g) { g.nodes[2].translation().y() = kNaN; },
       "node 2 has a non-finite pose"},
      {"edge_to_missing_node", [](PoseGraph& g) { g.edges[3].to = 7; },
       "edge 2 -> 7 names node 7, which the graph does not have"},
      {"nan_measurement", [](PoseGraph& g) { g.edges[1].Z.translation().z() = kNaN; },
       "edge 0 -> 2 has a non-finite relative pose"},
      {"inf_information", [](PoseGraph& g) { g.edges[0].information(3, 4) = INFINITY; },
       "edge 0 -> 1 has an information matrix that is not positive definite"},
      {"indefinite_information", [](PoseGraph& g) { g.edges[2].information(5, 5) = -1; },
       "edge 1 -> 2 has an information matrix that is not positive definite"},
      {"zero_information", [](PoseGraph& g) { g.edges[3].information.setZero(); },
       "edge 2 -> 3 has an information matrix that is not positive definite"},
  };
}

void PrintTo(const BadGraph& c, std::ostream* os) {
  *os << c.name;
}

testing::AppResult posegraph(const std::vector<std::string>& args) {
  return testing::runApp(app::runPoseGraphApp, "dba-posegraph", args);
}

TEST(BadPoseGraph, TheGoodGraphIsOptimized) {
  testing::TempDir dir;
  mrpt_bridge::writeGraphBinary(dir.file("g.graphbin"), goodGraph());
  std::ofstream(dir.file("g.nodes.csv"))
      << "node,tstamp,time_s\n0,0,1000\n1,1,1000.1\n2,2,1000.2\n3,3,1000.3\n";
  const testing::AppResult r =
      posegraph({"-g", dir.file("g.graphbin"), "-o", dir.file("o.rawlog"), "-q"});
  EXPECT_EQ(r.code, 0) << r.err;
  EXPECT_EQ(dir.entries(), (std::vector<std::string>{"g.graphbin", "g.nodes.csv", "o.rawlog"}));
}

class BadPoseGraphTest : public ::testing::TestWithParam<BadGraph> {};

TEST_P(BadPoseGraphTest, IsRefusedNamingNodeOrEdgeAndWritesNothing) {
  const BadGraph& c = GetParam();
  testing::TempDir dir;
  PoseGraph g = goodGraph();
  c.edit(g);
  mrpt_bridge::writeGraphBinary(dir.file("g.graphbin"), g);
  const testing::AppResult r = posegraph(
      {"-g", dir.file("g.graphbin"), "-o", dir.file("o.rawlog"), "--tum", dir.file("o.tum")});
  EXPECT_EQ(r.code, 1);
  EXPECT_EQ(r.err, "dba-posegraph: error: " + dir.file("g.graphbin") + ": " + c.error + "\n");
  EXPECT_EQ(dir.entries(), (std::vector<std::string>{"g.graphbin"}));
}

INSTANTIATE_TEST_SUITE_P(Corpus, BadPoseGraphTest, ::testing::ValuesIn(badGraphs()),
                         [](const auto& p) { return p.param.name; });

TEST(BadPoseGraph, DamagedFilesAreExplained) {
  testing::TempDir dir;
  mrpt_bridge::writeGraphBinary(dir.file("g.graphbin"), goodGraph());
  const std::string bytes = testing::readFile(dir.file("g.graphbin"));
  std::ofstream(dir.file("cut.graphbin"), std::ios::binary) << bytes.substr(0, bytes.size() / 2);
  std::ofstream(dir.file("text.graphbin")) << "VERTEX_SE3:QUAT 0 0 0 0 0 0 0 1\n";
  for (const auto& [file, error] : std::vector<std::pair<std::string, std::string>>{
           {"cut.graphbin",
            "not a binary CNetworkOfPoses3DInf ((EOF?) Cannot read requested "
            "number of bytes from stream)"},
           {"missing.graphbin", "cannot open for reading"}}) {
    SCOPED_TRACE(file);
    const testing::AppResult r = posegraph({"-g", dir.file(file), "-o", dir.file("o.rawlog")});
    EXPECT_EQ(r.code, 1);
    EXPECT_EQ(r.err, "dba-posegraph: error: " + dir.file(file) + ": " + error + "\n");
  }
  const testing::AppResult r =
      posegraph({"-g", dir.file("text.graphbin"), "-o", dir.file("o.rawlog")});
  EXPECT_EQ(r.code, 1);
  EXPECT_EQ(r.err.rfind("dba-posegraph: error: " + dir.file("text.graphbin") +
                            ": not a binary CNetworkOfPoses3DInf (",
                        0),
            0u)
      << r.err;
  EXPECT_FALSE(std::filesystem::exists(dir.file("o.rawlog")));
}

}  // namespace bad_pose_graphs
}  // namespace dbacov
