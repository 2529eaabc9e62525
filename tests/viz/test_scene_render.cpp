// Offscreen pictures and scene files: MRPT's renderer puts points where the documented camera
// model says (coloured spheres), a rendered scene is not blank, is framed by the fitted view and
// shows each kind of object in its colour where it should be, and the .3Dscene reloads with the
// same objects and geometry.
#include <filesystem>
#include <thread>

#include <gtest/gtest.h>
#include <mrpt/opengl/CEllipsoid3D.h>
#include <mrpt/opengl/CFrustum.h>
#include <mrpt/opengl/CSphere.h>

#include "dbacov/core/covariance.h"
#include "dbacov/mrpt/scene.h"
#include "dbacov/mrpt/scene_render.h"
#include "temp_dir.h"
#include "viz_fixtures.h"

namespace dbacov {
namespace {

using mrpt_bridge::SceneContent;
using mrpt_bridge::SceneStyle;
using mrpt_bridge::SceneView;

bool isBackground(const testing::Rgb& p) {
  return p.r > 245 && p.g > 245 && p.b > 245;
}
/// Neither background nor the light-grey grid.
bool isContent(const testing::Rgb& p) {
  const bool grey = std::abs(p.r - p.g) < 12 && std::abs(p.g - p.b) < 12 && p.r > 170;
  return !isBackground(p) && !grey;
}

TEST(SceneRender, MrptRendererFollowsTheDocumentedCameraModel) {
  mrpt::opengl::COpenGLScene scene;
  scene.getViewport()->setCustomBackgroundColor(mrpt::img::TColorf(1, 1, 1));
  const std::vector<std::pair<Eigen::Vector3d, mrpt::img::TColor>> marks{
      {{0, 0, 0}, {255, 0, 0}},
      {{1, 0, 0}, {0, 200, 0}},
      {{0, 1, 0}, {0, 0, 255}},
      {{0, 0, 1}, {255, 0, 255}}};
  for (const auto& [p, colour] : marks) {
    auto s = mrpt::opengl::CSphere::Create(0.03f);
    s->setLocation(p.x(), p.y(), p.z());
    s->setColor_u8(colour);
    scene.insert(s);
  }
  SceneView view;
  view.target = Eigen::Vector3d(0.2, 0.3, 0.1);
  view.azimuth_deg = 30;
  view.elevation_deg = 20;
  view.distance = 5;
  mrpt_bridge::SceneRenderer renderer(640, 400);
  const mrpt::img::CImage img = renderer.render(scene, view);
  ASSERT_EQ(img.getWidth(), 640u);
  for (const auto& [p, colour] : marks) {
    const mrpt::img::TColor c = colour;  // a structured binding is not capturable before C++20
    const testing::Box b = testing::pixelBox(img, [&](const testing::Rgb& q) {
      return std::abs(q.r - c.R) < 70 && std::abs(q.g - c.G) < 70 && std::abs(q.b - c.B) < 70 &&
             !isBackground(q);
    });
    ASSERT_FALSE(b.empty());
    const Eigen::Vector2d centre(0.5 * (b.x0 + b.x1), 0.5 * (b.y0 + b.y1));
    EXPECT_LT((centre - mrpt_bridge::projectToPicture(view, 640, 400, p)).norm(), 2.5)
        << p.transpose();
  }
}

/// Four keyframes of a real engine run with hand-made, clearly visible covariances.
SceneContent lineContent() {
  const Snapshot s = testing::windowSnapshot(0, 6);
  DbaOptions o = DbaOptions::droid();
  o.weight_scale = 4;
  const DbaCovariance cov(s, o);
  SceneContent c;
  c.intrinsics = s.intrinsics;
  c.W = s.W;
  c.H = s.H;
  for (int k : cov.keyframes())
    c.keyframes.push_back({std::to_string(k), cov.T_wc(k), cov.marginal(k), k < 2});
  for (int e = 0; e < s.numEdges(); ++e)
    if (s.ii[e] < s.jj[e])
      c.covisible.emplace_back(static_cast<int>(s.ii[e]), static_cast<int>(s.jj[e]));
  c.caption = {"test scene"};
  return c;
}

TEST(SceneRender, PictureIsFramedAndShowsEachKindOfObjectWhereItIs) {
  const SceneContent c = lineContent();
  SceneStyle style;
  const int W = 800, H = 500;
  auto scene = mrpt_bridge::buildScene(c, style);
  const SceneView view = mrpt_bridge::fitView(c, style, W, H);
  mrpt_bridge::SceneRenderer renderer(W, H);
  const mrpt::img::CImage img = renderer.render(*scene, view);

  // Content (not background, not grid) below the legend block: it fills the picture in at least
  // one direction and is not cut at the borders.
  const int legend_bottom = 150;
  const testing::Box b = testing::pixelBox(img, isContent, 0, legend_bottom);
  ASSERT_FALSE(b.empty()) << "blank picture";
  EXPECT_GT(std::max((b.x1 - b.x0) / double(W), (b.y1 - b.y0) / double(H - legend_bottom)), 0.6);
  EXPECT_GT(b.x0, 0.02 * W);
  EXPECT_LT(b.x1, 0.98 * W);
  EXPECT_LT(b.y1, 0.98 * H);

  // Colours where the objects are: red around the newest camera, orange ellipsoids around a
  // non-gauge camera, blue frustums, all in a window around the projected camera centre.
  const Eigen::Matrix3d R_dw = mrpt_bridge::displayRotation(style.up);
  auto near = [&](const Eigen::Isometry3d& T, bool (*colour)(const testing::Rgb&)) {
    const Eigen::Vector2d u = mrpt_bridge::projectToPicture(view, W, H, R_dw * T.translation());
    int n = 0;
    for (int y = std::max(0, int(u.y()) - 25); y < std::min(H, int(u.y()) + 25); ++y)
      for (int x = std::max(0, int(u.x()) - 25); x < std::min(W, int(u.x()) + 25); ++x)
        n += colour(testing::pixel(img, x, y)) ? 1 : 0;
    return n;
  };
  EXPECT_GT(near(c.keyframes.back().T_wc, testing::isRed), 10);
  EXPECT_GT(near(c.keyframes[3].T_wc, testing::isOrange), 20);
  EXPECT_GT(near(c.keyframes[3].T_wc, testing::isBlue), 5);
  EXPECT_EQ(near(c.keyframes[0].T_wc, testing::isOrange), 0)
      << "a hard-fixed keyframe has no ellipsoid";
  // The legend: dark text in the top-left corner.
  const testing::Box legend = testing::pixelBox(
      img, [](const testing::Rgb& p) { return p.r < 80 && p.g < 80 && p.b < 80; });
  EXPECT_LT(legend.y0, 40);
  EXPECT_LT(legend.x0, 40);
}

TEST(SceneRender, SceneFileReloadsWithTheSameObjectsAndGeometry) {
  testing::TempDir dir;
  const SceneContent c = lineContent();
  auto scene = mrpt_bridge::buildScene(c, SceneStyle{});
  mrpt_bridge::applyView(*scene, mrpt_bridge::fitView(c, SceneStyle{}, 640, 480));
  mrpt_bridge::saveSceneFile(*scene, dir.file("s.3Dscene"));
  EXPECT_EQ(dir.entries(), std::vector<std::string>{"s.3Dscene"});
  mrpt::opengl::COpenGLScene loaded;
  ASSERT_TRUE(loaded.loadFromFile(dir.file("s.3Dscene")));
  EXPECT_EQ(testing::countWorldObjects<mrpt::opengl::CFrustum>(loaded),
            static_cast<int>(c.keyframes.size()));
  EXPECT_EQ(testing::countWorldObjects<mrpt::opengl::CEllipsoid3D>(loaded),
            testing::countWorldObjects<mrpt::opengl::CEllipsoid3D>(*scene));
  for (const auto& kf : c.keyframes) {
    const auto a = testing::worldObject<mrpt::opengl::CEllipsoid3D>(*scene, "ellipsoid " + kf.name);
    const auto b = testing::worldObject<mrpt::opengl::CEllipsoid3D>(loaded, "ellipsoid " + kf.name);
    ASSERT_EQ(!a, !b);
    if (!a) continue;
    // The reloaded ellipsoid (poses are stored in single precision) still draws the 3-sigma
    // surface of the scaled world position covariance.
    const double f = mrpt_bridge::autoExaggeration(c, 3);
    const Eigen::Matrix3d M = 9 * f * f * mrpt_bridge::worldPositionCovariance(kf.T_wc, kf.Sigma);
    for (const auto& p : testing::ellipsoidVertices(*b)) {
      const Eigen::Vector3d d = p - kf.T_wc.translation();
      ASSERT_NEAR(d.dot(M.inverse() * d), 1.0, 1e-3);
    }
    EXPECT_EQ(a->getCovMatrix(), b->getCovMatrix());
  }
  EXPECT_EQ(loaded.getViewport()->getTextMessages().messages.size(),
            scene->getViewport()->getTextMessages().messages.size());
  EXPECT_NEAR(loaded.getViewport()->getCamera().getZoomDistance(),
              scene->getViewport()->getCamera().getZoomDistance(), 1e-6);
  // A missing directory: InputError naming the path, nothing written.
  EXPECT_THROW(mrpt_bridge::saveSceneFile(*scene, dir.file("no/such/dir/s.3Dscene")), InputError);
}

TEST(SceneRender, RendersFromAnyThread) {
  // EGL contexts are per thread and MRPT fails to render from another thread than its renderer's
  // creator: the renderer must hide that (dba-covariance consumes snapshots on pool threads).
  const SceneContent c = lineContent();
  auto scene = mrpt_bridge::buildScene(c, SceneStyle{});
  const SceneView view = mrpt_bridge::fitView(c, SceneStyle{}, 200, 120);
  mrpt_bridge::SceneRenderer renderer(200, 120);
  std::vector<int> red(3, 0);
  std::vector<std::thread> threads;
  for (int t = 0; t < 3; ++t)
    threads.emplace_back([&, t] {
      try {
        red[t] = testing::pixelBox(renderer.render(*scene, view), testing::isRed).count;
      } catch (const std::exception&) {
        red[t] = -1;
      }
    });
  for (auto& t : threads) t.join();
  for (int t = 0; t < 3; ++t) EXPECT_GT(red[t], 0) << "thread " << t;
  EXPECT_EQ(red[0], red[1]);
}

TEST(SceneRender, EmptyAndSingleKeyframeScenesRender) {
  mrpt_bridge::SceneRenderer renderer(160, 120);
  SceneContent c;
  c.caption = {"nothing processed"};
  for (int n = 0; n < 2; ++n) {
    auto scene = mrpt_bridge::buildScene(c, SceneStyle{});
    const mrpt::img::CImage img =
        renderer.render(*scene, mrpt_bridge::fitView(c, SceneStyle{}, 160, 120));
    EXPECT_FALSE(testing::pixelBox(img, [](const testing::Rgb& p) { return p.r < 80; }).empty())
        << n << " keyframes: the legend is drawn";
    c.keyframes.push_back(
        {"only", Eigen::Isometry3d::Identity(), 1e-4 * Matrix6d::Identity(), false});
  }
}

TEST(SceneRender, PngIsWrittenAtomicallyWithThePictureSize) {
  testing::TempDir dir;
  const SceneContent c = lineContent();
  auto scene = mrpt_bridge::buildScene(c, SceneStyle{});
  mrpt_bridge::SceneRenderer renderer(320, 200);
  renderer.renderPng(*scene, mrpt_bridge::fitView(c, SceneStyle{}, 320, 200), dir.file("p.png"));
  EXPECT_EQ(dir.entries(), std::vector<std::string>{"p.png"});
  mrpt::img::CImage img;
  ASSERT_TRUE(img.loadFromFile(dir.file("p.png")));
  EXPECT_EQ(img.getWidth(), 320u);
  EXPECT_EQ(img.getHeight(), 200u);
  EXPECT_THROW(mrpt_bridge::SceneRenderer(8, 200), std::invalid_argument);
}

}  // namespace
}  // namespace dbacov
