// dba-covariance --scene/--snapshot/--plots end to end, in-process: the files, their content
// against an independent selection of each keyframe's snapshot (recomputed here with the engine),
// usage errors (exit 2) and failures before any work (exit 1).
#include <stdlib.h>

#include <cstdio>
#include <filesystem>
#include <map>

#include <gtest/gtest.h>
#include <mrpt/opengl/CEllipsoid3D.h>
#include <mrpt/opengl/CFrustum.h>
#include <mrpt/opengl/CPointCloudColoured.h>

#include "app_runner.h"
#include "dbacov/app/covariance_app.h"
#include "dbacov/app/plots.h"
#include "dbacov/core/covariance.h"
#include "dbacov/core/criteria.h"
#include "dbacov/core/pipeline.h"
#include "dbacov/io/snapshot_npz.h"
#include "dbacov/mrpt/scene.h"
#include "temp_dir.h"
#include "viz_fixtures.h"

namespace dbacov {
namespace {

using testing::AppResult;

AppResult run(const std::vector<std::string>& args) {
  return testing::runApp(app::runCovarianceApp, "dba-covariance", args);
}

bool contains(const std::string& hay, const std::string& needle) {
  return hay.find(needle) != std::string::npos;
}

constexpr int kSnapshots = 3, kWindow = 5;

/// Writes the sliding-window sequence; returns the snapshots.
std::vector<Snapshot> writeSequence(const std::string& dir) {
  std::filesystem::create_directories(dir);
  std::vector<Snapshot> out;
  for (int s = 0; s < kSnapshots; ++s) {
    out.push_back(testing::windowSnapshot(s, kWindow));
    char name[32];
    std::snprintf(name, sizeof name, "/snap_%02d.npz", s);
    io::saveSnapshotNpz(dir + name, out.back());
  }
  return out;
}

/// What the pictures must show for a keyframe (documented rule, written as a backwards search):
/// the latest snapshot containing it outside its gauge, else the latest containing it.
struct Expected {
  int snapshot;
  int keyframe;
  bool gauge;
  Eigen::Isometry3d T_wc;
  Matrix6d Sigma;
  bool source;
};
std::map<double, Expected> expectedKeyframes(const std::vector<Snapshot>& snaps) {
  // The default pipeline (self-calibrated), as dba-covariance computes them.
  PipelineOptions p;
  p.engine.weight_scale = 4;
  std::vector<DbaCovariance> covs;
  for (const auto& s : snaps) covs.push_back(std::move(*computeCovariance(s, p).cov));
  std::map<double, Expected> out;
  for (std::size_t a = 0; a < snaps.size(); ++a)
    for (int k : covs[a].keyframes()) {
      const double t = snaps[a].tstamp[k];
      if (out.count(t)) continue;
      std::optional<Expected> last_any, last_free;
      for (int s = static_cast<int>(snaps.size()) - 1; s >= 0; --s) {
        for (int j : covs[s].keyframes()) {
          if (snaps[s].tstamp[j] != t) continue;
          const auto g = covs[s].gaugeKeyframes();
          const bool gauge = std::find(g.begin(), g.end(), j) != g.end();
          const auto src = covs[s].sourceKeyframes();
          const Expected e{s,
                           j,
                           gauge,
                           covs[s].T_wc(j),
                           covs[s].marginal(j),
                           std::find(src.begin(), src.end(), j) != src.end()};
          if (!last_any) last_any = e;
          if (!gauge && !last_free) last_free = e;
        }
      }
      out.emplace(t, last_free ? *last_free : *last_any);
    }
  return out;
}

double legendExaggeration(const mrpt::opengl::COpenGLScene& scene) {
  for (const auto& [id, m] : scene.getViewport()->getTextMessages().messages)
    if (const auto at = m.text.find("scaled x "); at != std::string::npos)
      return std::stod(m.text.substr(at + 9));
  return 0;
}

TEST(VisualApp, SceneAndPicturesShowEveryKeyframeFromItsChosenSnapshot) {
  testing::TempDir dir;
  const auto snaps = writeSequence(dir.file("in"));
  const AppResult r =
      run({"-i", dir.file("in"), "--weight-scale", "4", "--scene", dir.file("s.3Dscene"),
           "--snapshot", dir.file("s.png"), "--snapshot-every", "2", "--snapshot-size", "400x300",
           "--point-cloud", "-q"});
  ASSERT_EQ(r.code, 0) << r.err;
  EXPECT_EQ(dir.entries(), (std::vector<std::string>{"in", "s.3Dscene", "s.png", "s_000001.png"}));
  for (const char* png : {"s.png", "s_000001.png"}) {
    mrpt::img::CImage img;
    ASSERT_TRUE(img.loadFromFile(dir.file(png)));
    EXPECT_EQ(img.getWidth(), 400u);
    EXPECT_EQ(img.getHeight(), 300u);
    EXPECT_FALSE(testing::pixelBox(img, testing::isOrange).empty()) << png;
  }

  mrpt::opengl::COpenGLScene scene;
  ASSERT_TRUE(scene.loadFromFile(dir.file("s.3Dscene")));
  const auto expected = expectedKeyframes(snaps);
  EXPECT_EQ(testing::countWorldObjects<mrpt::opengl::CFrustum>(scene),
            static_cast<int>(expected.size()));
  const double f = legendExaggeration(scene);
  ASSERT_GT(f, 0);
  int ellipsoids = 0;
  for (const auto& [t, e] : expected) {
    char name[64];
    std::snprintf(name, sizeof name, "tstamp %g", t);
    ASSERT_TRUE(testing::worldObject<mrpt::opengl::CFrustum>(scene, std::string("frustum ") + name))
        << name;
    const auto ell =
        testing::worldObject<mrpt::opengl::CEllipsoid3D>(scene, std::string("ellipsoid ") + name);
    ASSERT_EQ(static_cast<bool>(ell), e.Sigma.norm() > 0) << name;
    if (!ell) continue;
    ++ellipsoids;
    const Eigen::Matrix3d R = e.T_wc.linear();
    const Eigen::Matrix3d M = 9 * f * f * R * e.Sigma.topLeftCorner<3, 3>() * R.transpose();
    for (const auto& p : testing::ellipsoidVertices(*ell)) {
      const Eigen::Vector3d d = p - e.T_wc.translation();
      ASSERT_NEAR(d.dot(M.inverse() * d), 1.0, 1e-3) << name;
    }
  }
  EXPECT_GT(ellipsoids, 3);
  const auto points = testing::worldObject<mrpt::opengl::CPointCloudColoured>(scene, "points");
  ASSERT_TRUE(points);
  EXPECT_GT(points->size(), 0u);
}

TEST(VisualApp, PlotsShowTheSequenceAndTheirValuesFollowTheChosenSnapshots) {
  testing::TempDir dir;
  const auto snaps = writeSequence(dir.file("in"));
  const AppResult r =
      run({"-i", dir.file("in"), "--weight-scale", "4", "--plots", dir.file("plots"), "-q"});
  ASSERT_EQ(r.code, 0) << r.err;
  const auto expected = expectedKeyframes(snaps);

  const auto lines = testing::splitLines(testing::readFile(dir.file("plots/keyframes.csv")));
  ASSERT_EQ(lines.size(), expected.size() + 1);
  EXPECT_EQ(lines[0], app::plotKeyframesCsvHeader());
  std::size_t row = 1;
  for (const auto& [t, e] : expected) {
    const auto f = testing::splitCsv(lines[row++]);
    ASSERT_EQ(f.size(), 15u);
    EXPECT_EQ(std::stod(f[1]), t);
    EXPECT_EQ(std::stod(f[2]), (*snaps[e.snapshot].timestamps_s)[e.keyframe]);
    EXPECT_EQ(std::stoi(f[3]), e.snapshot);  // the snapshots' ids are 0, 1, 2
    EXPECT_EQ(std::stoi(f[4]), e.keyframe);
    EXPECT_EQ(f[5], e.gauge ? "1" : "0");
    const UncertaintyCriteria c = computeCriteria(e.Sigma);
    if (std::isfinite(c.log10_det))
      EXPECT_NEAR(std::stod(f[6]), c.log10_det, 1e-9);
    else
      EXPECT_EQ(f[6], "-inf");
    for (int i = 0; i < 6; ++i)
      EXPECT_NEAR(std::stod(f[9 + i]), std::sqrt(e.Sigma(i, i)) * (i < 3 ? 1 : 180 / M_PI), 1e-12);
    if (e.source) {
      const std::string map = "plots/depth_sigma/" + std::to_string(e.snapshot) + "_" +
                              std::to_string(e.keyframe) + ".png";
      EXPECT_TRUE(std::filesystem::exists(dir.file(map))) << map;
    }
  }

  // The paper's figure: the curve on the left, both edge colours in the matrix on the right.
  mrpt::img::CImage fig;
  ASSERT_TRUE(fig.loadFromFile(dir.file("plots/covariance_covisibility.png")));
  const int W = static_cast<int>(fig.getWidth());
  auto colour = [](int R, int G, int B) {
    return [=](const testing::Rgb& p) {
      return std::abs(p.r - R) < 30 && std::abs(p.g - G) < 30 && std::abs(p.b - B) < 30;
    };
  };
  const testing::Box curve = testing::pixelBox(fig, colour(0x1f, 0x4e, 0x9c));
  const testing::Box current = testing::pixelBox(fig, colour(0xe6, 0x61, 0x01));
  ASSERT_FALSE(curve.empty());
  ASSERT_FALSE(current.empty());
  EXPECT_LT(curve.x0, W / 3) << "the log10 det curve is in the left panel";
  EXPECT_GT(current.x0, W / 2) << "the last snapshot's edges are in the matrix on the right";
  mrpt::img::CImage sig;
  ASSERT_TRUE(sig.loadFromFile(dir.file("plots/pose_sigmas.png")));
  EXPECT_FALSE(testing::pixelBox(sig, colour(0xd6, 0x27, 0x28)).empty());
}

TEST(VisualApp, EveryKeyframeFixedStillGivesEveryFigure) {
  // Two keyframes under the hard two-pose gauge: nothing to plot on the log10 det or sigma axes.
  testing::TempDir dir;
  io::saveSnapshotNpz(dir.file("two.npz"), testing::windowSnapshot(0, 2));
  const AppResult r = run({"-i", dir.file("two.npz"), "--weight-scale", "4", "--solver", "dense",
                           "--plots", dir.file("plots"), "--snapshot", dir.file("s.png"), "-q"});
  ASSERT_EQ(r.code, 0) << r.err;
  for (const char* f : {"plots/covariance_covisibility.png", "plots/pose_sigmas.png", "s.png"})
    EXPECT_TRUE(std::filesystem::exists(dir.file(f))) << f;
  const auto lines = testing::splitLines(testing::readFile(dir.file("plots/keyframes.csv")));
  ASSERT_EQ(lines.size(), 3u);
  EXPECT_EQ(testing::splitCsv(lines[1])[6], "-inf");
  EXPECT_EQ(testing::splitCsv(lines[2])[6], "-inf");
}

TEST(VisualApp, BadPictureOptionsAreUsageErrors) {
  testing::TempDir dir;
  writeSequence(dir.file("in"));
  const std::string in = dir.file("in");
  const std::vector<std::pair<std::vector<std::string>, std::string>> cases{
      {{"--scene", dir.file("s.3Dscene"), "--snapshot-every", "2"},
       "--snapshot-every needs --snapshot"},
      {{"--snapshot", dir.file("s.png"), "--snapshot-size", "640"}, "--snapshot-size"},
      {{"--snapshot", dir.file("s.png"), "--snapshot-size", "8x8"}, "--snapshot-size"},
      {{"--scene", dir.file("s.3Dscene"), "--scene-exaggeration", "-2"}, "--scene-exaggeration"},
      {{"--scene", dir.file("s.3Dscene"), "--scene-exaggeration", "big"}, "--scene-exaggeration"},
      {{"--csv", dir.file("k.csv"), "--point-cloud"}, "--point-cloud needs --scene or --snapshot"},
      {{"--scene", dir.file("s.3Dscene"), "--scene-up", "up"}, "--scene-up"},
      {{}, "--scene, --snapshot, --plots or --edge-csv"},
  };
  for (const auto& [extra, message] : cases) {
    std::vector<std::string> args{"-i", in};
    args.insert(args.end(), extra.begin(), extra.end());
    const AppResult r = run(args);
    EXPECT_EQ(r.code, 2) << message;
    EXPECT_TRUE(contains(r.err, message)) << r.err;
  }
  EXPECT_EQ(dir.entries(), std::vector<std::string>{"in"});
}

TEST(VisualApp, UnusableOutputsFailBeforeAnyWork) {
  testing::TempDir dir;
  writeSequence(dir.file("in"));
  AppResult r = run({"-i", dir.file("in"), "--scene", dir.file("missing/s.3Dscene"), "-q"});
  EXPECT_EQ(r.code, 1);
  EXPECT_TRUE(contains(r.err, dir.file("missing/s.3Dscene"))) << r.err;
  std::ofstream(dir.file("file")) << "x";
  r = run({"-i", dir.file("in"), "--plots", dir.file("file"), "-q"});
  EXPECT_EQ(r.code, 1);
  EXPECT_TRUE(contains(r.err, dir.file("file"))) << r.err;

  // Without gnuplot on PATH: the message names the Debian package.
  const std::string path = getenv("PATH") ? getenv("PATH") : "";
  setenv("PATH", dir.file("in").c_str(), 1);
  r = run({"-i", dir.file("in"), "--plots", dir.file("plots"), "-q"});
  setenv("PATH", path.c_str(), 1);
  EXPECT_EQ(r.code, 1);
  EXPECT_TRUE(contains(r.err, "gnuplot-nox")) << r.err;
  EXPECT_EQ(dir.entries(), (std::vector<std::string>{"file", "in"}));
}

TEST(VisualApp, HelpDocumentsThePictureOptionsAndConventions) {
  const AppResult r = run({"--help"});
  ASSERT_EQ(r.code, 0);
  for (const char* s :
       {"--scene", "--snapshot", "--snapshot-every", "--snapshot-size", "--scene-exaggeration",
        "--scene-up", "--point-cloud", "--point-stride", "--plots",
        "R_wc * Sigma[0:3,0:3] * R_wc^T", "not a\ngauge keyframe", "Exit status"})
    EXPECT_TRUE(contains(r.out, s)) << s;
}

}  // namespace
}  // namespace dbacov
