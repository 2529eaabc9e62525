// Bytes after the last object of a rawlog: CRawlog stops at them silently and zlib's
// gzread ignores whatever follows a gzip member, so an appended or damaged tail used to pass for
// a complete file. Now: junk after the last object (plain rawlog, or inside the compressed data)
// and non-gzip bytes after the last gzip member are refused naming the file, the byte offset, how
// many bytes and the entry they follow; a second valid gzip member (legal concatenation) and a
// clean end exactly at an object boundary are accepted. For the snapshot reader (dba-covariance)
// and the pose-rawlog reader (dba-evaluate --rawlog).
#include <filesystem>
#include <fstream>
#include <functional>
#include <regex>

#include <gtest/gtest.h>
#include <mrpt/obs/CObservationRobotPose.h>

#include "app_runner.h"
#include "bad_inputs.h"
#include "dbacov/app/covariance_app.h"
#include "dbacov/app/evaluate_app.h"
#include "dbacov/app/evaluation_inputs.h"
#include "dbacov/core/errors.h"
#include "dbacov/mrpt/rawlog_io.h"
#include "fixtures.h"
#include "rawlog_records.h"
#include "temp_dir.h"

namespace dbacov {
namespace trailing_bytes {  // not anonymous: the suite is compiled as a unity build

const Snapshot& good(int seed) {
  static std::map<int, Snapshot> cache;
  auto [it, fresh] = cache.try_emplace(seed);
  if (fresh) it->second = testing::tinySnapshot(seed, 100 + seed).snapshot;
  return it->second;
}

std::vector<unsigned char> bytesOf(const std::string& s) {
  return std::vector<unsigned char>(s.begin(), s.end());
}

void append(const std::string& path, const std::vector<unsigned char>& tail) {
  std::ofstream(path, std::ios::binary | std::ios::app)
      .write(reinterpret_cast<const char*>(tail.data()), static_cast<std::streamsize>(tail.size()));
}

std::uint64_t fileSize(const std::string& path) {
  return std::filesystem::file_size(path);
}

/// One good snapshot record (good(5), id 105), as MRPT's archive writes it.
std::vector<unsigned char> record() {
  return testing::serializeRecord(good(5)).bytes;
}

struct Tail {
  std::string name;
  /// Writes the rawlog; returns the message expected after "dba-covariance: error: <path>"
  /// ("" when the file must be accepted).
  std::function<std::string(const std::string& path)> make;
  int snapshots = 1;  ///< snapshots of the file that are processed
};

void PrintTo(const Tail& t, std::ostream* os) {
  *os << t.name;
}

std::vector<Tail> tails() {
  const std::string n = std::to_string(record().size());
  return {
      {"plain_rawlog_with_junk",
       [n](const std::string& p) {
         std::vector<unsigned char> b = record();
         const auto junk = bytesOf("garbage\n");
         b.insert(b.end(), junk.begin(), junk.end());
         testing::writeBytes(p, b);
         return ": 8 bytes at byte " + n +
                " of the file, after the last object (entry 0), are not a rawlog object (not an "
                "object in MRPT's serialization format (a rawlog written by MRPT >= 0.5.5 is "
                "expected); starting 67 61 72 62 61 67 65 0a)";
       }},
      {"plain_rawlog_with_zeros",
       [n](const std::string& p) {
         std::vector<unsigned char> b = record();
         b.resize(b.size() + 4096, 0);  // e.g. a file system's zero-filled tail after a crash
         testing::writeBytes(p, b);
         return ": 4096 bytes at byte " + n +
                " of the file, after the last object (entry 0), are not a rawlog object (not an "
                "object in MRPT's serialization format (a rawlog written by MRPT >= 0.5.5 is "
                "expected); starting 00 00 00 00 00 00 00 00)";
       }},
      {"junk_inside_the_compressed_data",
       [n](const std::string& p) {
         std::vector<unsigned char> b = record();
         b.insert(b.end(), {0x01, 0x02, 0x03});
         testing::writeGz(p, b);
         return ": 3 bytes at byte " + n +
                " of the uncompressed data, after the last object (entry 0), are not a rawlog "
                "object (not an object in MRPT's serialization format (a rawlog written by MRPT "
                ">= 0.5.5 is expected); starting 01 02 03)";
       }},
      {"a_cut_object_header_inside_the_compressed_data",
       [n](const std::string& p) {
         std::vector<unsigned char> b = record();
         b.push_back(0x85);  // an object whose 5-byte class name never comes
         testing::writeGz(p, b);
         return ": 1 byte at byte " + n +
                " of the uncompressed data, after the last object (entry 0), is not a rawlog "
                "object (the object's header is truncated; starting 85)";
       }},
      {"junk_after_a_zlib_member",
       [](const std::string& p) {
         testing::writeGz(p, record());
         const std::string at = std::to_string(fileSize(p));
         append(p, bytesOf("trailing junk"));
         return ": 13 bytes at byte " + at +
                " of the file, after the last gzip member, are not gzip data (starting 74 72 61 "
                "69 6c 69 6e 67): a gzip file holds only gzip members; was it appended to or "
                "damaged? (after entry 0, the last complete object)";
       }},
      {"junk_after_dbacovs_last_member",
       [](const std::string& p) {
         {
           mrpt_bridge::RawlogWriter w(p);
           CObservationDbaSnapshot obs;
           obs.snapshot = good(5);
           w.write(obs);
           w.commit();
         }
         const std::string at = std::to_string(fileSize(p));
         append(p, {0x1f});  // half a gzip magic number
         return ": 1 byte at byte " + at +
                " of the file, after the last gzip member, is not gzip data (starting 1f): a gzip "
                "file holds only gzip members; was it appended to or damaged? (after entry 0, the "
                "last complete object)";
       }},
      {"clean_end_at_an_object_boundary",
       [](const std::string& p) {
         testing::writeGz(p, record());
         return std::string();
       }},
      {"plain_clean_end",
       [](const std::string& p) {
         testing::writeBytes(p, record());
         return std::string();
       }},
      {"a_second_gzip_member_is_concatenation",
       [](const std::string& p) {
         testing::writeGz(p, record());
         const std::string second = p + ".2";
         testing::writeGz(second, testing::serializeRecord(good(6)).bytes);
         append(p, testing::readBytes(second));
         std::filesystem::remove(second);
         return std::string();
       },
       2},
  };
}

class TrailingBytesTest : public ::testing::TestWithParam<Tail> {};

TEST_P(TrailingBytesTest, AreRefusedNamingFileOffsetAndCountAndTheGoodSnapshotsAreKept) {
  const Tail& t = GetParam();
  testing::TempDir dir;
  const std::string path = dir.file("s.rawlog");
  const std::string expected = t.make(path);
  const testing::AppResult r =
      testing::runApp(app::runCovarianceApp, "dba-covariance",
                      {"-i", path, "--csv", dir.file("k.csv"), "--weight-scale", "4", "-q"});
  if (expected.empty()) {
    EXPECT_EQ(r.code, 0) << r.err;
    EXPECT_EQ(r.err, "");
  } else {
    EXPECT_EQ(r.code, 1);
    EXPECT_EQ(r.err, "dba-covariance: error: " + path + expected + "\n");
  }
  // Nothing lost: the snapshots before the tail are processed and written.
  std::set<std::string> ids;
  for (const auto& line : testing::splitLines(testing::readFile(dir.file("k.csv"))))
    ids.insert(testing::splitCsv(line)[0]);
  EXPECT_EQ(ids.size(), 1u + t.snapshots);
  EXPECT_TRUE(ids.count("105"));

  if (expected.empty()) return;
  // With --fail-fast the refused file stops the run: the previous output stays as it was.
  testing::writeBytes(dir.file("k.csv"), bytesOf("previous\n"));
  const testing::AppResult f = testing::runApp(
      app::runCovarianceApp, "dba-covariance",
      {"-i", path, "--csv", dir.file("k.csv"), "--weight-scale", "4", "-q", "--fail-fast"});
  EXPECT_EQ(f.code, 1);
  EXPECT_NE(f.err.find(path + expected), std::string::npos) << f.err;
  EXPECT_EQ(testing::readFile(dir.file("k.csv")), "previous\n");
}

INSTANTIATE_TEST_SUITE_P(Tails, TrailingBytesTest, ::testing::ValuesIn(tails()),
                         [](const auto& p) { return p.param.name; });

TEST(TrailingBytes, AfterAPoseRawlogAreRefusedByDbaEvaluate) {
  testing::TempDir dir;
  const std::string path = dir.file("poses.rawlog");
  {
    mrpt_bridge::RawlogWriter w(path);
    for (int i = 0; i < 2; ++i) {
      mrpt::obs::CObservationRobotPose obs;
      obs.timestamp = mrpt::Clock::fromDouble(1000.0 + i);
      obs.pose.cov.setIdentity();
      obs.pose.cov *= 1e-4;
      w.write(obs);
    }
    w.commit();
  }
  ASSERT_EQ(app::readPoseRawlog(path).size(), 2u);  // clean: accepted
  const std::string at = std::to_string(fileSize(path));
  append(path, std::vector<unsigned char>(100, 0));
  const std::string message = path + ": 100 bytes at byte " + at +
                              " of the file, after the last gzip member, are not gzip data "
                              "(starting 00 00 00 00 00 00 00 00): a gzip file holds only gzip "
                              "members; was it appended to or damaged? (after entry 1, the last "
                              "complete object)";
  try {
    app::readPoseRawlog(path);
    ADD_FAILURE() << "accepted";
  } catch (const InputError& e) {
    EXPECT_EQ(std::string(e.what()), message);
  }
  std::ofstream(dir.file("gt.tum")) << "1000 0 0 0 0 0 0 1\n1001 0 0 0 0 0 0 1\n";
  const testing::AppResult r =
      testing::runApp(app::runEvaluateApp, "dba-evaluate",
                      {"--rawlog", path, "--gt", dir.file("gt.tum"), "--json", dir.file("e.json")});
  EXPECT_EQ(r.code, 1);
  EXPECT_NE(r.err.find(message), std::string::npos) << r.err;
  EXPECT_FALSE(std::filesystem::exists(dir.file("e.json")));
}

}  // namespace trailing_bytes
}  // namespace dbacov
