// dba-covariance end to end: good input, every kind of bad input (message + exit code), atomic
// output.
#include <filesystem>
#include <fstream>

#include <gtest/gtest.h>

#include "app_runner.h"
#include "dbacov/app/covariance_app.h"
#include "dbacov/app/csv_format.h"
#include "dbacov/app/outputs.h"
#include "dbacov/core/covariance.h"
#include "dbacov/core/dba_solver.h"
#include "dbacov/core/pipeline.h"
#include "dbacov/io/npy.h"
#include "dbacov/io/snapshot_npz.h"
#include "dbacov/sim/synthetic_snapshot.h"
#include "fixtures.h"
#include "temp_dir.h"

namespace dbacov {
namespace {

using testing::AppResult;
using testing::readFile;
using testing::splitCsv;
using testing::splitLines;

AppResult run(const std::vector<std::string>& args) {
  return testing::runApp(app::runCovarianceApp, "dba-covariance", args);
}

sim::SyntheticSnapshot writeSynthetic(const std::string& path, std::uint64_t seed,
                                      std::int64_t id) {
  return testing::writeTinySnapshot(path, seed, id);
}

bool contains(const std::string& hay, const std::string& needle) {
  return hay.find(needle) != std::string::npos;
}

TEST(CovarianceApp, WritesOneFullPrecisionRowPerGraphKeyframe) {
  testing::TempDir dir;
  std::filesystem::create_directory(dir.file("in"));
  writeSynthetic(dir.file("in/b.npz"), 2, 7);
  writeSynthetic(dir.file("in/a.npz"), 1, 3);
  const AppResult r =
      run({"-i", dir.file("in"), "--csv", dir.file("out.csv"), "--weight-scale", "4", "-q"});
  ASSERT_EQ(r.code, 0) << r.err;
  const auto lines = splitLines(readFile(dir.file("out.csv")));
  ASSERT_EQ(lines.size(), 1u + 2 * 6);
  EXPECT_EQ(lines[0], app::keyframeCsvHeader());
  EXPECT_EQ(splitCsv(lines[0]).size(), 16u + 21u + 1u);
  EXPECT_EQ(lines[0].substr(0, 60), "snapshot,keyframe,tstamp,tx,ty,tz,qx,qy,qz,qw,log10_det,d_op");
  EXPECT_EQ(splitCsv(lines[0])[36], "cov_55");
  EXPECT_EQ(splitCsv(lines[0]).back(), "noise_model");
  // Name order: a.npz (id 3) first, then b.npz (id 7).
  EXPECT_EQ(splitCsv(lines[1])[0], "3");
  EXPECT_EQ(splitCsv(lines[7])[0], "7");

  // Values read back equal the engine's default pipeline's (computeCovariance: the
  // self-calibrated covariance) to the last bit, pose columns are T_wc.
  const Snapshot s = io::loadSnapshotNpz(dir.file("in/a.npz"), 0);
  PipelineOptions p;
  p.engine = DbaOptions::droid();
  p.engine.weight_scale = 4;
  const PipelineResult result = computeCovariance(s, p);
  const DbaCovariance& cov = *result.cov;
  for (int row = 1; row <= 6; ++row) {
    const auto f = splitCsv(lines[row]);
    EXPECT_EQ(f.back(), "self-calibrated");
    const int k = std::stoi(f[1]);
    EXPECT_EQ(std::stod(f[3]), s.T_wc(k).translation().x());
    const Matrix6d S = cov.marginal(k);
    int col = 16;
    for (int a = 0; a < 6; ++a)
      for (int b = a; b < 6; ++b) EXPECT_EQ(std::stod(f[col++]), S(a, b)) << "row " << row;
  }
  // Hard-fixed gauge keyframes 0 and 1: zero covariance, log10 det = -inf.
  EXPECT_EQ(splitCsv(lines[1])[10], "-inf");
  EXPECT_EQ(splitCsv(lines[1])[16], "0");
}

TEST(CovarianceApp, RelativeCsvAndDepthSigmaMatchTheDenseReference) {
  testing::TempDir dir;
  const auto syn = writeSynthetic(dir.file("a.npz"), 4, 12);
  // The stated model: the engine against its dense reference.
  const AppResult r =
      run({"-i", dir.file("a.npz"), "--relative-csv", dir.file("rel.csv"), "--depth-sigma",
           dir.file("sigma"), "--weight-scale", "4", "-q", "--stated-model"});
  ASSERT_EQ(r.code, 0) << r.err;
  DbaOptions o = DbaOptions::droid();
  o.weight_scale = 4;
  CovarianceOptions dense;
  dense.kind = SolverKind::Dense;
  dense.depth_variances = true;
  const DbaCovariance ref(syn.snapshot, o, dense);

  const auto lines = splitLines(readFile(dir.file("rel.csv")));
  EXPECT_EQ(lines[0], "snapshot,from,to,tx,ty,tz,qx,qy,qz,qw," + app::upperTriangleNames("cov_") +
                          ",noise_model");
  const auto pairs = syn.snapshot.relativePairs();
  ASSERT_EQ(lines.size(), 1 + pairs.size());
  for (std::size_t p = 0; p < pairs.size(); ++p) {
    const auto f = splitCsv(lines[p + 1]);
    EXPECT_EQ(f[0], "12");
    EXPECT_EQ(std::stoi(f[1]), pairs[p].first);
    EXPECT_EQ(std::stoi(f[2]), pairs[p].second);
    EXPECT_LT(pairs[p].first, pairs[p].second);
    const Eigen::Isometry3d Z =
        syn.snapshot.T_wc(pairs[p].first).inverse() * syn.snapshot.T_wc(pairs[p].second);
    EXPECT_NEAR(std::stod(f[3]), Z.translation().x(), 1e-12);
    const Matrix6d R = ref.relative(pairs[p].first, pairs[p].second);
    int col = 10;
    for (int a = 0; a < 6; ++a)
      for (int b = a; b < 6; ++b) EXPECT_NEAR(std::stod(f[col++]), R(a, b), 1e-9 * R.norm());
  }

  // One map per source keyframe, float32 H×W, NaN exactly where the reference has no variable.
  for (int k : ref.sourceKeyframes()) {
    const std::string path = dir.file("sigma/12_" + std::to_string(k) + ".npy");
    ASSERT_TRUE(std::filesystem::exists(path)) << path;
    const io::NpyArray a = io::readNpyFile(path);
    EXPECT_EQ(a.dtype, io::NpyArray::DType::Float32);
    EXPECT_EQ(a.shape, (std::vector<std::size_t>{8, 10}));
    const std::vector<float> got = io::npyToFloats(a, path), want = ref.inverseDepthSigma(k);
    for (std::size_t i = 0; i < got.size(); ++i) {
      EXPECT_EQ(std::isnan(got[i]), std::isnan(want[i])) << "pixel " << i;
      if (!std::isnan(want[i])) {
        EXPECT_NEAR(got[i], want[i], 1e-6 * want[i]);
      }
    }
  }
  EXPECT_EQ(std::distance(std::filesystem::directory_iterator(dir.file("sigma")), {}),
            static_cast<long>(ref.sourceKeyframes().size()));
}

TEST(CovarianceApp, ThreadCountDoesNotChangeTheOutput) {
  testing::TempDir dir;
  for (int i = 0; i < 6; ++i) writeSynthetic(dir.file("s" + std::to_string(i) + ".npz"), i + 1, i);
  std::ofstream(dir.file("s3.npz")) << "corrupt";  // a failure in the middle keeps its place
  for (const char* threads : {"1", "2"}) {
    const AppResult r =
        run({"-i", dir.path(), "--csv", dir.file(std::string("t") + threads + ".csv"),
             "--relative-csv", dir.file(std::string("r") + threads + ".csv"), "--weight-scale", "4",
             "--threads", threads, "-q"});
    EXPECT_EQ(r.code, 1) << r.err;
    EXPECT_TRUE(contains(r.err, "s3.npz")) << r.err;
  }
  EXPECT_EQ(readFile(dir.file("t1.csv")), readFile(dir.file("t2.csv")));
  EXPECT_EQ(readFile(dir.file("r1.csv")), readFile(dir.file("r2.csv")));
  // Snapshots appear in input order: ids 0, 1, 2, 4, 5.
  std::vector<std::string> ids;
  for (const auto& line : splitLines(readFile(dir.file("t2.csv"))))
    if (ids.empty() || splitCsv(line)[0] != ids.back()) ids.push_back(splitCsv(line)[0]);
  EXPECT_EQ(ids, (std::vector<std::string>{"snapshot", "0", "1", "2", "4", "5"}));
}

TEST(CovarianceApp, SharedDroidSnapshot) {
  const std::string shared = std::string(DBACOV_SHARED_DATA_DIR) + "/droid_window_0055.npz";
  if (!std::filesystem::exists(shared)) GTEST_SKIP() << "missing " << shared;
  testing::TempDir dir;
  const AppResult r = run({"-i", shared, "--csv", dir.file("out.csv"), "--preset", "paper"});
  ASSERT_EQ(r.code, 0) << r.err;
  const auto lines = splitLines(readFile(dir.file("out.csv")));
  ASSERT_EQ(lines.size(), 11u);  // keyframes 1..10; keyframe 0 takes part in no edge
  EXPECT_EQ(splitCsv(lines[1])[0], "55");
  EXPECT_EQ(splitCsv(lines[1])[1], "1");
  EXPECT_TRUE(contains(r.err, "1 snapshots read, 1 processed, 0 failed")) << r.err;
}

TEST(CovarianceApp, BadSnapshotIsReportedAndTheRestIsWritten) {
  testing::TempDir dir;
  std::filesystem::create_directory(dir.file("in"));
  writeSynthetic(dir.file("in/a.npz"), 1, 0);
  std::ofstream(dir.file("in/b.npz")) << "not a zip archive";
  writeSynthetic(dir.file("in/c.npz"), 3, 2);
  const AppResult r =
      run({"-i", dir.file("in"), "--csv", dir.file("out.csv"), "--weight-scale", "4"});
  EXPECT_EQ(r.code, 1);
  EXPECT_TRUE(contains(r.err, dir.file("in/b.npz"))) << r.err;
  EXPECT_TRUE(contains(r.err, "3 snapshots read, 2 processed, 1 failed")) << r.err;
  EXPECT_EQ(splitLines(readFile(dir.file("out.csv"))).size(), 1u + 2 * 6);
}

TEST(CovarianceApp, InvalidValuesNameFileKeyAndItem) {
  testing::TempDir dir;
  auto syn = writeSynthetic(dir.file("good.npz"), 1, 0);
  Snapshot bad = syn.snapshot;
  // Bypass saveSnapshotNpz's validation by writing through numpy-compatible arrays: negative
  // weight.
  bad.weight[5] = -1.0f;
  EXPECT_THROW(io::saveSnapshotNpz(dir.file("bad.npz"), bad), InputError);
  // An edge that loops on itself is refused on load with its index named.
  Snapshot loop = syn.snapshot;
  loop.jj[3] = loop.ii[3];
  try {
    loop.validate();
    FAIL();
  } catch (const InputError& e) {
    EXPECT_TRUE(contains(e.what(), "edge 3")) << e.what();
  }
}

TEST(CovarianceApp, NumericalFailureNamesKeyframesAndContinues) {
  testing::TempDir dir;
  std::filesystem::create_directory(dir.file("in"));
  auto syn = writeSynthetic(dir.file("in/a.npz"), 1, 0);
  Snapshot s = syn.snapshot;
  const std::size_t plane = 2 * s.pixelsPerFrame();
  for (int e = 0; e < s.numEdges(); ++e)
    if (s.ii[e] == 5 || s.jj[e] == 5)
      std::fill(s.weight.begin() + e * plane, s.weight.begin() + (e + 1) * plane, 0.0f);
  s.id = 1;
  io::saveSnapshotNpz(dir.file("in/b.npz"), s);
  const AppResult r =
      run({"-i", dir.file("in"), "--csv", dir.file("out.csv"), "--weight-scale", "4"});
  EXPECT_EQ(r.code, 1);
  EXPECT_TRUE(contains(r.err, "b.npz (snapshot 1)")) << r.err;
  EXPECT_TRUE(contains(r.err, "keyframes 5")) << r.err;
  EXPECT_EQ(splitLines(readFile(dir.file("out.csv"))).size(), 1u + 6);
}

TEST(CovarianceApp, BadUsageExitsWithTwo) {
  testing::TempDir dir;
  writeSynthetic(dir.file("a.npz"), 1, 0);
  const std::string in = dir.file("a.npz"), out = dir.file("o.csv");
  for (const auto& args : std::vector<std::vector<std::string>>{
           {"--csv", out},                                         // no input
           {"-i", in},                                             // no output
           {"-i", in, "--csv", out, "--preset", "fast"},           // unknown preset
           {"-i", in, "--csv", out, "--gauge", "three-pose"},      // unknown gauge
           {"-i", in, "--csv", out, "--weight-scale", "-1"},       // out of domain
           {"-i", in, "--csv", out, "--near", "2", "--far", "1"},  // near >= far
           {"-i", in, "--csv", out, "--gauge", "minimal", "--gauge-sigma-rot", "0.1"},
           {"-i", in, "--csv", out, "--bogus"}}) {
    const AppResult r = run(args);
    EXPECT_EQ(r.code, 2) << r.err;
    EXPECT_TRUE(contains(r.err, "--help")) << r.err;
    EXPECT_FALSE(std::filesystem::exists(out));
  }
  // An unknown enum name fails with the enum table's message (as the library and the Python
  // keywords give it), after the flag's name.
  for (const auto& [args, message] : std::vector<std::pair<std::vector<std::string>, std::string>>{
           {{"-i", in, "--csv", out, "--gauge", "three-pose"},
            "--gauge: unknown gauge 'three-pose', expected two-pose, minimal or droid"},
           {{"-i", in, "--csv", out, "--self-calibrate-nodes", "1"},
            "--self-calibrate-nodes: self-calibration nuisance nodes must be 0 (affine) or 2..8 "
            "(G x G bilinear tents)"},
           {{"-i", in, "--csv", out, "--self-calibrate-nodes", "abc"},
            "--self-calibrate-nodes: 'abc' is not an integer"},
           // A calibration option with the stated model would be ignored: refused.
           {{"-i", in, "--csv", out, "--stated-model", "--self-calibrate-nodes", "3"},
            "--self-calibrate-nodes applies to the self-calibrated covariance, not with "
            "--stated-model"},
           {{"-i", in, "--csv", out, "--stated-model", "--self-calibrate-depth-noise", "off"},
            "--self-calibrate-depth-noise applies to the self-calibrated covariance, not with "
            "--stated-model"},
           {{"-i", in, "--stated-model", "--edge-csv", out},
            "--edge-csv applies to the self-calibrated covariance, not with --stated-model"},
           // The study's methods and their options are not the product's.
           {{"-i", in, "--csv", out, "--self-calibrate-method", "vce"},
            "The following arguments were not expected: vce --self-calibrate-method"},
           // Integer options name a non-integer as such (CLI::Range said "not in range").
           {{"-i", in, "--csv", out, "--converge-iterations", "2.5"},
            "--converge-iterations: '2.5' is not an integer in 1..100000"},
           {{"-i", in, "--csv", out, "--converge-iterations", "99999999999999999999"},
            "--converge-iterations: '99999999999999999999' is not an integer in 1..100000"},
           {{"-i", in, "--csv", out, "--threads", "4097"}, "--threads: 4097 is not in 0..4096"},
           {{"-i", in, "--csv", out, "--threads", "-1"}, "--threads: -1 is not in 0..4096"},
           {{"-i", in, "--csv", out, "--self-calibrate-depth-noise", "maybe"},
            "--self-calibrate-depth-noise: maybe not in {on,off}"}}) {
    const AppResult r = run(args);
    EXPECT_EQ(r.code, 2) << r.err;
    EXPECT_TRUE(contains(r.err, "dba-covariance: " + message + "\n")) << r.err;
  }
}

// The run summary's noise-model line: the self-calibration (the default), the inflations, the
// time, the distance
// from the optimum (Gauss-Newton step in sigma and the gradient norm); a snapshot whose state is
// far from its optimum gets the warning naming it and --converge (which the Python suite and
// CalibratedSolve.* run).
TEST(CovarianceApp, SelfCalibrationSummaryLineAndTheFarFromTheOptimumWarning) {
  testing::TempDir dir;
  sim::SyntheticSnapshot syn = testing::tinySnapshot(1, 0);
  // The synthetic state (the truth, noisy flows) is far from its optimum at weight scale 400;
  // a free keyframe moved 5 mm makes sure of it.
  syn.snapshot.poses_cw(4, 0) += 0.005;
  io::saveSnapshotNpz(dir.file("a.npz"), syn.snapshot);
  const std::string in = dir.file("a.npz"), out = dir.file("o.csv");
  const AppResult r = run({"-i", in, "--csv", out, "--weight-scale", "400"});
  ASSERT_EQ(r.code, 0) << r.err;
  for (const char* part :
       {"dba-covariance: noise model: self-calibrated from the residuals (per-edge flow-error "
        "field): 1 snapshots, edge inflation median ",
        ", global residual scale ", " s per snapshot, Gauss-Newton step to the optimum median ",
        " sigma per sqrt(DoF) (gauge-reduced gradient norm median ", ", 1 far from their optimum"})
    EXPECT_TRUE(contains(r.noise, part)) << part << "\n" << r.noise;
  EXPECT_TRUE(contains(r.noise, "dba-covariance: warning: " + in +
                                    " (snapshot 0): the state is far from the optimum of its "
                                    "factors (one Gauss-Newton step is "))
      << r.noise;
  EXPECT_TRUE(contains(r.noise, "consider --converge")) << r.noise;
  // The stated model says so.
  const AppResult stated = run({"-i", in, "--csv", out, "--weight-scale", "400", "--stated-model"});
  ASSERT_EQ(stated.code, 0) << stated.err;
  EXPECT_EQ(stated.noise,
            "dba-covariance: noise model: stated (--stated-model: the snapshots' confidences "
            "times the weight scale, not calibrated)\n");
}

// --converge's iteration cap: kOptimumSolveIterations (the simulator's) by default, not the
// solver's 50; a solve that reaches it is reported with the cap and how to raise it. The tiny
// snapshot's flow noise (drawn at weight scale 4: σ = 0.5 px at confidence 1 on a 10-px-wide image,
// many inverse depths pushed to their bound) makes a badly curved cost that Levenberg-Marquardt
// needs over 200 iterations for (the cost's scale, the preset's, does not change its path).
TEST(CovarianceApp, ConvergeIterationsCapTheSolveAndAReachedCapIsReported) {
  testing::TempDir dir;
  const std::string in = dir.file("a.npz");
  writeSynthetic(in, 1, 0);
  auto csv = [&](const std::vector<std::string>& extra, const std::string& out) {
    std::vector<std::string> args = {"-i", in, "--csv", dir.file(out)};
    args.insert(args.end(), extra.begin(), extra.end());
    return run(args);
  };
  const AppResult capped = csv({"--converge-iterations", "5"}, "c5.csv");  // implies --converge
  ASSERT_EQ(capped.code, 0) << capped.err;
  EXPECT_TRUE(contains(capped.err, "dba-covariance: warning: " + in +
                                       " (snapshot 0): --converge: the DBA solve did not "
                                       "converge (5 iterations ("))
      << capped.err;
  EXPECT_TRUE(contains(capped.err,
                       ", max iterations; it reached the cap of 5 iterations "
                       "(--converge-iterations raises it))\n"))
      << capped.err;
  EXPECT_TRUE(contains(capped.err, "dba-covariance: --converge: 0 snapshots solved to convergence"))
      << capped.err;
  const AppResult solved = csv({"--converge", "--converge-iterations", "1000"}, "c1000.csv");
  ASSERT_EQ(solved.code, 0) << solved.err;
  EXPECT_TRUE(contains(solved.err, "dba-covariance: --converge: 1 snapshots solved to convergence"))
      << solved.err;
  EXPECT_FALSE(contains(solved.err, "warning")) << solved.err;
  // The default cap is kOptimumSolveIterations: the same output as that cap given, another than
  // the solver's own default of 50 (which does not converge here either).
  const AppResult by_default = csv({"--converge"}, "cd.csv");
  const AppResult fifty = csv({"--converge-iterations", "50"}, "c50.csv");
  const AppResult given =
      csv({"--converge-iterations", std::to_string(kOptimumSolveIterations)}, "cg.csv");
  ASSERT_EQ(by_default.code, 0) << by_default.err;
  ASSERT_EQ(fifty.code, 0) << fifty.err;
  ASSERT_EQ(given.code, 0) << given.err;
  EXPECT_TRUE(contains(fifty.err, "it reached the cap of 50 iterations")) << fifty.err;
  const AppResult one = csv({"--converge-iterations", "1"}, "c1.csv");
  EXPECT_TRUE(contains(one.err, "it reached the cap of 1 iteration (")) << one.err;
  EXPECT_EQ(readFile(dir.file("cd.csv")), readFile(dir.file("cg.csv")));
  EXPECT_NE(readFile(dir.file("cd.csv")), readFile(dir.file("c50.csv")));
  EXPECT_NE(readFile(dir.file("c5.csv")), readFile(dir.file("c1000.csv")));
  for (const char* bad : {"0", "-3", "many"}) {
    const AppResult r = csv({"--converge-iterations", bad}, "bad.csv");
    EXPECT_EQ(r.code, 2) << bad << "\n" << r.err;
    EXPECT_FALSE(std::filesystem::exists(dir.file("bad.csv"))) << bad;
  }
}

TEST(CovarianceApp, MissingInputsFailWithoutTouchingTheOutput) {
  testing::TempDir dir;
  std::filesystem::create_directory(dir.file("empty"));
  std::ofstream(dir.file("out.csv")) << "previous contents\n";
  for (const auto& in : {dir.file("nope.npz"), dir.file("empty"), dir.file("out.csv")}) {
    const AppResult r = run({"-i", in, "--csv", dir.file("out.csv")});
    // The output as input is refused as bad usage (io::OutputPlan), the others fail at reading.
    EXPECT_EQ(r.code, in == dir.file("out.csv") ? 2 : 1);
    EXPECT_TRUE(contains(r.err, in)) << r.err;
    EXPECT_EQ(readFile(dir.file("out.csv")), "previous contents\n");
  }
  EXPECT_EQ(dir.entries(), (std::vector<std::string>{"empty", "out.csv"}));  // no temporaries
}

TEST(CovarianceApp, UnwritableOutputIsAnError) {
  testing::TempDir dir;
  writeSynthetic(dir.file("a.npz"), 1, 0);
  const AppResult r = run({"-i", dir.file("a.npz"), "--csv", dir.file("no/such/dir/out.csv")});
  EXPECT_EQ(r.code, 1);
  EXPECT_TRUE(contains(r.err, "no/such/dir/out.csv")) << r.err;
}

// DBACOV_KERNEL_ISA picks the pixel kernel's variant (docs/development/performance.md); a value
// that is no variant is a usage error naming the variable (exit 2, before anything is read or
// written), not a silent fallback and not one error per snapshot.
TEST(CovarianceApp, KernelVariantFromTheEnvironment) {
  testing::TempDir dir;
  writeSynthetic(dir.file("a.npz"), 1, 0);
  const std::string app =
      std::string(DBACOV_BINARY_DIR) + "/bin/dba-covariance -q -i " + dir.file("a.npz") + " --csv ";
  const AppResult bad = testing::runCommand("DBACOV_KERNEL_ISA=avx9 " + app + dir.file("bad.csv"));
  EXPECT_EQ(bad.code, 2);
  EXPECT_TRUE(contains(bad.out, "dba-covariance: DBACOV_KERNEL_ISA=avx9: unknown pixel kernel"))
      << bad.out;
  EXPECT_FALSE(contains(bad.out, "snapshot")) << bad.out;
  EXPECT_FALSE(std::filesystem::exists(dir.file("bad.csv")));
  const AppResult help =
      testing::runCommand(std::string(DBACOV_BINARY_DIR) + "/bin/dba-covariance --help");
  EXPECT_TRUE(contains(help.out, "DBACOV_KERNEL_ISA=baseline|avx2")) << help.out;
  const AppResult base =
      testing::runCommand("DBACOV_KERNEL_ISA=baseline " + app + dir.file("base.csv"));
  EXPECT_EQ(base.code, 0) << base.out;
  EXPECT_TRUE(std::filesystem::exists(dir.file("base.csv")));
}

TEST(CovarianceApp, DpvoPresetIsRefusedForDroidSnapshotsBeforeAnyWork) {
  testing::TempDir dir;
  const AppResult r =
      testing::runCommand(std::string(DBACOV_BINARY_DIR) + "/bin/dba-covariance -i " +
                          dir.file("none.npz") + " --csv " + dir.file("k.csv") + " --preset dpvo");
  EXPECT_EQ(r.code, 2) << r.out;  // bad usage, named before the (missing) input is looked at
  EXPECT_TRUE(contains(r.out, "preset 'dpvo' is that of DPVO's patch graphs")) << r.out;
  EXPECT_FALSE(std::filesystem::exists(dir.file("k.csv")));
}

TEST(CovarianceApp, HelpDocumentsEveryOptionAndTheConventions) {
  // The real executable.
  const AppResult r =
      testing::runCommand(std::string(DBACOV_BINARY_DIR) + "/bin/dba-covariance --help");
  EXPECT_EQ(r.code, 0);
  for (const char* opt :
       {"--input", "--csv", "--preset", "--weight-scale", "--gauge", "--gauge-sigma-rot",
        "--gauge-sigma-trans", "--near", "--far", "--quiet", "T_wc", "[rho; phi]", "Exit status"})
    EXPECT_TRUE(contains(r.out, opt)) << "missing " << opt << " in\n" << r.out;
}

}  // namespace
}  // namespace dbacov
