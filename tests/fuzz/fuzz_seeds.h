// Seed corpora of the fuzz targets, generated from small synthetic snapshots: valid inputs in
// every layout the readers accept, which the fuzzer then mutates. Used by the fuzz_seeds tool
// (scripts/fuzz.sh) and replayed by test_fuzz_replay.cpp.
#pragma once

#include <unistd.h>

#include <cstdio>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <map>
#include <string>
#include <vector>

#include <mrpt/io/CMemoryStream.h>
#include <mrpt/obs/CSensoryFrame.h>
#include <mrpt/serialization/CArchive.h>

#include "dbacov/io/npz.h"
#include "dbacov/io/snapshot_npz.h"
#include "dbacov/mrpt/observation_dba_snapshot.h"
#include "dbacov/mrpt/rawlog_io.h"
#include "dbacov/sim/synthetic_snapshot.h"
#include "fixtures.h"

namespace dbacov::fuzz {

using Corpus = std::map<std::string, std::vector<unsigned char>>;

/// A valid snapshot of `keyframes` keyframes over an H×W grid, keyframes before `first` outside
/// the graph.
inline Snapshot seedSnapshot(int keyframes, int H, int W, int first = 0, std::uint64_t seed = 1) {
  sim::SyntheticSnapshotConfig c = testing::gridConfig(seed, keyframes, H, W);
  c.first_keyframe = first;
  c.id = static_cast<std::int64_t>(seed);
  Snapshot s = sim::generateSyntheticSnapshot(c).snapshot;
  deriveKeyframeTimes(s, 20.0);
  return s;
}

/// The bytes of a file written by `write(path)` in a scratch file.
template <typename F>
std::vector<unsigned char> fileBytes(F&& write) {
  const std::string path = (std::filesystem::temp_directory_path() /
                            ("dbacov_seed_" + std::to_string(::getpid()) + ".bin"))
                               .string();
  write(path);
  std::ifstream in(path, std::ios::binary);
  std::vector<unsigned char> bytes(std::istreambuf_iterator<char>(in), {});
  std::remove(path.c_str());
  return bytes;
}

inline Corpus npzSeeds() {
  Corpus c;
  const Snapshot tiny = seedSnapshot(3, 4, 5), small = seedSnapshot(6, 8, 10, 1, 2);
  c["tiny_deflated.npz"] =
      fileBytes([&](const std::string& p) { io::saveSnapshotNpz(p, tiny, true); });
  c["tiny_stored.npz"] =
      fileBytes([&](const std::string& p) { io::saveSnapshotNpz(p, tiny, false); });
  c["small_outside_graph.npz"] =
      fileBytes([&](const std::string& p) { io::saveSnapshotNpz(p, small, true); });
  // Other accepted layouts: float64 arrays, int32 indices, id of shape (1,), no optional keys.
  c["tiny_variants.npz"] = fileBytes([&](const std::string& p) {
    const std::size_t N = tiny.numKeyframes(), E = tiny.numEdges(), H = tiny.H, W = tiny.W;
    io::NpzWriter w(p, false);
    w.add("poses",
          io::makeNpy(std::vector<double>(tiny.poses_cw.data(), tiny.poses_cw.data() + N * 7),
                      {N, 7}));
    w.add("disps",
          io::makeNpy(std::vector<double>(tiny.disps.begin(), tiny.disps.end()), {N, H, W}));
    w.add(
        "intrinsics",
        io::makeNpy(std::vector<double>(tiny.intrinsics.data(), tiny.intrinsics.data() + 4), {4}));
    w.add("ii", io::makeNpy(std::vector<std::int32_t>(tiny.ii.begin(), tiny.ii.end()), {E}));
    w.add("jj", io::makeNpy(std::vector<std::int32_t>(tiny.jj.begin(), tiny.jj.end()), {E}));
    w.add("target", io::makeNpy(tiny.target, {E, 2, H, W}));
    w.add("weight",
          io::makeNpy(std::vector<double>(tiny.weight.begin(), tiny.weight.end()), {E, 2, H, W}));
    w.add("tstamp", io::makeNpy(std::vector<float>(tiny.tstamp.begin(), tiny.tstamp.end()), {N}));
    w.add("id", io::makeNpy(std::vector<std::int32_t>{7}, {1}));
    w.commit();
  });
  return c;
}

/// `objects` serialized one after another as MRPT's archive writes a rawlog (uncompressed).
inline std::vector<unsigned char> rawlogBytes(
    const std::vector<const mrpt::serialization::CSerializable*>& objects) {
  mrpt::io::CMemoryStream mem;
  auto arch = mrpt::serialization::archiveFrom(mem);
  for (const auto* o : objects) arch << *o;
  const auto* p = static_cast<const unsigned char*>(mem.getRawBufferData());
  return std::vector<unsigned char>(p, p + mem.getTotalBytesCount());
}

inline Corpus rawlogSeeds() {
  Corpus c;
  CObservationDbaSnapshot a, b;
  a.snapshot = seedSnapshot(3, 4, 5);
  a.sensorLabel = "DBA_SNAPSHOT";
  a.timestamp = mrpt::Clock::fromDouble(10.0);
  b.snapshot = seedSnapshot(4, 4, 5, 1, 3);
  b.snapshot.timestamps_s.reset();
  b.snapshot.id.reset();
  b.sensorLabel = "X";
  c["one.rawlog"] = rawlogBytes({&a});
  c["two.rawlog"] = rawlogBytes({&a, &b});
  auto frame = mrpt::obs::CSensoryFrame::Create();
  frame->insert(std::make_shared<CObservationDbaSnapshot>(b));
  frame->insert(std::make_shared<CObservationDbaSnapshot>(a));
  c["frame.rawlog"] = rawlogBytes({frame.get(), &a});
  return c;
}

/// Number of snapshots that seed `bytes` of `target` ("npz" or "rawlog") holds, each read back by
/// the reader under test and validated. Throws dbacov::InputError when it cannot be read: the
/// fuzzer would then only exercise the error paths (e.g. a build where CObservationDbaSnapshot is
/// not registered with MRPT).
inline int snapshotsInSeed(const std::string& target, const std::string& name,
                           const std::vector<unsigned char>& bytes) {
  if (target == "npz") {
    io::loadSnapshotNpzFromMemory(name, bytes, 0);
    return 1;
  }
  mrpt_bridge::RawlogSnapshotReader reader(name, bytes, 0);
  Snapshot s;
  int n = 0;
  for (; reader.next(&s); ++n) s.validate();
  return n;
}

}  // namespace dbacov::fuzz
