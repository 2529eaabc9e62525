// Snapshot::validate's value scans (non-finite, negative weights), which test the bits of whole
// blocks of 256 values at a time: against a plain scalar search for the first offending value, at
// every position class (first block, block boundaries, the tail after the last whole block) and for
// every special value, including the ones the bit tests could get wrong (-0, denormals, -NaN).
#include <gtest/gtest.h>

#include <cmath>
#include <limits>
#include <sstream>
#include <string>

#include "dbacov/core/errors.h"
#include "fixtures.h"

namespace dbacov {
namespace {

std::string validationError(const Snapshot& s) {
  try {
    s.validate();
  } catch (const InputError& e) {
    return e.what();
  }
  return "";
}

/// The position of flat index i of an (E, 2, H, W) array, as validate() words it.
std::string edgePixel(const Snapshot& s, std::size_t i) {
  const std::size_t HW = static_cast<std::size_t>(s.H) * s.W, plane = i / HW, p = i % HW;
  std::ostringstream os;
  os << "edge " << plane / 2 << " channel " << plane % 2 << " pixel (x=" << p % s.W
     << ", y=" << p / s.W << ")";
  return os.str();
}

/// Positions around the block boundaries of the scans (blocks of 256) and in the tail.
std::vector<std::size_t> probePositions(std::size_t n) {
  std::vector<std::size_t> at = {0, 1, 255, 256, 257, 511, 512, n / 2, n - 257, n - 256, n - 1};
  const std::size_t tail = n - n % 256;  // the first value after the last whole block
  if (tail < n) at.push_back(tail);
  return at;
}

TEST(SnapshotChecks, FirstNonFiniteValueIsNamedWhereverItIs) {
  const Snapshot good = testing::tinySnapshot(3, 0).snapshot;
  ASSERT_EQ(validationError(good), "");
  const std::size_t n = good.target.size();
  ASSERT_GT(n, 1024u);
  ASSERT_NE(n % 256, 0u) << "the tail after the last block must be probed too";
  const float specials[] = {
      std::numeric_limits<float>::quiet_NaN(), -std::numeric_limits<float>::quiet_NaN(),
      std::numeric_limits<float>::infinity(), -std::numeric_limits<float>::infinity()};
  for (const std::size_t at : probePositions(n)) {
    for (const float bad : specials) {
      for (const char* key : {"target", "weight"}) {
        Snapshot s = good;
        float* v = std::string(key) == "target" ? s.target.data() : s.weight.data();
        v[at] = bad;
        v[n - 1] = std::numeric_limits<float>::infinity();  // a later one must not be named
        if (at == n - 1) v[n - 1] = bad;
        const std::string message = validationError(s);
        SCOPED_TRACE(std::string(key) + " at " + std::to_string(at) + " = " + std::to_string(bad));
        EXPECT_NE(
            message.find(std::string("key '") + key + "' is non-finite at " + edgePixel(s, at)),
            std::string::npos)
            << message;
      }
    }
  }
  // Large finite values are finite: the largest float, the smallest denormal.
  Snapshot s = good;
  s.target[300] = std::numeric_limits<float>::max();
  s.target[301] = -std::numeric_limits<float>::max();
  s.target[302] = std::numeric_limits<float>::denorm_min();
  EXPECT_EQ(validationError(s), "");
}

TEST(SnapshotChecks, NegativeWeightsAreFoundAndMinusZeroIsNotNegative) {
  const Snapshot good = testing::tinySnapshot(4, 0).snapshot;
  const std::size_t n = good.weight.size();
  for (const std::size_t at : probePositions(n)) {
    for (const float neg :
         {-1.0f, -std::numeric_limits<float>::denorm_min(), -std::numeric_limits<float>::max()}) {
      Snapshot s = good;
      s.weight[at] = neg;
      s.weight[n - 1] = -2.0f;  // a later one must not be named
      if (at == n - 1) s.weight[n - 1] = neg;
      const std::string message = validationError(s);
      SCOPED_TRACE("weight " + std::to_string(neg) + " at " + std::to_string(at));
      EXPECT_NE(message.find("key 'weight' is negative"), std::string::npos) << message;
      EXPECT_NE(message.find(") at " + edgePixel(s, at) + ","), std::string::npos) << message;
    }
  }
  // -0 is not negative; weights that are all ±0 carry no information; one positive denormal does.
  Snapshot s = good;
  for (float& w : s.weight) w = -0.0f;
  EXPECT_NE(validationError(s).find("key 'weight' is zero at every pixel"), std::string::npos);
  s.weight[n / 2 + 3] = std::numeric_limits<float>::denorm_min();
  EXPECT_EQ(validationError(s), "");
  s.weight[n / 2 + 3] = 0.0f;
  s.weight[n - 1] = 1.0f;  // in the tail after the last whole block
  EXPECT_EQ(validationError(s), "");
}

TEST(SnapshotChecks, NegativeSensorDepthsAreFoundAndZeroMeansNoReading) {
  Snapshot good = testing::tinySnapshot(6, 0).snapshot;
  good.disps_sens = std::vector<float>(good.disps.data(), good.disps.data() + good.disps.size());
  ASSERT_EQ(validationError(good), "");
  const std::size_t n = good.disps_sens->size(), HW = static_cast<std::size_t>(good.H) * good.W;
  ASSERT_GT(n, 300u);
  for (std::size_t at : {std::size_t{0}, std::size_t{255}, std::size_t{256}, n / 2, n - 1}) {
    Snapshot s = good;
    (*s.disps_sens)[at] = -std::numeric_limits<float>::denorm_min();
    if (at != n - 1) (*s.disps_sens)[n - 1] = -1.0f;  // a later one must not be named
    std::ostringstream where;
    where << "keyframe " << at / HW << " pixel (x=" << at % HW % good.W
          << ", y=" << at % HW / good.W << ")";
    const std::string message = validationError(s);
    EXPECT_NE(message.find("key 'disps_sens' is negative at " + where.str()), std::string::npos)
        << message;
  }
  Snapshot s = good;
  for (float& d : *s.disps_sens) d = -0.0f;  // no reading anywhere is valid
  EXPECT_EQ(validationError(s), "");
}

TEST(SnapshotChecks, NonFiniteKeyframeTimesAreNamed) {
  const Snapshot good = testing::tinySnapshot(5, 0).snapshot;
  ASSERT_TRUE(good.timestamps_s);
  for (const double bad :
       {std::numeric_limits<double>::quiet_NaN(), -std::numeric_limits<double>::infinity()}) {
    Snapshot s = good;
    (*s.timestamps_s)[2] = bad;
    const std::string message = validationError(s);
    EXPECT_NE(message.find("key 'timestamps_s' keyframe 2 has the non-finite value"),
              std::string::npos)
        << message;
  }
  Snapshot s = good;
  (*s.timestamps_s)[3] = std::numeric_limits<double>::max();  // finite, if absurd
  EXPECT_EQ(validationError(s).find("non-finite"), std::string::npos);
}

}  // namespace
}  // namespace dbacov
