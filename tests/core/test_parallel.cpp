// Threads change the speed, never the result: sources are merged in order, snapshots are written
// in order.
#include <gtest/gtest.h>

#include "dbacov/core/covariance.h"
#include "dbacov/core/linearization.h"
#include "dbacov/core/parallel.h"
#include "dbacov/sim/synthetic_snapshot.h"
#include "fixtures.h"

namespace dbacov {
namespace {

TEST(Parallel, LinearizationIsBitIdenticalForAnyThreadCount) {
  sim::SyntheticSnapshotConfig c = testing::gridConfig(5, 9, 12, 16);
  c.covisibility.edge_radius = 3;
  const auto syn = sim::generateSyntheticSnapshot(c);
  DbaOptions o;
  o.weight_scale = 4;
  DbaNormalEquations one, two;
  {
    const ThreadLimit limit(1);
    EXPECT_EQ(currentThreadLimit(), 1u);
    one = linearizeDba(syn.snapshot, o, true);
  }
  {
    const ThreadLimit limit(2);
    two = linearizeDba(syn.snapshot, o, true);
  }
  EXPECT_EQ(one.S.toDense(), two.S.toDense());
  EXPECT_EQ(one.Hpp.toDense(), two.Hpp.toDense());
  EXPECT_EQ(one.g_S, two.g_S);
  ASSERT_EQ(one.depths.size(), two.depths.size());
  for (std::size_t i = 0; i < one.depths.size(); ++i) EXPECT_EQ(one.depths[i].B, two.depths[i].B);
  EXPECT_GT(one.S.toDense().norm(), 0);
}

TEST(Parallel, ExceptionsPropagate) {
  EXPECT_THROW(parallelFor(8,
                           [](std::size_t i) {
                             if (i == 5) throw std::runtime_error("boom");
                           }),
               std::runtime_error);
}

}  // namespace
}  // namespace dbacov
