#include "dbacov/app/simul_app.h"

#include <cstdio>
#include <filesystem>

#include <CLI/CLI.hpp>

#include "dbacov/app/csv_format.h"
#include "dbacov/io/atomic_file.h"
#include "dbacov/io/snapshot_npz.h"
#include "dbacov/sim/synthetic_snapshot.h"

namespace dbacov::app {

int runSimulApp(int argc, const char* const* argv, std::ostream& out, std::ostream& err) {
  std::string out_dir;
  int snapshots = 5, window = 8;
  sim::SyntheticSnapshotConfig c;
  c.H = 24;
  c.W = 32;
  CLI::App cli{"simul-dba: synthetic DROID-like DBA snapshots with ground truth", "simul-dba"};
  cli.footer(R"(
Writes DIR/snapshot_NNNN.npz (the DROID snapshot format, with keyframe times 'timestamps_s' =
start + tstamp / fps) and DIR/groundtruth.tum (t tx ty tz qx qy qz qw, camera-to-world, t in seconds).
Snapshot s holds keyframes 0..s+W-1 in 'poses' and edges among its last W keyframes, like
DROID-SLAM's sliding window. The stored state is the ground truth; targets are
true projections plus Gaussian noise of variance 1/(weight_scale*w) per axis, so
`dba-covariance --weight-scale X` with the same X is consistent.)");
  cli.add_option("-o,--out-dir", out_dir, "Output directory (created if missing)")->required();
  cli.add_option("--snapshots", snapshots, "Number of snapshots")->check(CLI::Range(1, 100000));
  cli.add_option("--window", window, "Keyframes per snapshot graph")->check(CLI::Range(2, 1000));
  cli.add_option("--height", c.H, "Grid height (pixels)")->check(CLI::Range(2, 4096));
  cli.add_option("--width", c.W, "Grid width (pixels)")->check(CLI::Range(2, 4096));
  cli.add_option("--edge-radius", c.covisibility.edge_radius, "Link keyframes at most this far apart")->check(CLI::Range(1, 1000));
  cli.add_option("--weight-scale", c.weight_scale, "Information per unit confidence, px^-2")->check(CLI::PositiveNumber);
  cli.add_option("--seed", c.seed, "Random seed");
  double fps = 20.0, start_time = 1.7e9;
  cli.add_option("--fps", fps, "Camera rate: keyframe times 'timestamps_s' = start + tstamp / fps")->check(CLI::PositiveNumber);
  cli.add_option("--start-time", start_time, "Time of image 0, seconds since 1970 (MRPT treats 0 as 'no time')");
  try {
    cli.parse(argc, argv);
  } catch (const CLI::ParseError& e) {
    if (e.get_exit_code() == 0) {
      out << cli.help();
      return 0;
    }
    err << "simul-dba: " << e.what() << "\nRun with --help for usage.\n";
    return 2;
  }
  // Intrinsics follow the grid (≈ 60° horizontal field of view).
  c.fx = c.fy = 0.87 * c.W;
  c.cx = 0.5 * (c.W - 1);
  c.cy = 0.5 * (c.H - 1);
  try {
    std::filesystem::create_directories(out_dir);
    const std::uint64_t seed = c.seed;
    for (int s = 0; s < snapshots; ++s) {
      c.num_keyframes = s + window;
      c.first_keyframe = s;
      c.seed = seed + static_cast<std::uint64_t>(s);
      c.id = s;
      sim::SyntheticSnapshot syn = sim::generateSyntheticSnapshot(c);
      deriveKeyframeTimes(syn.snapshot, fps);
      for (double& t : *syn.snapshot.timestamps_s) t += start_time;
      char name[64];
      std::snprintf(name, sizeof name, "/snapshot_%04d.npz", s);
      io::saveSnapshotNpz(out_dir + name, syn.snapshot);
    }
    c.num_keyframes = snapshots + window - 1;
    io::writeFileAtomically(out_dir + "/groundtruth.tum", [&](std::ostream& os) {
      for (int k = 0; k < c.num_keyframes; ++k) {
        const auto tq = poseToTQ(sim::trajectoryPose(c.trajectory, k));
        os << formatDouble(start_time + c.frame_interval * k / fps);
        for (int i = 0; i < 7; ++i) os << ' ' << formatDouble(tq[i]);
        os << '\n';
      }
    });
  } catch (const std::exception& e) {
    err << "simul-dba: error: " << e.what() << '\n';
    return 1;
  }
  out << "simul-dba: wrote " << snapshots << " snapshots and groundtruth.tum to " << out_dir << '\n';
  return 0;
}

}  // namespace dbacov::app
