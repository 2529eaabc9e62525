// Bit-for-bit comparison of two snapshots (every array and scalar of conventions §1), for round
// trips.
#pragma once

#include <gtest/gtest.h>

#include "dbacov/core/snapshot.h"

namespace dbacov::testing {

/// `intrinsics_as_float32`: compare the intrinsics at float32 precision, for a snapshot that went
/// through a .npz file (conventions §1 stores them as float32) against one that did not.
inline void expectSameSnapshot(const Snapshot& a, const Snapshot& b,
                               bool intrinsics_as_float32 = false) {
  EXPECT_EQ(a.H, b.H);
  EXPECT_EQ(a.W, b.W);
  EXPECT_TRUE(a.poses_cw == b.poses_cw);
  EXPECT_EQ(a.disps, b.disps);
  if (intrinsics_as_float32)
    EXPECT_TRUE(a.intrinsics.cast<float>() == b.intrinsics.cast<float>());
  else
    EXPECT_TRUE(a.intrinsics == b.intrinsics);
  EXPECT_EQ(a.ii, b.ii);
  EXPECT_EQ(a.jj, b.jj);
  EXPECT_EQ(a.target, b.target);
  EXPECT_EQ(a.weight, b.weight);
  EXPECT_EQ(a.tstamp, b.tstamp);
  EXPECT_EQ(a.timestamps_s, b.timestamps_s);
  EXPECT_EQ(a.id, b.id);
  EXPECT_EQ(a.disps_sens, b.disps_sens);
  EXPECT_TRUE(a.stereo_rig == b.stereo_rig);
  EXPECT_EQ(a.t0, b.t0);
}

}  // namespace dbacov::testing
