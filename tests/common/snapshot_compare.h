// Bit-for-bit comparison of two snapshots (every array and scalar of SPEC §1), for round trips.
#pragma once

#include <gtest/gtest.h>

#include "dbacov/core/snapshot.h"

namespace dbacov::testing {

inline void expectSameSnapshot(const Snapshot& a, const Snapshot& b) {
  EXPECT_EQ(a.H, b.H);
  EXPECT_EQ(a.W, b.W);
  EXPECT_TRUE(a.poses_cw == b.poses_cw);
  EXPECT_EQ(a.disps, b.disps);
  EXPECT_TRUE(a.intrinsics == b.intrinsics);
  EXPECT_EQ(a.ii, b.ii);
  EXPECT_EQ(a.jj, b.jj);
  EXPECT_EQ(a.target, b.target);
  EXPECT_EQ(a.weight, b.weight);
  EXPECT_EQ(a.tstamp, b.tstamp);
  EXPECT_EQ(a.timestamps_s, b.timestamps_s);
  EXPECT_EQ(a.id, b.id);
}

}  // namespace dbacov::testing
