// The saved .3Dscene of the shared DROID snapshot opens framed in SceneViewer3D.
//
// What MRPT 2.5.8's SceneViewer3D does on load (apps/SceneViewer3D/_DSceneViewerMain.cpp,
// _DSceneViewerFrame::loadFromFile): it deserializes the scene; when the scene's followCamera flag
// is set it takes pointing, zoom distance, elevation and azimuth from a CCamera object in the
// scene, else from the main viewport's camera, into its canvas (a CGlCanvasBase); without the flag
// it keeps its own camera (target 0, zoom distance 20). Before each frame the canvas writes its
// camera parameters into the main viewport's camera (CGlCanvasBase::updateCameraParams: also
// projective, FOV 30°) and renders the scene. This test does exactly that with MRPT's own headless
// canvas class, on the file reloaded from disk, and renders the result offscreen with CFBORender.
#include <filesystem>

#include <gtest/gtest.h>
#include <mrpt/gui/CGlCanvasBase.h>
#include <mrpt/opengl/CCamera.h>
#include <mrpt/opengl/CFBORender.h>
#include <mrpt/opengl/COpenGLScene.h>

#include "app_runner.h"
#include "dbacov/app/covariance_app.h"
#include "temp_dir.h"
#include "viz_fixtures.h"

namespace dbacov {
namespace {

const std::string kShared = std::string(DBACOV_SHARED_DATA_DIR) + "/droid_window_0055.npz";

/// SceneViewer3D's camera handling on load, through MRPT's canvas class.
void openAsSceneViewer3D(mrpt::opengl::COpenGLScene& scene, mrpt::gui::CGlCanvasBase& canvas) {
  canvas.setCameraPointing(0, 0, 0);  // the viewer's initial camera
  canvas.setZoomDistance(20);
  if (scene.followCamera()) {
    auto cam = scene.getByClass<mrpt::opengl::CCamera>();
    const bool in_scene = static_cast<bool>(cam);
    if (!in_scene) cam = mrpt::opengl::CCamera::Create(scene.getViewport("main")->getCamera());
    canvas.setCameraPointing(cam->getPointingAtX(), cam->getPointingAtY(), cam->getPointingAtZ());
    canvas.setZoomDistance(cam->getZoomDistance());
    canvas.setElevationDegrees(cam->getElevationDegrees());
    canvas.setAzimuthDegrees(cam->getAzimuthDegrees());
    if (in_scene) scene.removeObject(cam);
  }
}

/// Bounding box of the pixels that are not the white background, below the legend band.
testing::Box contentBox(const mrpt::img::CImage& img, int top) {
  return testing::pixelBox(
      img, [](const testing::Rgb& p) { return !(p.r > 245 && p.g > 245 && p.b > 245); }, 0, top);
}

TEST(SceneViewer, SavedRealDataSceneOpensFramedInSceneViewer3D) {
  if (!std::filesystem::exists(kShared)) GTEST_SKIP() << "missing " << kShared;
  testing::TempDir dir;
  const auto r = testing::runApp(app::runCovarianceApp, "dba-covariance",
                                 {"-i", kShared, "--scene", dir.file("s.3Dscene"), "-q"});
  ASSERT_EQ(r.code, 0) << r.err;

  mrpt::opengl::COpenGLScene scene;
  ASSERT_TRUE(scene.loadFromFile(dir.file("s.3Dscene")));
  EXPECT_TRUE(scene.followCamera()) << "SceneViewer3D would ignore the scene's camera";

  const int W = 700, H = 600;  // graph-slam --view's window; SceneViewer3D is resizable
  mrpt::opengl::CFBORender fbo(W, H);
  auto render = [&](const mrpt::gui::CGlCanvasBase& canvas) {
    mrpt::opengl::CCamera& cam = canvas.updateCameraParams(scene.getViewport("main")->getCamera());
    fbo.setCamera(scene, cam);
    mrpt::img::CImage img;
    fbo.render_RGB(scene, img);
    return img;
  };
  const int legend_bottom = 150;  // the legend's text lines at the top left

  mrpt::gui::CGlCanvasBaseHeadless viewer;
  openAsSceneViewer3D(scene, viewer);
  EXPECT_LT(viewer.getZoomDistance(), 5) << "a DROID scene is a fraction of a unit across";
  const testing::Box b = contentBox(render(viewer), legend_bottom);
  ASSERT_FALSE(b.empty()) << "blank view";
  const double fill =
      std::max((b.x1 - b.x0) / double(W), (b.y1 - b.y0) / double(H - legend_bottom));
  EXPECT_GT(fill, 0.5) << "content box " << b.x0 << ".." << b.x1 << " x " << b.y0 << ".." << b.y1;

  // Control: the viewer's own camera (what it showed before the flag) makes the scene a speck,
  // so the measure above can fail.
  mrpt::gui::CGlCanvasBaseHeadless stock;
  stock.setCameraPointing(0, 0, 0);
  stock.setZoomDistance(20);
  const testing::Box s = contentBox(render(stock), legend_bottom);
  ASSERT_FALSE(s.empty());
  EXPECT_LT(std::max((s.x1 - s.x0) / double(W), (s.y1 - s.y0) / double(H - legend_bottom)), 0.1);
}

}  // namespace
}  // namespace dbacov
