// Keyframes that `poses` holds but no edge names (keyframe 0 of the shared DROID snapshot, and the
// first keyframes of a synthetic one) are not graph keyframes: never a gauge keyframe, and absent
// from every output (keyframe table, pair table, pose rawlog, pose graph, depth-sigma maps).
#include <filesystem>
#include <set>

#include <gtest/gtest.h>
#include <mrpt/obs/CObservationRobotPose.h>

#include "app_runner.h"
#include "dbacov/app/covariance_app.h"
#include "dbacov/core/covariance.h"
#include "dbacov/mrpt/pose_graph_io.h"
#include "dbacov/mrpt/rawlog_io.h"
#include "fixtures.h"
#include "temp_dir.h"

namespace dbacov {
namespace outside_graph {  // not anonymous: the suite is compiled as a unity build

const std::string kShared = std::string(DBACOV_SHARED_DATA_DIR) + "/droid_window_0055.npz";

/// Runs dba-covariance with every file output on `input`; returns the keyframes named by each.
struct Named {
  std::set<int> csv, pairs, rawlog_times, graph_nodes, sigma_maps;
};

Named runAllOutputs(const testing::TempDir& dir, const std::string& input,
                    const std::vector<std::string>& extra) {
  std::vector<std::string> args{"-i",
                                input,
                                "--csv",
                                dir.file("k.csv"),
                                "--relative-csv",
                                dir.file("r.csv"),
                                "-o",
                                dir.file("p.rawlog"),
                                "--emit",
                                "all",
                                "--graph",
                                dir.file("g"),
                                "--depth-sigma",
                                dir.file("sigma"),
                                "-q"};
  args.insert(args.end(), extra.begin(), extra.end());
  const testing::AppResult r = testing::runApp(app::runCovarianceApp, "dba-covariance", args);
  EXPECT_EQ(r.code, 0) << r.err;
  Named n;
  const auto rows = testing::splitLines(testing::readFile(dir.file("k.csv")));
  for (std::size_t i = 1; i < rows.size(); ++i)
    n.csv.insert(std::stoi(testing::splitCsv(rows[i])[1]));
  const auto pairs = testing::splitLines(testing::readFile(dir.file("r.csv")));
  for (std::size_t i = 1; i < pairs.size(); ++i)
    for (int c : {1, 2}) n.pairs.insert(std::stoi(testing::splitCsv(pairs[i])[c]));
  mrpt_bridge::RawlogReader reader(dir.file("p.rawlog"));
  while (auto obj = reader.next())
    n.rawlog_times.insert(static_cast<int>(std::lround(
        mrpt::Clock::toDouble(
            std::dynamic_pointer_cast<mrpt::obs::CObservationRobotPose>(obj)->timestamp) *
        1000)));
  for (const auto& [id, pose] : mrpt_bridge::readGraphBinary(dir.file("g.graphbin")).nodes)
    n.graph_nodes.insert(static_cast<int>(id));
  for (const auto& e : std::filesystem::directory_iterator(dir.file("sigma"))) {
    const std::string name = e.path().stem().string();
    n.sigma_maps.insert(std::stoi(name.substr(name.find('_') + 1)));
  }
  return n;
}

TEST(OutsideTheGraph, SyntheticKeyframesWithoutEdgesAppearNowhere) {
  testing::TempDir dir;
  sim::SyntheticSnapshotConfig c = testing::gridConfig(4, 7, 8, 10);
  c.first_keyframe = 2;  // keyframes 0 and 1 exist in `poses` but take part in no edge
  c.id = 9;
  auto syn = sim::generateSyntheticSnapshot(c);
  deriveKeyframeTimes(syn.snapshot, 1000.0);  // keyframe k at tstamp k·3 ms
  io::saveSnapshotNpz(dir.file("s.npz"), syn.snapshot);
  ASSERT_EQ(syn.snapshot.graphKeyframes(), (std::vector<int>{2, 3, 4, 5, 6}));
  DbaOptions o = DbaOptions::droid();
  o.weight_scale = 4;
  EXPECT_EQ(DbaCovariance(syn.snapshot, o).gaugeKeyframes(), (std::vector<int>{2, 3}));

  const Named n = runAllOutputs(dir, dir.file("s.npz"), {"--weight-scale", "4"});
  const std::set<int> graph{2, 3, 4, 5, 6};
  EXPECT_EQ(n.csv, graph);
  EXPECT_EQ(n.pairs, graph);
  EXPECT_EQ(n.rawlog_times, (std::set<int>{6, 9, 12, 15, 18}));  // ms: tstamp 3k / 1000 fps
  EXPECT_EQ(n.graph_nodes, graph);
  for (int k : n.sigma_maps) EXPECT_TRUE(graph.count(k)) << k;
  // The hard-fixed gauge keyframes are the two lowest graph keyframes: zero covariance.
  const auto rows = testing::splitLines(testing::readFile(dir.file("k.csv")));
  EXPECT_EQ(testing::splitCsv(rows[1])[1], "2");
  EXPECT_EQ(testing::splitCsv(rows[1])[10], "-inf");
  EXPECT_EQ(testing::splitCsv(rows[2])[10], "-inf");
  EXPECT_NE(testing::splitCsv(rows[3])[10], "-inf");
}

TEST(OutsideTheGraph, KeyframeZeroOfTheSharedDroidSnapshotAppearsNowhere) {
  if (!std::filesystem::exists(kShared)) GTEST_SKIP() << "missing " << kShared;
  const Snapshot s = io::loadSnapshotNpz(kShared, 0);
  ASSERT_EQ(s.numKeyframes(), 11);
  ASSERT_EQ(s.graphKeyframes().front(), 1);
  EXPECT_EQ(DbaCovariance(s, DbaOptions::droid()).gaugeKeyframes(), (std::vector<int>{1, 2}));
  testing::TempDir dir;
  const Named n = runAllOutputs(dir, kShared, {"--fps", "1000"});
  const std::set<int> graph{1, 2, 3, 4, 5, 6, 7, 8, 9, 10};
  EXPECT_EQ(n.csv, graph);
  EXPECT_EQ(n.pairs, graph);
  std::set<int> times;
  for (int k : graph) times.insert(static_cast<int>(s.tstamp[k]));  // tstamp / 1000 fps, in ms
  EXPECT_EQ(n.rawlog_times, times);
  EXPECT_EQ(n.graph_nodes, graph);
  EXPECT_FALSE(n.sigma_maps.empty());
  EXPECT_EQ(n.sigma_maps.count(0), 0u);
}

}  // namespace outside_graph
}  // namespace dbacov
