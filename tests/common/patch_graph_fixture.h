// Small synthetic DPVO patch graphs for tests, and their dense DROID equivalents.
//
// makePatchGraph: N frames moving along x with small rotations, M patches per frame at distinct
// integer pixels of a W×H grid (so that a dense snapshot can hold the same factors), every patch
// seen by the frames at most `reach` away and by its own frame (a self-edge, as DPVO links them),
// targets = projection + noise, float-representable values (the dense snapshot stores floats).
// denseEquivalent: the same factors as a dense Snapshot, one edge per (ii, jj) pair, weights
// non-zero only at the patch pixels.
#pragma once

#include <algorithm>
#include <map>
#include <numeric>
#include <random>
#include <utility>
#include <vector>

#include "dbacov/core/dba_factor.h"
#include "dbacov/core/patch_graph.h"
#include "dbacov/core/se3.h"
#include "dbacov/core/snapshot.h"

namespace dbacov::testing {

inline constexpr int kPatchGridW = 24, kPatchGridH = 18;

inline double asFloat(double v) {
  return static_cast<double>(static_cast<float>(v));
}

inline PatchGraph makePatchGraph(unsigned seed, int N = 5, int M = 6, int reach = 2,
                                 double noise_px = 0.3) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> u(-1, 1);
  std::normal_distribution<double> gauss(0, 1);
  PatchGraph g;
  g.source = "synthetic patch graph";
  g.M = M;
  g.intrinsics = Eigen::Vector4d(20, 21, 11.5, 8.5);
  const PinholeIntrinsics K = PinholeIntrinsics::fromVector(g.intrinsics);
  g.poses_cw.resize(N, 7);
  std::vector<Eigen::Isometry3d> T_wc(N);
  for (int k = 0; k < N; ++k) {
    Vector6d xi;
    xi << 0.08 * k + 0.01 * u(rng), 0.02 * u(rng), 0.02 * u(rng), 0.03 * u(rng), 0.03 * u(rng),
        0.03 * u(rng);
    T_wc[k] = expSE3(xi);
    g.poses_cw.row(k) = poseToTQ(T_wc[k].inverse()).transpose();
    T_wc[k] = g.T_wc(k);  // as the graph stores it
  }
  std::vector<int> pixels((kPatchGridW - 4) * (kPatchGridH - 4));
  std::iota(pixels.begin(), pixels.end(), 0);
  for (int f = 0; f < N; ++f) {
    std::shuffle(pixels.begin(), pixels.end(), rng);
    for (int m = 0; m < M; ++m) {
      g.patch_x.push_back(2 + pixels[m] % (kPatchGridW - 4));
      g.patch_y.push_back(2 + pixels[m] / (kPatchGridW - 4));
      g.patch_d.push_back(asFloat(0.6 + 0.3 * u(rng)));
    }
  }
  for (int f = 0; f < N; ++f)
    for (int m = 0; m < M; ++m)
      for (int j = std::max(0, f - reach); j <= std::min(N - 1, f + reach); ++j) {
        const int p = f * M + m;
        const Eigen::Vector2d r0 = pixelFactorResidual(T_wc[f], T_wc[j], K, g.patch_x[p],
                                                       g.patch_y[p], g.patch_d[p], 0, 0);
        g.ii.push_back(f);
        g.jj.push_back(j);
        g.kk.push_back(p);
        for (int c = 0; c < 2; ++c) {
          g.target.push_back(asFloat(-r0[c] + noise_px * gauss(rng)));
          g.weight.push_back(asFloat(0.5 + 0.4 * u(rng)));
        }
      }
  g.t0 = 1;
  for (int k = 0; k < N; ++k) g.tstamp.push_back(3.0 * k);
  g.validate();
  return g;
}

inline Snapshot denseEquivalent(const PatchGraph& g) {
  Snapshot s;
  s.source = "dense equivalent of " + g.source;
  s.H = kPatchGridH;
  s.W = kPatchGridW;
  const int N = g.numFrames();
  const std::size_t HW = s.pixelsPerFrame();
  s.poses_cw = g.poses_cw;
  s.intrinsics = g.intrinsics;
  s.tstamp = g.tstamp;
  s.t0 = g.t0;
  s.disps.assign(N * HW, 0.5f);
  for (int p = 0; p < g.numPatches(); ++p)
    s.disps[(p / g.M) * HW + static_cast<std::size_t>(g.patch_y[p]) * s.W +
            static_cast<std::size_t>(g.patch_x[p])] = static_cast<float>(g.patch_d[p]);
  std::map<std::pair<int, int>, int> edge_of;
  for (int e = 0; e < g.numEdges(); ++e) {
    if (g.ii[e] == g.jj[e]) continue;
    const auto key = std::make_pair(static_cast<int>(g.ii[e]), static_cast<int>(g.jj[e]));
    auto [it, inserted] = edge_of.emplace(key, s.numEdges());
    if (inserted) {
      s.ii.push_back(key.first);
      s.jj.push_back(key.second);
      s.target.resize(s.target.size() + 2 * HW, 0.f);
      s.weight.resize(s.weight.size() + 2 * HW, 0.f);
    }
    const std::size_t pix = static_cast<std::size_t>(g.patch_y[g.kk[e]]) * s.W +
                            static_cast<std::size_t>(g.patch_x[g.kk[e]]);
    for (int c = 0; c < 2; ++c) {
      s.target[(2 * it->second + c) * HW + pix] = static_cast<float>(g.target[2 * e + c]);
      s.weight[(2 * it->second + c) * HW + pix] = static_cast<float>(g.weight[2 * e + c]);
    }
  }
  s.validate();
  return s;
}

}  // namespace dbacov::testing
