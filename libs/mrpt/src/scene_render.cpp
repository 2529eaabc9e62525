#include "dbacov/mrpt/scene_render.h"

#include <algorithm>
#include <cmath>
#include <condition_variable>
#include <exception>
#include <functional>
#include <mutex>
#include <stdexcept>
#include <thread>
#include <vector>

#include <mrpt/opengl/CFBORender.h>
#include <mrpt/opengl/CSetOfObjects.h>
#include <Eigen/Eigenvalues>
#include <opencv2/core.hpp>
#include <opencv2/imgcodecs.hpp>

#include "dbacov/io/atomic_file.h"
#include "dbacov/mrpt/mrpt_errors.h"
#include "scene_internal.h"

namespace dbacov::mrpt_bridge {
namespace {

/// Unit vectors of the camera of `view`: forward (eye → target), right and up on the picture.
struct ViewAxes {
  Eigen::Vector3d forward, right, up;
};
ViewAxes viewAxes(const SceneView& v) {
  const double az = v.azimuth_deg * M_PI / 180, el = v.elevation_deg * M_PI / 180;
  ViewAxes a;
  a.forward =
      -Eigen::Vector3d(std::cos(el) * std::cos(az), std::cos(el) * std::sin(az), std::sin(el));
  a.right = a.forward.cross(Eigen::Vector3d::UnitZ()).normalized();
  a.up = a.right.cross(a.forward);
  return a;
}

/// tan of the half field of view, vertical and horizontal.
std::pair<double, double> halfFov(const SceneView& v, int width, int height) {
  const double ty = std::tan(0.5 * v.fov_deg * M_PI / 180);
  return {ty, ty * width / height};
}

/// Releases the OpenGL resources of every object (on the rendering thread) and marks the objects
/// changed, so that a later render recreates them (MRPT does not after freeOpenGLResources alone).
void releaseGl(mrpt::opengl::COpenGLScene& scene) {
  scene.freeOpenGLResources();
  std::function<void(const mrpt::opengl::CRenderizable::Ptr&)> mark = [&](const auto& o) {
    if (!o) return;
    o->notifyChange();
    if (const auto set = std::dynamic_pointer_cast<mrpt::opengl::CSetOfObjects>(o))
      for (const auto& child : *set) mark(child);
  };
  if (const auto vp = scene.getViewport())  // the scenes here have only the main viewport
    for (const auto& o : *vp) mark(o);
}

}  // namespace

SceneView fitView(const SceneContent& content, const SceneStyle& style, int width, int height) {
  const SceneStyle s = detail::resolveStyle(content, style);
  const Eigen::Matrix3d R_dw = displayRotation(s.up);
  std::vector<Eigen::Vector3d> pts = detail::worldExtent(content, s, false);
  for (auto& p : pts) p = R_dw * p;
  SceneView view;
  if (pts.empty()) return view;

  // Horizontal main direction of the camera centres and their mean viewing direction.
  Eigen::Vector2d mean = Eigen::Vector2d::Zero(), forward = Eigen::Vector2d::Zero();
  for (const auto& kf : content.keyframes) {
    mean += (R_dw * kf.T_wc.translation()).head<2>();
    forward += (R_dw * kf.T_wc.linear().col(2)).head<2>();
  }
  const double n = static_cast<double>(std::max<std::size_t>(content.keyframes.size(), 1));
  mean /= n;
  Eigen::Matrix2d C = Eigen::Matrix2d::Zero();
  for (const auto& kf : content.keyframes) {
    const Eigen::Vector2d d = (R_dw * kf.T_wc.translation()).head<2>() - mean;
    C += d * d.transpose();
  }
  Eigen::Vector2d back;  // horizontal direction from the target towards the eye
  if (C.trace() > 1e-12 * (1 + mean.squaredNorm())) {
    const Eigen::Vector2d main =
        Eigen::SelfAdjointEigenSolver<Eigen::Matrix2d>(C).eigenvectors().col(1);
    back = Eigen::Vector2d(-main.y(), main.x());
    if (back.dot(forward) > 0) back = -back;
  } else {
    back = forward.norm() > 1e-9 ? Eigen::Vector2d(-forward.normalized()) : Eigen::Vector2d(1, 0);
  }
  // A quarter-profile: 20° off the perpendicular shows depth along the trajectory.
  view.azimuth_deg = std::atan2(back.y(), back.x()) * 180 / M_PI + 20;
  view.elevation_deg = 30;

  Eigen::Vector3d lo = pts[0], hi = pts[0];
  for (const auto& p : pts) {
    lo = lo.cwiseMin(p);
    hi = hi.cwiseMax(p);
  }
  view.target = 0.5 * (lo + hi);
  const ViewAxes a = viewAxes(view);
  auto [ty, tx] = halfFov(view, width, height);
  // The legend (top-left text) takes the top band of the picture: the content goes below it.
  const double legend_px =
      (1.5 * static_cast<double>(content.caption.size() + 4) + 1.0) * s.legend_px + 4;
  const double band = std::min(0.35, legend_px / height);  // tiny pictures: the legend overlaps
  const double t_right = 0.9 * tx, t_down = 0.9 * ty, t_up = 0.9 * ty * (1 - 2 * band);
  // A point at offset q from the target lies at depth d + q·forward; it is inside the picture when
  // |q·right| <= t_right·depth and −t_down·depth <= q·up <= t_up·depth.
  double d = 1e-9, span = (hi - lo).norm();
  for (const auto& p : pts) {
    const Eigen::Vector3d q = p - view.target;
    const double ahead = q.dot(a.forward), up = q.dot(a.up);
    d = std::max({d, std::abs(q.dot(a.right)) / t_right - ahead,
                  (up > 0 ? up / t_up : -up / t_down) - ahead});
  }
  if (!(span > 0)) span = 1;
  view.distance = std::max(d, 0.5 * span) * 1.02;
  view.clip_near = static_cast<float>(std::max(1e-6, 0.01 * view.distance));
  view.clip_far = static_cast<float>(100 * (view.distance + span));
  return view;
}

Eigen::Vector2d projectToPicture(const SceneView& view, int width, int height,
                                 const Eigen::Vector3d& p) {
  const ViewAxes a = viewAxes(view);
  const Eigen::Vector3d eye = view.target - view.distance * a.forward;
  const Eigen::Vector3d v = p - eye;
  const double f = 0.5 * height / halfFov(view, width, height).first;
  const double z = v.dot(a.forward);
  return {0.5 * width + f * v.dot(a.right) / z - 0.5, 0.5 * height - f * v.dot(a.up) / z - 0.5};
}

namespace {

/// Points `cam` (a camera that renders `scene`) as `view` says and sets the clip distances of the
/// scene's main viewport.
void aimCamera(mrpt::opengl::CCamera& cam, mrpt::opengl::COpenGLScene& scene,
               const SceneView& view) {
  cam.setProjectiveModel(true);
  cam.setProjectiveFOVdeg(static_cast<float>(view.fov_deg));
  cam.setPointingAt(static_cast<float>(view.target.x()), static_cast<float>(view.target.y()),
                    static_cast<float>(view.target.z()));
  cam.setZoomDistance(static_cast<float>(view.distance));
  cam.setAzimuthDegrees(static_cast<float>(view.azimuth_deg));
  cam.setElevationDegrees(static_cast<float>(view.elevation_deg));
  scene.getViewport()->setViewportClipDistances(static_cast<float>(view.clip_near),
                                                static_cast<float>(view.clip_far));
}

}  // namespace

void applyView(mrpt::opengl::COpenGLScene& scene, const SceneView& view) {
  aimCamera(scene.getViewport()->getCamera(), scene, view);
  // SceneViewer3D (MRPT 2.5.8, _DSceneViewerFrame::loadFromFile) takes the main viewport's camera
  // (pointing, zoom, azimuth, elevation) only when the scene's followCamera flag is set; without
  // it the viewer keeps its own camera (target 0, zoom 20): a sub-unit DROID scene is a speck.
  scene.enableFollowCamera(true);
}

/// The thread that owns the EGL context: runs one job at a time, posted by run().
struct SceneRenderer::Worker {
  std::mutex call;  // one render() at a time
  std::mutex m;
  std::condition_variable cv;
  std::function<void()> job;
  bool stop = false;
  std::unique_ptr<mrpt::opengl::CFBORender> fbo;
  std::thread thread;

  Worker() : thread([this] { loop(); }) {}
  ~Worker() {
    {
      std::lock_guard<std::mutex> lock(m);
      stop = true;
    }
    cv.notify_all();
    thread.join();
  }
  void loop() {
    std::unique_lock<std::mutex> lock(m);
    for (;;) {
      cv.wait(lock, [this] { return stop || job; });
      if (job) {
        job();
        job = nullptr;
        cv.notify_all();
      }
      if (stop) break;
    }
    fbo.reset();  // the context is destroyed on its own thread
  }
  /// Runs `f` on the worker and waits; rethrows what `f` threw.
  void run(const std::function<void()>& f) {
    std::lock_guard<std::mutex> one(call);
    std::exception_ptr error;
    std::unique_lock<std::mutex> lock(m);
    job = [&] {
      try {
        f();
      } catch (...) {
        error = std::current_exception();
      }
    };
    cv.notify_all();
    cv.wait(lock, [this] { return !job; });
    lock.unlock();
    if (error) std::rethrow_exception(error);
  }
};

SceneRenderer::SceneRenderer(int width, int height)
    : width_(width), height_(height), worker_(std::make_unique<Worker>()) {
  if (width < 16 || height < 16 || width > 8192 || height > 8192)
    throw std::invalid_argument("picture size must be within 16..8192 pixels per side");
  worker_->run([&] {
    try {
      worker_->fbo = std::make_unique<mrpt::opengl::CFBORender>(static_cast<unsigned>(width),
                                                                static_cast<unsigned>(height));
    } catch (const std::exception& e) {
      throw InputError("offscreen rendering (MRPT CFBORender through EGL) is unavailable: " +
                       conciseMrptMessage(e.what()) +
                       " (Debian packages libegl1 libegl-mesa0 libgl1-mesa-dri; scripts/setup.sh)");
    }
  });
}

SceneRenderer::~SceneRenderer() = default;

mrpt::img::CImage SceneRenderer::render(mrpt::opengl::COpenGLScene& scene, const SceneView& view) {
  mrpt::img::CImage image;
  worker_->run([&] {
    aimCamera(worker_->fbo->getCamera(scene), scene, view);
    try {
      worker_->fbo->render_RGB(scene, image);
      releaseGl(scene);
    } catch (const std::exception& e) {
      releaseGl(scene);
      throw InputError("offscreen rendering failed: " + conciseMrptMessage(e.what()));
    }
  });
  return image;
}

void SceneRenderer::renderPng(mrpt::opengl::COpenGLScene& scene, const SceneView& view,
                              const std::string& path) {
  savePng(render(scene, view), path);
}

void saveSceneFile(const mrpt::opengl::COpenGLScene& scene, const std::string& path) {
  io::AtomicOutputFile file(path);
  bool ok = false;
  try {
    ok = scene.saveToFile(file.writePath());
  } catch (const std::exception& e) {
    throw InputError(path + ": cannot write the scene: " + conciseMrptMessage(e.what()));
  }
  if (!ok) throw InputError(path + ": cannot write the scene");
  file.commit();
}

std::vector<unsigned char> encodePng(const mrpt::img::CImage& image, const std::string& path) {
  const cv::Mat& m = image.asCvMatRef();  // BGR, as OpenCV expects
  std::vector<unsigned char> png;
  if (m.empty() || !cv::imencode(".png", m, png, {cv::IMWRITE_PNG_COMPRESSION, 9}))
    throw InputError(path + ": cannot encode the picture as PNG");
  return png;
}

void savePng(const mrpt::img::CImage& image, const std::string& path) {
  const std::vector<unsigned char> png = encodePng(image, path);
  io::AtomicOutputFile file(path);
  file.write(png.data(), png.size());
  file.commit();
}

}  // namespace dbacov::mrpt_bridge
