// Fixtures of the picture tests: sliding-window snapshot sequences, scene objects by name, PNGs.
#pragma once

#include <algorithm>
#include <cstdint>
#include <string>
#include <vector>

#include <mrpt/img/CImage.h>
#include <mrpt/opengl/CEllipsoid3D.h>
#include <mrpt/opengl/COpenGLScene.h>
#include <mrpt/opengl/CSetOfObjects.h>
#include <mrpt/poses/CPose3D.h>
#include <Eigen/Geometry>

#include "dbacov/sim/synthetic_snapshot.h"

#include "fixtures.h"

namespace dbacov::testing {

/// Snapshot s of a DROID-like sliding window (like simul-dba): keyframes 0..s+window−1 in
/// `poses`, edges among the last `window`; 8×10 grid, keyframe times at 20 Hz.
inline Snapshot windowSnapshot(int s, int window = 5, std::uint64_t seed = 3) {
  sim::SyntheticSnapshotConfig c =
      gridConfig(seed + static_cast<std::uint64_t>(s), s + window, 8, 10);
  c.first_keyframe = s;
  c.id = s;
  Snapshot snap = sim::generateSyntheticSnapshot(c).snapshot;
  deriveKeyframeTimes(snap, 20.0);
  return snap;
}

/// The object named `name` inside the scene's "world" set (nullptr if absent).
template <class T>
typename T::Ptr worldObject(const mrpt::opengl::COpenGLScene& scene, const std::string& name) {
  auto world = std::dynamic_pointer_cast<mrpt::opengl::CSetOfObjects>(
      const_cast<mrpt::opengl::COpenGLScene&>(scene).getByName("world"));
  if (!world) return nullptr;
  for (const auto& o : *world)
    if (o && o->getName() == name) return std::dynamic_pointer_cast<T>(o);
  return nullptr;
}

/// Number of objects of class T inside the "world" set.
template <class T>
int countWorldObjects(const mrpt::opengl::COpenGLScene& scene) {
  auto world = std::dynamic_pointer_cast<mrpt::opengl::CSetOfObjects>(
      const_cast<mrpt::opengl::COpenGLScene&>(scene).getByName("world"));
  int n = 0;
  if (world)
    for (const auto& o : *world) n += std::dynamic_pointer_cast<T>(o) ? 1 : 0;
  return n;
}

inline Eigen::Isometry3d toIsometry(const mrpt::poses::CPose3D& p) {
  Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
  const auto& R = p.getRotationMatrix();
  for (int r = 0; r < 3; ++r) {
    T.translation()[r] = p.m_coords[r];
    for (int c = 0; c < 3; ++c) T.linear()(r, c) = R(r, c);
  }
  return T;
}

/// Vertices of an ellipsoid as MRPT generates them for rendering, in the coordinates of its
/// parent (object pose and scale applied).
inline std::vector<Eigen::Vector3d> ellipsoidVertices(const mrpt::opengl::CEllipsoid3D& e) {
  e.renderUpdateBuffers();  // CPU-side geometry; no OpenGL context needed
  const Eigen::Isometry3d P = toIsometry(e.getPoseRef());
  std::vector<Eigen::Vector3d> out;
  for (const auto& v : e.shaderWireframeVertexPointBuffer())
    out.push_back(P *
                  Eigen::Vector3d(v.x * e.getScaleX(), v.y * e.getScaleY(), v.z * e.getScaleZ()));
  return out;
}

/// RGB of pixel (x, y) of an image loaded by MRPT (stored BGR).
struct Rgb {
  int r, g, b;
};
inline Rgb pixel(const mrpt::img::CImage& img, int x, int y) {
  const auto* p = img.ptr<std::uint8_t>(x, y);
  return {p[2], p[1], p[0]};
}

/// Bounding box of the pixels for which `keep` holds; {−1,…} when none.
struct Box {
  int x0 = -1, y0 = -1, x1 = -1, y1 = -1;
  int count = 0;
  bool empty() const { return count == 0; }
};
template <class Pred>
Box pixelBox(const mrpt::img::CImage& img, Pred keep, int x_from = 0, int y_from = 0) {
  Box b;
  const int W = static_cast<int>(img.getWidth()), H = static_cast<int>(img.getHeight());
  for (int y = y_from; y < H; ++y)
    for (int x = x_from; x < W; ++x)
      if (keep(pixel(img, x, y))) {
        if (b.count++ == 0) {
          b.x0 = b.x1 = x;
          b.y0 = b.y1 = y;
        }
        b.x0 = std::min(b.x0, x);
        b.x1 = std::max(b.x1, x);
        b.y0 = std::min(b.y0, y);
        b.y1 = std::max(b.y1, y);
      }
  return b;
}

inline bool isRed(const Rgb& p) {
  return p.r > 150 && p.g < 100 && p.b < 100;
}
inline bool isOrange(const Rgb& p) {
  return p.r > 150 && p.g > 60 && p.g < 190 && p.b < 90;
}
inline bool isBlue(const Rgb& p) {
  return p.b > 120 && p.r < 110 && p.b > p.g + 30;
}

}  // namespace dbacov::testing
