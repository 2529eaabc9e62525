// Bad .npz snapshots between two good ones: for each, dba-covariance reports the exact message
// (file, key, keyframe or edge, and what was expected) and exit code 1, does not crash, and still
// processes and writes both good snapshots.
#include <algorithm>
#include <filesystem>
#include <functional>

#include <gtest/gtest.h>

#include "app_runner.h"
#include "bad_inputs.h"
#include "dbacov/app/covariance_app.h"
#include "fixtures.h"
#include "temp_dir.h"

namespace dbacov {
namespace bad_npz {  // not anonymous: the suite is compiled as a unity build

using testing::NpzArrays;
using D = io::NpyArray::DType;

struct BadNpz {
  std::string name;
  std::function<void(const std::string& path, const Snapshot& good)> make;
  std::string expected;  ///< the message after "<path>: "
};

/// A case that writes the good snapshot's arrays after `edit`.
BadNpz arrays(std::string name, std::function<void(NpzArrays&)> edit, std::string expected) {
  return {std::move(name),
          [edit](const std::string& path, const Snapshot& good) {
            NpzArrays a = testing::snapshotArrays(good);
            edit(a);
            testing::writeArrays(path, a);
          },
          std::move(expected)};
}

/// A case that damages the bytes of the good snapshot's file.
BadNpz bytes(std::string name, std::function<void(std::vector<unsigned char>&)> edit,
             std::string expected) {
  return {std::move(name),
          [edit](const std::string& path, const Snapshot& good) {
            io::saveSnapshotNpz(path, good);
            std::vector<unsigned char> b = testing::readBytes(path);
            edit(b);
            testing::writeBytes(path, b);
          },
          std::move(expected)};
}

/// Sets value `i` of `key` to `v`.
std::function<void(NpzArrays&)> set(const std::string& key, std::size_t i, double v) {
  return [=](NpzArrays& a) { testing::setValue(testing::arrayOf(a, key), i, v); };
}

// The tiny snapshot: N = 6 keyframes, E = 18 edges, an 8×10 grid (80 pixels per plane).
std::vector<BadNpz> corpus() {
  const double nan = testing::quietNan(), inf = testing::infinity();
  return {
      // Damaged files.
      bytes(
          "empty", [](auto& b) { b.clear(); },
          "cannot open as a .npz (zip) archive: Not a zip archive"),
      bytes(
          "truncated", [](auto& b) { b.resize(b.size() / 2); },
          "cannot open as a .npz (zip) archive: Not a zip archive"),
      bytes(
          "not_a_zip", [](auto& b) { b.assign(500, 'x'); },
          "cannot open as a .npz (zip) archive: Not a zip archive"),
      {"flipped_byte",
       [](const std::string& path, const Snapshot& good) {
         testing::writeArrays(path, testing::snapshotArrays(good), /*stored=*/true);
         std::vector<unsigned char> b = testing::readBytes(path);
         const std::string name = "target.npy";
         const auto at = std::search(b.begin(), b.end(), name.begin(), name.end());
         at[name.size() + 200] ^= 0x55;  // a byte of the first target values
         testing::writeBytes(path, b);
       },
       "key 'target': cannot read member: CRC error"},
      // Keys, dtypes and shapes.
      arrays(
          "missing_weight", [](auto& a) { testing::removeKey(a, "weight"); },
          "missing required key 'weight' (conventions §1)"),
      arrays(
          "ii_float",
          [](auto& a) {
            auto& x = testing::arrayOf(a, "ii");
            x = testing::withDtype(x, D::Float32);
          },
          "key 'ii' has dtype float32, expected int32 or int64"),
      arrays(
          "poses_int",
          [](auto& a) {
            auto& x = testing::arrayOf(a, "poses");
            x = testing::withDtype(x, D::Int64);
          },
          "key 'poses' has dtype int64, expected float32 or float64"),
      arrays(
          "weight_uint8",
          [](auto& a) {
            auto& x = testing::arrayOf(a, "weight");
            x = testing::withDtype(x, D::UInt8);
          },
          "key 'weight' has dtype uint8, expected float32 or float64"),
      arrays(
          "poses_6_columns",
          [](auto& a) {
            auto& x = testing::arrayOf(a, "poses");
            x = testing::withShape(x, {6, 6});
          },
          "key 'poses' has shape (6,6), expected (6,7)"),
      arrays(
          "disps_2d",
          [](auto& a) {
            auto& x = testing::arrayOf(a, "disps");
            x = testing::withShape(x, {6, 80});
          },
          "key 'disps' has shape (6,80), expected (6,H,W) (N from 'poses')"),
      arrays(
          "disps_wrong_n",
          [](auto& a) {
            auto& x = testing::arrayOf(a, "disps");
            x = testing::withShape(x, {5, 8, 10});
          },
          "key 'disps' has shape (5,8,10), expected (6,8,10) (N from 'poses')"),
      arrays(
          "target_wrong_w",
          [](auto& a) {
            auto& x = testing::arrayOf(a, "target");
            x = testing::withShape(x, {18, 2, 8, 9});
          },
          "key 'target' has shape (18,2,8,9), expected (18,2,8,10) (E,2,H,W from 'ii' and "
          "'disps')"),
      arrays(
          "weight_one_channel",
          [](auto& a) {
            auto& x = testing::arrayOf(a, "weight");
            x = testing::withShape(x, {18, 1, 8, 10});
          },
          "key 'weight' has shape (18,1,8,10), expected (18,2,8,10) (E,2,H,W from 'ii' and "
          "'disps')"),
      arrays(
          "jj_short",
          [](auto& a) {
            auto& x = testing::arrayOf(a, "jj");
            x = testing::withShape(x, {17});
          },
          "key 'jj' has shape (17,), expected (18,) (E from 'ii')"),
      arrays(
          "intrinsics_3",
          [](auto& a) {
            auto& x = testing::arrayOf(a, "intrinsics");
            x = testing::withShape(x, {3});
          },
          "key 'intrinsics' has shape (3,), expected (4,) (fx fy cx cy)"),
      arrays(
          "tstamp_2d",
          [](auto& a) {
            auto& x = testing::arrayOf(a, "tstamp");
            x = testing::withShape(x, {6, 1});
          },
          "key 'tstamp' has shape (6,1), expected (N,) (N from 'poses')"),
      arrays(
          "id_vector",
          [](auto& a) {
            auto& x = testing::arrayOf(a, "id");
            x = testing::withShape(x, {2});
          },
          "key 'id' has shape (2,), expected () or (1,)"),
      arrays(
          "no_keyframes",
          [](auto& a) {
            for (const auto& [key, shape] :
                 std::vector<std::pair<std::string, std::vector<std::size_t>>>{
                     {"poses", {0, 7}},
                     {"disps", {0, 8, 10}},
                     {"tstamp", {0}},
                     {"timestamps_s", {0}}}) {
              auto& x = testing::arrayOf(a, key);
              x = testing::withShape(x, shape);
            }
          },
          "key 'poses' is empty: expected at least 2 keyframes"),
      // Values: NaN and Inf in every array.
      arrays(
          "nan_pose", set("poses", 3 * 7 + 2, nan),
          "key 'poses' keyframe 3 has the non-finite value nan in column 2 (tz), expected a finite "
          "pose [tx ty tz qx qy qz qw]"),
      arrays("inf_quaternion", set("poses", 4 * 7 + 6, -inf),
             "key 'poses' keyframe 4 has the non-finite value -inf in column 6 (qw), expected a "
             "finite "
             "pose [tx ty tz qx qy qz qw]"),
      arrays("nan_disp", set("disps", 2 * 80 + 3 * 10 + 4, nan),
             "key 'disps' is non-finite at keyframe 2 pixel (x=4, y=3)"),
      arrays("inf_disp", set("disps", 0, inf),
             "key 'disps' is non-finite at keyframe 0 pixel (x=0, y=0)"),
      arrays("nan_intrinsics", set("intrinsics", 2, nan),
             "key 'intrinsics' is [fx fy cx cy] = [9 9 nan 3.5], expected finite values with fx, "
             "fy > 0"),
      arrays("nan_target", set("target", (5 * 2 + 1) * 80 + 7, nan),
             "key 'target' is non-finite at edge 5 channel 1 pixel (x=7, y=0)"),
      arrays("inf_weight", set("weight", (17 * 2 + 0) * 80 + 79, inf),
             "key 'weight' is non-finite at edge 17 channel 0 pixel (x=9, y=7)"),
      arrays("nan_tstamp", set("tstamp", 4, nan),
             "key 'tstamp' keyframe 4 has the non-finite value nan, expected a finite time"),
      arrays("inf_timestamps_s", set("timestamps_s", 1, inf),
             "key 'timestamps_s' keyframe 1 has the non-finite value inf, expected a finite time"),
      // Graph and value ranges.
      arrays(
          "ii_out_of_range", [](auto& a) { testing::setInt(testing::arrayOf(a, "ii"), 7, 6); },
          "key 'ii' edge 7 names keyframe 6, expected 0..5"),
      arrays(
          "jj_negative", [](auto& a) { testing::setInt(testing::arrayOf(a, "jj"), 0, -1); },
          "key 'jj' edge 0 names keyframe -1, expected 0..5"),
      arrays(
          "self_loop",
          [](auto& a) {
            testing::setInt(testing::arrayOf(a, "jj"), 9, 0);
            testing::setInt(testing::arrayOf(a, "ii"), 9, 0);
          },
          "edge 9 links keyframe 0 to itself (ii == jj): a stereo edge needs the rig "
          "transform, key 'stereo_rig'"),
      arrays("negative_weight", set("weight", 3 * 160 + 80 + 12, -0.5),
             "key 'weight' is negative (-0.500000) at edge 3 channel 1 pixel (x=2, y=1), expected "
             "confidences >= 0"),
      arrays(
          "all_zero_weights",
          [](auto& a) {
            auto& w = testing::arrayOf(a, "weight");
            std::fill(w.data.begin(), w.data.end(), 0);
          },
          "key 'weight' is zero at every pixel of every edge: the snapshot carries no information, "
          "expected some confidences > 0"),
      arrays(
          "zero_quaternion",
          [](auto& a) {
            for (int c = 3; c < 7; ++c)
              testing::setValue(testing::arrayOf(a, "poses"), 2 * 7 + c, 0);
          },
          "key 'poses' keyframe 2 has a zero quaternion, expected a unit quaternion [qx qy qz qw]"),
      arrays("zero_focal_length", set("intrinsics", 1, 0),
             "key 'intrinsics' is [fx fy cx cy] = [9 0 4.5 3.5], expected finite values with fx, "
             "fy > 0"),
  };
}

void PrintTo(const BadNpz& c, std::ostream* os) {
  *os << c.name;
}

class BadNpzTest : public ::testing::TestWithParam<BadNpz> {};

TEST_P(BadNpzTest, IsExplainedAndTheGoodSnapshotsAreWritten) {
  const BadNpz& c = GetParam();
  testing::TempDir dir;
  std::filesystem::create_directory(dir.file("in"));
  testing::writeTinySnapshot(dir.file("in/a.npz"), 1, 1);
  c.make(dir.file("in/b.npz"), testing::tinySnapshot(2, 2).snapshot);
  testing::writeTinySnapshot(dir.file("in/c.npz"), 3, 3);
  const testing::AppResult r =
      testing::runApp(app::runCovarianceApp, "dba-covariance",
                      {"-i", dir.file("in"), "--csv", dir.file("k.csv"), "--relative-csv",
                       dir.file("r.csv"), "-o", dir.file("p.rawlog"), "--weight-scale", "4"});
  EXPECT_EQ(r.code, 1);
  EXPECT_EQ(
      r.err,
      "dba-covariance: error: " + dir.file("in/b.npz") + ": " + c.expected + "\n" +
          "dba-covariance: 3 snapshots read, 2 processed, 1 failed: 1 invalid input (b.npz)\n");
  const auto rows = testing::splitLines(testing::readFile(dir.file("k.csv")));
  ASSERT_EQ(rows.size(), 1u + 2 * 6);
  EXPECT_EQ(testing::splitCsv(rows[1])[0], "1");
  EXPECT_EQ(testing::splitCsv(rows[12])[0], "3");
  EXPECT_GT(testing::splitLines(testing::readFile(dir.file("r.csv"))).size(), 1u);
  EXPECT_TRUE(std::filesystem::exists(dir.file("p.rawlog")));
}

INSTANTIATE_TEST_SUITE_P(Corpus, BadNpzTest, ::testing::ValuesIn(corpus()),
                         [](const auto& p) { return p.param.name; });

}  // namespace bad_npz
}  // namespace dbacov
