// SnapshotStream with deferred .npz loads (read later by loadPending, as the pipeline's workers
// do) yields exactly what the eager stream yields: the same snapshots with the same indices and
// sources, the same failures with the same messages, sources and kinds, in the same order.

#include <filesystem>
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

/// Every item of the stream; a deferred one read with loadPending (*deferred counts them).
std::vector<app::SnapshotItem> readAll(const app::SnapshotInputs& inputs, bool defer,
                                       int* deferred = nullptr) {
  app::SnapshotStream stream(inputs, defer);
  std::vector<app::SnapshotItem> items;
  app::SnapshotItem item;
  while (stream.next(&item)) {
    if (defer) {
      if (!item.pending_npz.empty()) {
        EXPECT_EQ(item.snapshot.numKeyframes(), 0) << "a pending item holds no snapshot yet";
        if (deferred) ++*deferred;
      }
      app::loadPending(&item);
      EXPECT_TRUE(item.pending_npz.empty());
    } else {
      EXPECT_TRUE(item.pending_npz.empty()) << "an eager stream left " << item.pending_npz;
    }
    items.push_back(item);  // `item` is reused, as SnapshotInputs::forEach does
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
  testing::writeTinySnapshot(dir.file("gone.npz"), 5, 40);
  const app::SnapshotInputs inputs({dir.file("a.npz"), dir.file("b.npz"), dir.file("missing.npz"),
                                    dir.file("gone.npz"), dir.file("c.rawlog"), dir.file("d.npz")});
  // Listed, then removed before it is read: the load itself fails (missing.npz fails earlier, in
  // the listing).
  std::filesystem::remove(dir.file("gone.npz"));

  const auto eager = readAll(inputs, false);
  int pending = 0;
  const auto deferred = readAll(inputs, true, &pending);
  EXPECT_EQ(pending, 4) << "a, b, gone and d are read by loadPending";
  // a, b (fails), missing (fails), gone (fails), two from c, d
  ASSERT_EQ(eager.size(), 7u);
  ASSERT_EQ(deferred.size(), eager.size());
  EXPECT_FALSE(eager[1].ok());
  EXPECT_FALSE(eager[2].ok());
  EXPECT_NE(eager[1].error.find("b.npz"), std::string::npos) << eager[1].error;
  EXPECT_NE(eager[2].error.find("missing.npz"), std::string::npos) << eager[2].error;
  EXPECT_FALSE(eager[3].ok());
  EXPECT_NE(eager[3].error.find("gone.npz"), std::string::npos) << eager[3].error;
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
  EXPECT_EQ(*eager[6].snapshot.id, 30);
}

}  // namespace
}  // namespace dbacov
