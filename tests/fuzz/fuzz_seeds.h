// Seed corpora of the fuzz targets, generated from small synthetic snapshots and graphs (and
// hand-written ground-truth files): valid inputs in every layout the readers accept, which the
// fuzzer then mutates. Used by the fuzz_seeds tool
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

#include "dbacov/app/evaluation_inputs.h"
#include "dbacov/io/npz.h"
#include "dbacov/io/snapshot_npz.h"
#include "dbacov/mrpt/observation_dba_snapshot.h"
#include "dbacov/mrpt/pose_graph_io.h"
#include "dbacov/mrpt/rawlog_io.h"
#include "dbacov/sim/sensor_modes.h"
#include "dbacov/sim/synthetic_snapshot.h"
#include "fixtures.h"
#include "python_snapshot_codec.h"

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

/// The arguments of Python's Snapshot(...) (python_snapshot_codec.h): a mono snapshot with int64,
/// int32 and integral float64 indices, and one with every optional argument.
inline Corpus pythonSnapshotSeeds() {
  Corpus c;
  const Snapshot tiny = seedSnapshot(3, 4, 5);
  c["tiny_int64_indices.bin"] = encodeSnapshotArrays(tiny);
  c["tiny_int32_indices.bin"] = encodeSnapshotArrays(tiny, 4);
  c["tiny_float64_indices.bin"] = encodeSnapshotArrays(tiny, 0);
  Snapshot full = seedSnapshot(4, 3, 4, 1, 2);
  full.timestamps_s = std::vector<double>{1.5, 2.5, 3.5, 4.5};
  full.disps_sens = full.disps;
  full.stereo_rig = (Eigen::Matrix<double, 7, 1>() << -0.1, 0, 0, 0, 0, 0, 1).finished();
  full.ii.push_back(2);  // a stereo edge
  full.jj.push_back(2);
  full.target.insert(full.target.end(), full.target.begin(),
                     full.target.begin() + 2 * full.pixelsPerFrame());
  full.weight.insert(full.weight.end(), full.weight.begin(),
                     full.weight.begin() + 2 * full.pixelsPerFrame());
  full.id = 7;
  full.t0 = 1;
  full.validate();
  c["small_every_optional.bin"] = encodeSnapshotArrays(full);
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
  // DROID's other modes: stereo edges and rig, depth-sensor readings, t0 (record version 1).
  CObservationDbaSnapshot m;
  m.snapshot = seedSnapshot(3, 4, 5, 0, 4);
  sim::addStereoEdges(m.snapshot, sim::StereoConfig{});
  sim::addSensorDepth(m.snapshot, sim::RgbdConfig{});
  m.snapshot.t0 = 1;
  c["droid_modes.rawlog"] = rawlogBytes({&m});
  return c;
}

/// Text pose graphs as dba-covariance --graph writes them (PREFIX.graph, PREFIX.g2o: MRPT's loader
/// reads both layouts' lines), and hand-written lines of the other tags (VERTEX3, EDGE3, FIX).
inline Corpus graphSeeds() {
  PoseGraph g;
  for (int k = 0; k < 4; ++k) {
    Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
    T.translation() = Eigen::Vector3d(k, 0.1 * k, 0);
    T.linear() = Eigen::AngleAxisd(0.1 * k, Eigen::Vector3d::UnitZ()).toRotationMatrix();
    g.nodes[k] = T;
  }
  Matrix6d I = Matrix6d::Identity() * 100;
  I(0, 1) = I(1, 0) = 5;
  I(3, 4) = I(4, 3) = 2;
  for (const auto& [a, b] : std::vector<std::pair<int, int>>{{0, 1}, {0, 2}, {1, 2}, {2, 3}})
    g.edges.push_back({a, b, g.nodes[a].inverse() * g.nodes[b], I});
  Corpus c;
  c["mrpt.graph"] = fileBytes([&](const std::string& p) {
    mrpt_bridge::writeGraphText(p, g, mrpt_bridge::GraphTextLayout::Mrpt258);
  });
  c["g2o.graph"] = fileBytes([&](const std::string& p) {
    mrpt_bridge::writeGraphText(p, g, mrpt_bridge::GraphTextLayout::G2o);
  });
  const std::string info21 = " 1 0 0 0 0 0 1 0 0 0 0 1 0 0 0 1 0 0 1 0 1";
  const std::string text =
      "# other tags\nVERTEX3 0 0 0 0 0 0 0\nVERTEX3 1 1 0 0 0.1 0 0\n"
      "EDGE3 0 1 1 0 0 0.1 0 0" +
      info21 + "\nFIX 0\n";
  c["tags.graph"] = std::vector<unsigned char>(text.begin(), text.end());
  return c;
}

/// Ground-truth files of dba-evaluate (--gt: TUM, EuRoC's state_groundtruth_estimate0/data.csv)
/// and image-time lists (--image-times: one time per line, EuRoC's cam0/data.csv).
inline Corpus groundTruthSeeds() {
  auto bytes = [](const std::string& s) { return std::vector<unsigned char>(s.begin(), s.end()); };
  Corpus c;
  c["tum.txt"] = bytes(
      "# timestamp tx ty tz qx qy qz qw\n1000 0 0 0 0 0 0 1\n"
      "1000.05 0.1 0 0.01 0 0 0.0499792 0.99875\n1000.1 0.2 0.01 0.02 0 0 0.0998334 0.995004\n");
  c["euroc.csv"] = bytes(
      "#timestamp, p_RS_R_x [m], p_RS_R_y [m], p_RS_R_z [m], q_RS_w [], q_RS_x [], q_RS_y [], "
      "q_RS_z [], v_RS_R_x [m s^-1], v_RS_R_y [m s^-1], v_RS_R_z [m s^-1], b_w_RS_S_x [rad s^-1], "
      "b_w_RS_S_y [rad s^-1], b_w_RS_S_z [rad s^-1], b_a_RS_S_x [m s^-2], b_a_RS_S_y [m s^-2], "
      "b_a_RS_S_z [m s^-2]\n"
      "1403636579758555392,4.688319,-1.786938,0.783338,0.534108,-0.153029,-0.827383,-0.082152,"
      "-0.027876,0.033207,0.800006,-0.003172,0.021267,0.078502,-0.025266,0.136696,0.075593\n"
      "1403636579763555584,4.688177,-1.786770,0.787350,0.534640,-0.152990,-0.826976,-0.082863,"
      "-0.040116,0.025858,0.800818,-0.003172,0.021267,0.078502,-0.025266,0.136696,0.075593\n");
  c["image_times.txt"] = bytes("# seconds\n1000\n1000.05\n1000.1\n");
  c["cam0.csv"] = bytes(
      "#timestamp [ns],filename\n1403636579763555584,1403636579763555584.png\n"
      "1403636579813555456,1403636579813555456.png\n");
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

/// What seed `bytes` of any target holds, read back by the reader under test: snapshots (npz,
/// rawlog), graph nodes (graph), ground-truth poses or image times (ground_truth). Throws
/// dbacov::InputError when it cannot be read.
inline int itemsInSeed(const std::string& target, const std::string& name,
                       const std::vector<unsigned char>& bytes) {
  if (target == "npz" || target == "rawlog") return snapshotsInSeed(target, name, bytes);
  if (target == "python_snapshot") {
    const auto d = decodeSnapshotArrays(bytes.data(), bytes.size());
    if (!d) throw InputError(name + ": declares too many items");
    python::snapshotFromArrays(d->arrays);
    return 1;
  }
  const std::string path = (std::filesystem::temp_directory_path() /
                            ("dbacov_seed_" + std::to_string(::getpid()) + "_" + name))
                               .string();
  std::ofstream(path, std::ios::binary)
      .write(reinterpret_cast<const char*>(bytes.data()),
             static_cast<std::streamsize>(bytes.size()));
  struct Remove {
    std::string p;
    ~Remove() { std::remove(p.c_str()); }
  } remove{path};
  if (target == "graph")
    return static_cast<int>(
        mrpt_bridge::fromNetwork(mrpt_bridge::readGraphMrptText(path), path).nodes.size());
  if (name.rfind("image_times", 0) == 0 || name.rfind("cam0", 0) == 0) {
    const app::KeyframeTimes times = app::KeyframeTimes::fromFile(path);
    int n = 0;
    for (; n < 1000; ++n) try {
        times(n);
      } catch (const InputError&) {
        break;
      }
    return n;
  }
  return static_cast<int>(app::GroundTruth::load(path).size());
}

}  // namespace dbacov::fuzz
