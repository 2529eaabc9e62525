#include "dbacov/sim/scene.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <stdexcept>

namespace dbacov::sim {
namespace {

/// Entry distance s > 0 of the ray o + s·v into the box (slab method), or +inf when it misses or
/// starts inside.
double boxEntry(const Box& b, const Eigen::Vector3d& o, const Eigen::Vector3d& v) {
  double s_in = -std::numeric_limits<double>::infinity(),
         s_out = std::numeric_limits<double>::infinity();
  for (int axis = 0; axis < 3; ++axis) {
    if (std::abs(v[axis]) < 1e-12) {
      if (o[axis] <= b.min_corner[axis] || o[axis] >= b.max_corner[axis])
        return std::numeric_limits<double>::infinity();
      continue;
    }
    double s0 = (b.min_corner[axis] - o[axis]) / v[axis],
           s1 = (b.max_corner[axis] - o[axis]) / v[axis];
    if (s0 > s1) std::swap(s0, s1);
    s_in = std::max(s_in, s0);
    s_out = std::min(s_out, s1);
  }
  return s_in <= s_out && s_in > 1e-9 ? s_in : std::numeric_limits<double>::infinity();
}

}  // namespace

double RoomScene::inverseDepth(const Eigen::Isometry3d& T_wc, double xn, double yn) const {
  // Ray o + s·v (s = depth along the optical axis, since v's camera z component is 1).
  const Eigen::Vector3d o = T_wc.translation();
  const Eigen::Vector3d v = T_wc.linear() * Eigen::Vector3d(xn, yn, 1.0);
  double s_min = std::numeric_limits<double>::infinity();
  for (int axis = 0; axis < 3; ++axis) {
    if (std::abs(v[axis]) < 1e-12) continue;
    for (double wall : {min_corner[axis], max_corner[axis]}) {
      const double s = (wall - o[axis]) / v[axis];
      if (s > 1e-9) s_min = std::min(s_min, s);
    }
  }
  for (const Box& b : boxes) s_min = std::min(s_min, boxEntry(b, o, v));
  return std::isfinite(s_min) ? 1.0 / s_min : 0.0;
}

void RoomScene::validate() const {
  if (!(min_corner.array() < max_corner.array()).all())
    throw std::invalid_argument(
        "scene: the room's min corner must be below its max corner on every axis");
  for (std::size_t i = 0; i < boxes.size(); ++i) {
    const Box& b = boxes[i];
    if (!(b.min_corner.array() < b.max_corner.array()).all())
      throw std::invalid_argument("scene: box " + std::to_string(i) +
                                  ": min corner must be below max corner on every axis");
    if (!(b.min_corner.array() >= min_corner.array()).all() ||
        !(b.max_corner.array() <= max_corner.array()).all())
      throw std::invalid_argument("scene: box " + std::to_string(i) + " reaches outside the room");
  }
}

bool RoomScene::isFree(const Eigen::Vector3d& p) const {
  if (!(p.array() > min_corner.array()).all() || !(p.array() < max_corner.array()).all())
    return false;
  for (const Box& b : boxes)
    if ((p.array() >= b.min_corner.array()).all() && (p.array() <= b.max_corner.array()).all())
      return false;
  return true;
}

}  // namespace dbacov::sim
