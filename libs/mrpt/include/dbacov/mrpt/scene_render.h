// Offscreen pictures of scenes (conventions §6) and the atomic scene and PNG files.
//
// Rendering uses mrpt::opengl::CFBORender, which needs no X server: it creates an EGL context
// through Mesa (Debian: libegl1 libegl-mesa0 libgl1-mesa-dri; scripts/setup.sh installs them).
//
// The view is MRPT's orbit camera (CCamera): it looks at `target` from
//   eye = target + distance · (cos el · cos az, cos el · sin az, sin el)
// in the display frame (+Z up), with a perspective of vertical field of view `fov_deg`.
// fitView() chooses it from the content: it looks across the main horizontal direction of the
// trajectory from behind the cameras' mean viewing direction (so frustums point into the picture),
// from 30° above, and moves back until every camera centre, frustum corner and ellipsoid box lies
// inside the picture with a 5% margin, below the band that the legend takes at the top. The point
// cloud is context: it is not fitted (the far walls of a room would make the estimate tiny) and may
// extend beyond the picture.
#pragma once

#include <memory>
#include <string>
#include <vector>

#include <mrpt/img/CImage.h>
#include <mrpt/opengl/COpenGLScene.h>
#include <Eigen/Core>

#include "dbacov/mrpt/scene.h"

namespace mrpt::opengl {
class CFBORender;
}

namespace dbacov::mrpt_bridge {

struct SceneView {
  Eigen::Vector3d target = Eigen::Vector3d::Zero();  ///< display frame
  double azimuth_deg = 45, elevation_deg = 30, distance = 10, fov_deg = 30;
  double clip_near = 0.1, clip_far = 1000;
};

/// The view that shows all of `content` (drawn with `style`) in a width×height picture.
SceneView fitView(const SceneContent& content, const SceneStyle& style, int width, int height);

/// Pixel coordinates (x right, y down, pixel centres at integers) of display point p in the
/// picture taken from `view` — the model of MRPT's projective camera that fitView() uses.
Eigen::Vector2d projectToPicture(const SceneView& view, int width, int height,
                                 const Eigen::Vector3d& p_display);

/// Sets the scene's main viewport camera and clip distances to `view` and enables the scene's
/// followCamera flag, so that SceneViewer3D opens the saved scene with this view (it ignores the
/// viewport camera without the flag). The viewer's canvas uses a 30° perspective, as fitView().
void applyView(mrpt::opengl::COpenGLScene& scene, const SceneView& view);

/// An offscreen renderer of a fixed picture size.
///
/// An EGL context is current on one thread only, and MRPT cannot render from any other thread
/// than the one that created its CFBORender. So every EGL/OpenGL call runs on a worker thread that
/// this object owns: render() may be called from any thread (calls are serialized), and it
/// releases the scene's OpenGL resources on the worker afterwards, so the scene may be destroyed
/// anywhere.
class SceneRenderer {
 public:
  /// Creates the EGL context. Throws InputError when offscreen rendering is unavailable (no EGL
  /// device), naming the packages it needs; std::invalid_argument for a size outside 16..8192.
  SceneRenderer(int width, int height);
  ~SceneRenderer();
  SceneRenderer(const SceneRenderer&) = delete;
  SceneRenderer& operator=(const SceneRenderer&) = delete;

  int width() const { return width_; }
  int height() const { return height_; }
  /// Renders the scene from `view` (RGB). Sets the main viewport's clip distances to the view's.
  /// Throws InputError when rendering fails.
  mrpt::img::CImage render(mrpt::opengl::COpenGLScene& scene, const SceneView& view);
  /// Renders and writes a PNG atomically. Throws InputError naming `path` on failure.
  void renderPng(mrpt::opengl::COpenGLScene& scene, const SceneView& view, const std::string& path);

 private:
  struct Worker;
  int width_, height_;
  std::unique_ptr<Worker> worker_;
};

/// Writes the scene (COpenGLScene::saveToFile's format, `.3Dscene`) atomically; it reloads with
/// COpenGLScene::loadFromFile and opens in SceneViewer3D. Throws InputError naming `path`.
void saveSceneFile(const mrpt::opengl::COpenGLScene& scene, const std::string& path);

/// Writes an image as PNG atomically (the extension of `path` does not matter). Throws InputError.
void savePng(const mrpt::img::CImage& image, const std::string& path);
/// The PNG file of an image, in memory. Throws InputError naming `path` (the file it is meant for).
std::vector<unsigned char> encodePng(const mrpt::img::CImage& image, const std::string& path);

}  // namespace dbacov::mrpt_bridge
