#include "dbacov/sim/covisibility.h"

#include <algorithm>
#include <cmath>
#include <set>

namespace dbacov::sim {

double viewOverlap(const RoomScene& scene, const PinholeIntrinsics& K, int H, int W,
                   const Eigen::Isometry3d& T_wc_i, const Eigen::Isometry3d& T_wc_j) {
  const Eigen::Isometry3d T_ji = T_wc_j.inverse() * T_wc_i;
  const int step = std::max(1, std::min(H, W) / 8);
  int inside = 0, total = 0;
  for (int y = step / 2; y < H; y += step)
    for (int x = step / 2; x < W; x += step) {
      const double xn = (x - K.cx) / K.fx, yn = (y - K.cy) / K.fy;
      const double d = scene.inverseDepth(T_wc_i, xn, yn);
      ++total;
      if (!(d > 0)) continue;
      const Eigen::Vector3d Y = T_ji * (Eigen::Vector3d(xn, yn, 1.0) / d);
      if (Y.z() < 0.1) continue;
      const double u = K.fx * Y.x() / Y.z() + K.cx, v = K.fy * Y.y() / Y.z() + K.cy;
      inside += u >= 0 && u <= W - 1 && v >= 0 && v <= H - 1;
    }
  return total ? static_cast<double>(inside) / total : 0.0;
}

std::vector<std::pair<int, int>> selectEdges(const std::vector<Eigen::Isometry3d>& T_wc, int first,
                                             const RoomScene& scene, const PinholeIntrinsics& K,
                                             int H, int W, const CovisibilityConfig& c) {
  const int n = static_cast<int>(T_wc.size());
  std::set<std::pair<int, int>> pairs;  // unordered pairs, i < j
  for (int i = first; i < n; ++i)
    for (int j = i + 1; j < n && j - i <= c.edge_radius; ++j) pairs.emplace(i, j);
  if (c.overlap_threshold > 0) {
    for (int i = first; i < n; ++i) {
      std::vector<std::pair<double, int>> cand;  // (overlap, j)
      for (int j = first; j < n; ++j) {
        if (std::abs(i - j) <= c.edge_radius) continue;
        if ((T_wc[i].translation() - T_wc[j].translation()).norm() > c.candidate_distance) continue;
        if (T_wc[i].linear().col(2).dot(T_wc[j].linear().col(2)) < std::cos(M_PI / 4)) continue;
        const double o = std::min(viewOverlap(scene, K, H, W, T_wc[i], T_wc[j]),
                                  viewOverlap(scene, K, H, W, T_wc[j], T_wc[i]));
        if (o >= c.overlap_threshold) cand.emplace_back(o, j);
      }
      std::sort(cand.rbegin(), cand.rend());
      for (int q = 0; q < static_cast<int>(cand.size()) && q < c.max_overlap_edges; ++q)
        pairs.emplace(std::min(i, cand[q].second), std::max(i, cand[q].second));
    }
  }
  std::vector<std::pair<int, int>> edges;
  for (const auto& [i, j] : pairs) {
    edges.emplace_back(i, j);
    edges.emplace_back(j, i);
  }
  std::sort(edges.begin(), edges.end());
  return edges;
}

}  // namespace dbacov::sim
