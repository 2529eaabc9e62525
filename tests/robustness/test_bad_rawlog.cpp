// Bad rawlogs of snapshots between two good .npz snapshots: truncated and corrupt gz streams,
// damaged records (sizes, flags, class, version), empty rawlogs and rawlogs of other classes.
// For each, dba-covariance reports the exact message naming the file and entry, exits with 1, and
// still processes and writes the good snapshots (including those of the same rawlog that come
// before the damage).
#include <filesystem>
#include <functional>
#include <map>
#include <regex>

#include <gtest/gtest.h>
#include <mrpt/obs/CObservationRobotPose.h>

#include "app_runner.h"
#include "bad_inputs.h"
#include "dbacov/app/covariance_app.h"
#include "dbacov/mrpt/rawlog_io.h"
#include "fixtures.h"
#include "rawlog_records.h"
#include "temp_dir.h"

namespace dbacov {
namespace bad_rawlog {  // not anonymous: the suite is compiled as a unity build

using testing::RecordBytes;

struct BadRawlog {
  std::string name;
  std::function<void(const std::string& path)> make;
  std::string expected;    ///< the error line after "dba-covariance: error: <path>"
  int good_in_rawlog = 0;  ///< snapshots of the rawlog that are still processed
  std::string failed_as;   ///< the summary's name of the failed snapshot
  bool regex = false;      ///< `expected` is a regular expression (the damage depends on zlib)
};

void PrintTo(const BadRawlog& c, std::ostream* os) {
  *os << c.name;
}

const Snapshot& good(int seed) {
  static std::map<int, Snapshot> cache;
  auto [it, fresh] = cache.try_emplace(seed);
  if (fresh) it->second = testing::tinySnapshot(seed, 100 + seed).snapshot;
  return it->second;
}

/// A rawlog of one record of a good snapshot, changed by `edit`.
std::function<void(const std::string&)> record(std::function<void(RecordBytes&)> edit) {
  return [edit](const std::string& path) { testing::writeRecord(path, good(5), edit); };
}

/// A rawlog of records `first` (good) and then `second` changed by `edit`.
std::function<void(const std::string&)> twoRecords(std::function<void(RecordBytes&)> edit) {
  return [edit](const std::string& path) {
    RecordBytes a = testing::serializeRecord(good(5)), b = testing::serializeRecord(good(6));
    edit(b);
    a.bytes.insert(a.bytes.end(), b.bytes.begin(), b.bytes.end());
    testing::writeGz(path, a.bytes);
  };
}

std::vector<BadRawlog> corpus() {
  const std::size_t target_at = [] {
    const Snapshot& s = good(5);
    return testing::serializeRecord(s).flagAt(s) - s.numKeyframes() * 8 -
           2 * static_cast<std::size_t>(s.numEdges()) * 2 * s.pixelsPerFrame() * 4;
  }();
  return {
      {"empty", [](const std::string& p) { testing::writeBytes(p, {}); },
       ": holds no DBA snapshot (0 objects of other classes), expected the CObservationDbaSnapshot "
       "entries that droid2rawlog writes",
       0, "bad.rawlog"},
      {"text",
       [](const std::string& p) { testing::writeBytes(p, std::vector<unsigned char>(300, 'x')); },
       ": entry 0 cannot be read: not an object in MRPT's serialization format (a rawlog written "
       "by "
       "MRPT >= 0.5.5 is expected)",
       0, "bad.rawlog"},
      {"gz_truncated",
       [](const std::string& p) {
         testing::writeRecord(p, good(5), [](RecordBytes&) {});
         auto b = testing::readBytes(p);
         b.resize(b.size() / 2);
         testing::writeBytes(p, b);
       },
       ": entry 0 cannot be read: snapshot record truncated in '[a-z_]+': it declares [0-9]+ "
       "values "
       "\\([0-9]+ bytes\\) but the stream ends after [0-9]+ bytes",
       0, "bad.rawlog", true},
      {"gz_cut_at_flush_point",
       [](const std::string& p) {
         // A good record, flushed, then the file ends: no end-of-stream marker, no trailer.
         testing::writeBytes(p, testing::gzCutAtFlush(testing::serializeRecord(good(5)).bytes));
       },
       ": entry 1 cannot be read: read error: the compressed data is damaged or ends early "
       "(truncated)",
       1, "bad.rawlog"},
      {"gz_corrupt",
       [](const std::string& p) {
         testing::writeRecord(p, good(5), [](RecordBytes&) {});
         auto b = testing::readBytes(p);
         for (std::size_t i = b.size() / 3; i < b.size() / 3 + 16; ++i) b[i] ^= 0xA5;
         testing::writeBytes(p, b);
       },
       ": entry 0 cannot be read: snapshot record unreadable in '[a-z_]+': the stream reports a "
       "read error \\(damaged compressed data\\?\\)",
       0, "bad.rawlog", true},
      {"record_cut_in_target", record([=](RecordBytes& r) { r.bytes.resize(target_at + 1000); }),
       ": entry 0 cannot be read: snapshot record truncated in 'target': it declares 2880 values "
       "(11520 bytes) but the stream ends after 1000 bytes",
       0, "bad.rawlog"},
      {"negative_sizes", record([](RecordBytes& r) { r.setSizes(6, -8, 10, 18); }),
       ": entry 0 cannot be read: snapshot record declares negative sizes (N=6, H=-8, W=10, E=18)",
       0, "bad.rawlog"},
      {"bad_flag", record([](RecordBytes& r) { r.bytes[r.flagAt(good(5))] = 7; }),
       ": entry 0 cannot be read: snapshot record has the presence flag 7 for 'timestamps_s', "
       "expected 0 or 1",
       0, "bad.rawlog"},
      {"unknown_class", record([](RecordBytes& r) { r.bytes[11] ^= 0x20; }),  // COBservation...
       ": entry 0 cannot be read: an object of class dbacov::COBservationDbaSnapshot, expected "
       "CObservationDbaSnapshot (plain or in CSensoryFrames)",
       0, "bad.rawlog"},
      {"unknown_version", record([](RecordBytes& r) { r.bytes[r.label_at - 9] = 3; }),
       ": entry 0 cannot be read: Cannot parse object: unknown serialization version number: '3'",
       0, "bad.rawlog"},
      {"second_entry_cut", twoRecords([](RecordBytes& r) { r.bytes.resize(r.sizes_at + 40); }),
       ": entry 1 cannot be read: snapshot record truncated in 'poses': it declares 42 values (336 "
       "bytes) but the stream ends after 24 bytes",
       1, "bad.rawlog"},
      {"second_entry_nan",
       [](const std::string& p) {
         Snapshot bad = good(6);
         bad.disps[3] = std::numeric_limits<float>::quiet_NaN();
         RecordBytes a = testing::serializeRecord(good(5)), b = testing::serializeRecord(bad);
         a.bytes.insert(a.bytes.end(), b.bytes.begin(), b.bytes.end());
         testing::writeGz(p, a.bytes);
       },
       "#1: key 'disps' is non-finite at keyframe 0 pixel (x=3, y=0)", 1, "bad.rawlog#1"},
      {"poses_only",
       [](const std::string& p) {
         mrpt_bridge::RawlogWriter w(p);
         for (int i = 0; i < 2; ++i) w.write(mrpt::obs::CObservationRobotPose());
         w.commit();
       },
       ": entry 0 cannot be read: an object of class mrpt::obs::CObservationRobotPose, expected "
       "CObservationDbaSnapshot (plain or in CSensoryFrames)",
       0, "bad.rawlog"},
      {"frame_in_frame",
       [](const std::string& p) {
         // Hand-made: MRPT cannot write it (a CSensoryFrame holds observations only).
         const std::string name = "mrpt::obs::CSensoryFrame";
         std::vector<unsigned char> b{static_cast<unsigned char>(0x80 | name.size())};
         b.insert(b.end(), name.begin(), name.end());
         b.insert(b.end(), {2, 1, 0, 0, 0});  // version 2, one observation
         b.push_back(static_cast<unsigned char>(0x80 | name.size()));
         b.insert(b.end(), name.begin(), name.end());
         b.insert(b.end(), {2, 0, 0, 0, 0, 0x88, 0x88});
         testing::writeGz(p, b);
       },
       ": entry 0 cannot be read: a CSensoryFrame inside a CSensoryFrame", 0, "bad.rawlog"},
  };
}

class BadRawlogTest : public ::testing::TestWithParam<BadRawlog> {};

TEST_P(BadRawlogTest, IsExplainedAndTheGoodSnapshotsAreWritten) {
  const BadRawlog& c = GetParam();
  testing::TempDir dir;
  io::saveSnapshotNpz(dir.file("a.npz"), good(1));
  c.make(dir.file("bad.rawlog"));
  io::saveSnapshotNpz(dir.file("c.npz"), good(3));
  const testing::AppResult r =
      testing::runApp(app::runCovarianceApp, "dba-covariance",
                      {"-i", dir.file("a.npz"), "-i", dir.file("bad.rawlog"), "-i",
                       dir.file("c.npz"), "--csv", dir.file("k.csv"), "--weight-scale", "4"});
  EXPECT_EQ(r.code, 1);
  const int read = 3 + c.good_in_rawlog, processed = 2 + c.good_in_rawlog;
  const std::string summary = "dba-covariance: " + std::to_string(read) + " snapshots read, " +
                              std::to_string(processed) +
                              " processed, 1 failed: 1 invalid input (" + c.failed_as + ")\n";
  const std::string error = "dba-covariance: error: " + dir.file("bad.rawlog");
  if (c.regex) {
    const auto lines = testing::splitLines(r.err);
    ASSERT_EQ(lines.size(), 2u) << r.err;
    EXPECT_EQ(lines[0].substr(0, error.size()), error);
    EXPECT_TRUE(std::regex_match(lines[0].substr(error.size()), std::regex(c.expected)))
        << lines[0];
    EXPECT_EQ(lines[1] + "\n", summary);
  } else {
    EXPECT_EQ(r.err, error + c.expected + "\n" + summary);
  }
  EXPECT_EQ(r.err.find("Call stack"), std::string::npos);
  std::vector<std::string> ids;
  for (const auto& line : testing::splitLines(testing::readFile(dir.file("k.csv"))))
    if (ids.empty() || testing::splitCsv(line)[0] != ids.back())
      ids.push_back(testing::splitCsv(line)[0]);
  std::vector<std::string> expected{"snapshot", "101"};
  if (c.good_in_rawlog) expected.push_back("105");
  expected.push_back("103");
  EXPECT_EQ(ids, expected);
}

INSTANTIATE_TEST_SUITE_P(Corpus, BadRawlogTest, ::testing::ValuesIn(corpus()),
                         [](const auto& p) { return p.param.name; });

}  // namespace bad_rawlog
}  // namespace dbacov
