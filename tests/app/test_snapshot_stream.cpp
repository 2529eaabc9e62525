// SnapshotStream with deferred .npz loads (read later by loadPending, as the pipeline's workers
// do) yields exactly what the eager stream yields: the same snapshots with the same indices and
// sources, the same failures with the same messages, sources and kinds, in the same order.

#include <fstream>
#include <string>
#include <vector>

#include <gtest/gtest.h>

#include "dbacov/app/snapshot_inputs.h"
#include "dbacov/mrpt/bridge.h"
#include "fixtures.h"
#include "temp_dir.h"

namespace dbacov {
namespace {

std::vector<app::SnapshotItem> readAll(const app::SnapshotInputs& inputs, bool defer) {
  app::SnapshotStream stream(inputs, defer);
  std::vector<app::SnapshotItem> items;
  app::SnapshotItem item;
  while (stream.next(&item)) {
    if (defer) {
      app::loadPending(&item);
      EXPECT_TRUE(item.pending_npz.empty());
    } else {
      EXPECT_TRUE(item.pending_npz.empty()) << "an eager stream left " << item.pending_npz;
    }
    items.push_back(item);
    item = app::SnapshotItem();
  }
  return items;
}

TEST(SnapshotStream, DeferredLoadsYieldWhatTheEagerStreamYields) {
  testing::TempDir dir;
  testing::writeTinySnapshot(dir.file("a.npz"), 1, 10);
  std::ofstream(dir.file("b.npz")) << "not a zip archive";
  {
    const auto writer = mrpt_bridge::mrptBridge().createSnapshotRawlog(dir.file("c.rawlog"));
    writer->write(testing::tinySnapshot(2, 20, 6).snapshot, 1.0, "dba");
    writer->write(testing::tinySnapshot(3, 21, 6).snapshot, 2.0, "dba");
    writer->commit();
  }
  testing::writeTinySnapshot(dir.file("d.npz"), 4, 30);
  const app::SnapshotInputs inputs({dir.file("a.npz"), dir.file("b.npz"), dir.file("missing.npz"),
                                    dir.file("c.rawlog"), dir.file("d.npz")});

  const auto eager = readAll(inputs, false);
  const auto deferred = readAll(inputs, true);
  ASSERT_EQ(eager.size(), 6u);  // a, b (fails), missing (fails), two from c, d
  ASSERT_EQ(deferred.size(), eager.size());
  EXPECT_FALSE(eager[1].ok());
  EXPECT_FALSE(eager[2].ok());
  EXPECT_NE(eager[1].error.find("b.npz"), std::string::npos) << eager[1].error;
  EXPECT_NE(eager[2].error.find("missing.npz"), std::string::npos) << eager[2].error;
  for (std::size_t k = 0; k < eager.size(); ++k) {
    SCOPED_TRACE("item " + std::to_string(k));
    const app::SnapshotItem& e = eager[k];
    const app::SnapshotItem& d = deferred[k];
    ASSERT_EQ(e.ok(), d.ok());
    EXPECT_EQ(e.error, d.error);
    EXPECT_EQ(e.source, d.source);
    if (!e.ok()) {
      EXPECT_EQ(e.kind, d.kind);
      continue;
    }
    EXPECT_EQ(e.snapshot.index, static_cast<std::int64_t>(k));
    EXPECT_EQ(e.snapshot.index, d.snapshot.index);
    EXPECT_EQ(e.snapshot.source, d.snapshot.source);
    EXPECT_EQ(e.snapshot.id, d.snapshot.id);
    EXPECT_EQ(e.snapshot.poses_cw, d.snapshot.poses_cw);
    EXPECT_EQ(e.snapshot.target, d.snapshot.target);
    EXPECT_EQ(e.snapshot.ii, d.snapshot.ii);
    EXPECT_EQ(e.snapshot.jj, d.snapshot.jj);
    EXPECT_EQ(e.snapshot.weight, d.snapshot.weight);
    EXPECT_EQ(e.snapshot.disps, d.snapshot.disps);
  }
  EXPECT_EQ(*eager[0].snapshot.id, 10);
  EXPECT_EQ(*eager[5].snapshot.id, 30);
}

}  // namespace
}  // namespace dbacov
