// Linearization of DPVO's patch graph (linearization.h): the DBA factor of conventions §2 at each
// edge's patch centre, one depth variable per patch, eliminated per patch.
#include <algorithm>

#include "dbacov/core/dba_factor.h"
#include "dbacov/core/linearization.h"
#include "dbacov/core/parallel.h"
#include "source_system.h"

namespace dbacov {
namespace {

/// What the graph's geometry gives every frame: the slots and the poses.
struct Geometry {
  const PatchGraph& g;
  const DbaOptions& o;
  PinholeIntrinsics K;
  std::vector<int> slot_of;
  std::vector<Eigen::Isometry3d> T_cw, T_wc;
};

/// DPVO's BA drops an edge beyond its residual and image bounds (options.max_residual,
/// options.image_margin); the depth rule is keepPixelFactor's.
bool keepEdge(const Geometry& geo, const PixelFactorLinearization& f, double tx, double ty) {
  const DbaOptions& o = geo.o;
  if (o.max_residual && !(f.r.norm() < *o.max_residual)) return false;
  if (o.image_margin) {
    const double m = *o.image_margin, px = tx - f.r.x(), py = ty - f.r.y();
    if (!(px > -m && py > -m && px < 2 * geo.K.cx + m && py < 2 * geo.K.cy + m)) return false;
  }
  return true;
}

/// Linearizes the patches of frame `src` whose edges (non-self) are listed in `edges` by patch:
/// edges[m] are the edges of patch m of the frame.
detail::SourceSystem linearizeFrame(const Geometry& geo, int src,
                                    const std::vector<std::vector<int>>& edges,
                                    bool keep_depth_terms) {
  const PatchGraph& g = geo.g;
  detail::SourceSystem res;
  res.touched.push_back(geo.slot_of[src]);
  auto position = [&](int slot) {
    const auto it = std::find(res.touched.begin(), res.touched.end(), slot);
    if (it != res.touched.end()) return static_cast<int>(it - res.touched.begin());
    res.touched.push_back(slot);
    return static_cast<int>(res.touched.size()) - 1;
  };
  for (const std::vector<int>& pe : edges)
    for (int e : pe) position(geo.slot_of[g.jj[e]]);
  const int T = static_cast<int>(res.touched.size());
  res.Hloc = Eigen::MatrixXd::Zero(6 * T, 6 * T);
  res.g_loc = Eigen::VectorXd::Zero(6 * T);
  Eigen::MatrixXd schur = Eigen::MatrixXd::Zero(6 * T, 6 * T);  // Σ_k b_k b_kᵀ / h_k
  Eigen::VectorXd schur_g = Eigen::VectorXd::Zero(6 * T);
  std::vector<Eigen::VectorXd> kept_b;

  for (int m = 0; m < static_cast<int>(edges.size()); ++m) {
    if (edges[m].empty()) continue;
    const int p = src * g.M + m;
    const double x = g.patch_x[p], y = g.patch_y[p], d = g.patch_d[p];
    Eigen::VectorXd b = Eigen::VectorXd::Zero(6 * T);
    double h = 0, gd = 0;
    for (int e : edges[m]) {
      const int t = position(geo.slot_of[g.jj[e]]);
      const Eigen::Isometry3d T_ji = geo.T_cw[g.jj[e]] * geo.T_wc[src];
      const double tx = g.target[2 * e], ty = g.target[2 * e + 1];
      const Eigen::Vector3d Y = transferPoint(T_ji.linear(), T_ji.translation(), geo.K, x, y, d);
      PixelFactorLinearization f;
      if (keepPixelFactor(geo.o, d, Y.z()))
        linearizePixelFactor(T_ji.linear(), T_ji.translation(), geo.K, x, y, d, tx, ty, &f);
      if (!keepPixelFactor(geo.o, d, Y.z()) || !keepEdge(geo, f, tx, ty)) {
        ++res.stats.factors_filtered;
        continue;
      }
      const Eigen::Vector2d w(geo.o.weight_scale * g.weight[2 * e],
                              geo.o.weight_scale * g.weight[2 * e + 1]);
      if (w.isZero(0)) continue;
      ++res.stats.factors_used;
      const auto W = w.asDiagonal();
      const Eigen::Matrix<double, 6, 2> JiW = f.J_i.transpose() * W, JjW = f.J_j.transpose() * W;
      res.Hloc.block<6, 6>(0, 0) += JiW * f.J_i;
      res.Hloc.block<6, 6>(6 * t, 6 * t) += JjW * f.J_j;
      res.Hloc.block<6, 6>(0, 6 * t) += JiW * f.J_j;
      res.Hloc.block<6, 6>(6 * t, 0) += JjW * f.J_i;
      res.g_loc.segment<6>(0) += JiW * f.r;
      res.g_loc.segment<6>(6 * t) += JjW * f.r;
      b.segment<6>(0) += JiW * f.J_d;
      b.segment<6>(6 * t) += JjW * f.J_d;
      h += f.J_d.dot(W * f.J_d);
      gd += f.J_d.dot(W * f.r);
      res.stats.chi2 += f.r.dot(W * f.r);
    }
    if (h > geo.o.depth_info_eps) {
      ++res.stats.depths_used;
      schur.selfadjointView<Eigen::Lower>().rankUpdate(b, -1.0 / h);
      schur_g -= b * (gd / h);
      if (keep_depth_terms) {
        res.depth.pixel.push_back(m);
        res.depth.h.push_back(h);
        res.depth.g.push_back(gd);
        kept_b.push_back(std::move(b));
      }
    } else if (h > 0) {
      ++res.stats.depths_unobservable;
    }
  }
  res.Hloc = 0.5 * (res.Hloc + res.Hloc.transpose()).eval();
  schur.triangularView<Eigen::StrictlyUpper>() = schur.transpose();
  res.Sloc = res.Hloc + schur;
  res.gS_loc = res.g_loc + schur_g;
  if (keep_depth_terms) {
    res.depth.source_slot = res.touched[0];
    res.depth.touched = res.touched;
    res.depth.B.resize(6 * T, static_cast<Eigen::Index>(kept_b.size()));
    for (std::size_t c = 0; c < kept_b.size(); ++c) res.depth.B.col(c) = kept_b[c];
  }
  return res;
}

}  // namespace

DbaNormalEquations linearizePatchGraph(const PatchGraph& g, const DbaOptions& o,
                                       bool keep_depth_terms) {
  DbaNormalEquations ne;
  ne.keyframes = g.graphFrames();
  const int n = static_cast<int>(ne.keyframes.size());
  Geometry geo{g, o, PinholeIntrinsics::fromVector(g.intrinsics), {}, {}, {}};
  geo.slot_of.assign(g.numFrames(), -1);
  geo.T_cw.resize(g.numFrames());
  geo.T_wc.resize(g.numFrames());
  for (int a = 0; a < n; ++a) {
    const int k = ne.keyframes[a];
    geo.slot_of[k] = a;
    geo.T_cw[k] = g.T_cw(k);
    geo.T_wc[k] = geo.T_cw[k].inverse();
  }
  ne.slot_of = geo.slot_of;
  ne.Hpp = BlockSymmetricMatrix(n);
  ne.S = BlockSymmetricMatrix(n);
  ne.g_p = Eigen::VectorXd::Zero(6 * n);
  ne.g_S = Eigen::VectorXd::Zero(6 * n);
  for (int a = 0; a < n; ++a) ne.S.at(a, a);  // every slot has a diagonal block, even if zero

  // The edges of every patch, grouped by source frame (in edge order within a patch).
  std::vector<std::vector<std::vector<int>>> by_frame(g.numFrames());
  for (int e = 0; e < g.numEdges(); ++e) {
    if (g.ii[e] == g.jj[e]) continue;  // a self-edge: identity transform, no information
    auto& frame = by_frame[g.ii[e]];
    if (frame.empty()) frame.resize(g.M);
    frame[g.kk[e] % g.M].push_back(static_cast<int>(e));
  }
  std::vector<int> sources;
  for (int k = 0; k < g.numFrames(); ++k)
    if (!by_frame[k].empty()) sources.push_back(k);
  std::vector<detail::SourceSystem> results(sources.size());
  parallelFor(sources.size(), [&](std::size_t i) {
    results[i] = linearizeFrame(geo, sources[i], by_frame[sources[i]], keep_depth_terms);
  });

  detail::mergeSourceSystems(results, keep_depth_terms, ne);
  return ne;
}

}  // namespace dbacov
