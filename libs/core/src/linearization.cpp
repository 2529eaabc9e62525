#include "dbacov/core/linearization.h"

#include <algorithm>

#include "dbacov/core/dba_factor.h"

namespace dbacov {
namespace {

struct EdgeRef {
  int edge;    ///< index into ii/jj
  int target;  ///< position of the target slot in the source's touched list (>= 1)
  Eigen::Matrix3d R_ji;
  Eigen::Vector3d t_ji;
};

}  // namespace

bool keepPixelFactor(const DbaOptions& o, double d, double Y2) {
  if (!(Y2 > 0)) return false;
  if (o.min_depth_ratio && Y2 < *o.min_depth_ratio) return false;
  if (o.near && !(d * *o.near < 1.0 && Y2 / d > *o.near)) return false;
  if (o.far && !(d * *o.far > 1.0)) return false;
  return true;
}

DbaNormalEquations linearizeDba(const Snapshot& s, const DbaOptions& o, bool keep_depth_terms) {
  DbaNormalEquations ne;
  ne.keyframes = s.graphKeyframes();
  const int n = static_cast<int>(ne.keyframes.size());
  ne.slot_of.assign(s.numKeyframes(), -1);
  for (int a = 0; a < n; ++a) ne.slot_of[ne.keyframes[a]] = a;
  ne.Hpp = BlockSymmetricMatrix(n);
  ne.S = BlockSymmetricMatrix(n);
  ne.g_p = Eigen::VectorXd::Zero(6 * n);
  ne.g_S = Eigen::VectorXd::Zero(6 * n);
  for (int a = 0; a < n; ++a) ne.S.at(a, a);  // every slot has a diagonal block, even if zero

  std::vector<Eigen::Isometry3d> T_wc(s.numKeyframes()), T_cw(s.numKeyframes());
  for (int k : ne.keyframes) {
    T_cw[k] = s.T_cw(k);
    T_wc[k] = T_cw[k].inverse();
  }
  const PinholeIntrinsics K = PinholeIntrinsics::fromVector(s.intrinsics);
  const int HW = static_cast<int>(s.pixelsPerFrame());

  for (int src_slot = 0; src_slot < n; ++src_slot) {
    const int src = ne.keyframes[src_slot];
    // Edges leaving this keyframe and the slots they touch.
    std::vector<int> touched{src_slot};
    std::vector<EdgeRef> edges;
    for (int e = 0; e < s.numEdges(); ++e) {
      if (s.ii[e] != src) continue;
      const int tgt_slot = ne.slot_of[s.jj[e]];
      auto it = std::find(touched.begin(), touched.end(), tgt_slot);
      const int t = static_cast<int>(it - touched.begin());
      if (it == touched.end()) touched.push_back(tgt_slot);
      const Eigen::Isometry3d T_ji = T_cw[s.jj[e]] * T_wc[src];
      edges.push_back({e, t, T_ji.linear(), T_ji.translation()});
    }
    if (edges.empty()) continue;
    const int T = static_cast<int>(touched.size());

    // Per-edge 12×12 blocks of Jᵀ Λ J over (ξ_src, ξ_tgt), per-slot gradients, and the b_k columns.
    std::vector<Eigen::Matrix<double, 12, 12>> He(edges.size(), Eigen::Matrix<double, 12, 12>::Zero());
    Eigen::VectorXd g_loc = Eigen::VectorXd::Zero(6 * T);
    Eigen::MatrixXd B(6 * T, HW);
    std::vector<int> pix;
    std::vector<double> hv, gv;
    pix.reserve(HW);
    hv.reserve(HW);
    gv.reserve(HW);
    PixelFactorLinearization f;

    for (int p = 0; p < HW; ++p) {
      const double d = s.disps[static_cast<std::size_t>(src) * HW + p];
      if (!(d > 0)) continue;
      const double x = p % s.W, y = p / s.W;
      const int col = static_cast<int>(pix.size());
      auto b = B.col(col);
      b.setZero();
      double h = 0, gd = 0;
      for (std::size_t q = 0; q < edges.size(); ++q) {
        const EdgeRef& er = edges[q];
        const double wx = o.weight_scale * s.weightPlane(er.edge, 0)[p];
        const double wy = o.weight_scale * s.weightPlane(er.edge, 1)[p];
        if (wx == 0 && wy == 0) continue;
        const double Y2 = er.R_ji.row(2).dot(Eigen::Vector3d((x - K.cx) / K.fx, (y - K.cy) / K.fy, 1)) +
                          er.t_ji.z() * d;
        if (!keepPixelFactor(o, d, Y2)) {
          ++ne.stats.factors_filtered;
          continue;
        }
        linearizePixelFactor(er.R_ji, er.t_ji, K, x, y, d, s.targetPlane(er.edge, 0)[p],
                             s.targetPlane(er.edge, 1)[p], &f);
        ++ne.stats.factors_used;
        const double w[2] = {wx, wy};
        for (int c = 0; c < 2; ++c) {
          if (w[c] == 0) continue;
          Eigen::Matrix<double, 1, 12> J;
          J << f.J_i.row(c), f.J_j.row(c);
          He[q].noalias() += w[c] * J.transpose() * J;
          const double wr = w[c] * f.r[c], wJd = w[c] * f.J_d[c];
          g_loc.segment<6>(0) += wr * f.J_i.row(c).transpose();
          g_loc.segment<6>(6 * er.target) += wr * f.J_j.row(c).transpose();
          b.segment<6>(0) += wJd * f.J_i.row(c).transpose();
          b.segment<6>(6 * er.target) += wJd * f.J_j.row(c).transpose();
          h += wJd * f.J_d[c];
          gd += wJd * f.r[c];
          ne.stats.chi2 += wr * f.r[c];
        }
      }
      if (h > o.depth_info_eps) {
        pix.push_back(p);
        hv.push_back(h);
        gv.push_back(gd);
      } else if (h > 0) {
        // b_k b_kᵀ/h_k ≼ (this pixel's share of Hpp) and b_k → 0 with h_k: leaving an
        // unobservable depth out of the elimination changes S by a negligible amount.
        ++ne.stats.depths_unobservable;
      }
    }
    const int P = static_cast<int>(pix.size());
    ne.stats.depths_used += P;

    // Dense local system of the touched slots: Hloc from the edges, then the Schur term
    // W = Σ_k b_k b_kᵀ / h_k as one rank-P update (B D^-1/2)(B D^-1/2)ᵀ.
    Eigen::MatrixXd Hloc = Eigen::MatrixXd::Zero(6 * T, 6 * T);
    for (std::size_t q = 0; q < edges.size(); ++q) {
      const int t = edges[q].target;
      Hloc.block<6, 6>(0, 0) += He[q].topLeftCorner<6, 6>();
      Hloc.block<6, 6>(6 * t, 6 * t) += He[q].bottomRightCorner<6, 6>();
      Hloc.block<6, 6>(0, 6 * t) += He[q].topRightCorner<6, 6>();
      Hloc.block<6, 6>(6 * t, 0) += He[q].bottomLeftCorner<6, 6>();
    }
    Eigen::MatrixXd Bs = B.leftCols(P);
    Eigen::VectorXd gS_loc = g_loc;
    for (int k = 0; k < P; ++k) {
      gS_loc.noalias() -= Bs.col(k) * (gv[k] / hv[k]);
      Bs.col(k) /= std::sqrt(hv[k]);
    }
    Eigen::MatrixXd Sloc = Hloc;
    Sloc.selfadjointView<Eigen::Lower>().rankUpdate(Bs, -1.0);
    Sloc.triangularView<Eigen::StrictlyUpper>() = Sloc.transpose();

    for (int a = 0; a < T; ++a) {
      ne.g_p.segment<6>(6 * touched[a]) += g_loc.segment<6>(6 * a);
      ne.g_S.segment<6>(6 * touched[a]) += gS_loc.segment<6>(6 * a);
      for (int c = a; c < T; ++c) {
        const Matrix6d Hb = Hloc.block<6, 6>(6 * a, 6 * c);
        if (!Hb.isZero(0)) ne.Hpp.add(touched[a], touched[c], Hb);
        const Matrix6d Sb = Sloc.block<6, 6>(6 * a, 6 * c);
        if (a == c || !Sb.isZero(0)) ne.S.add(touched[a], touched[c], Sb);
      }
    }

    if (keep_depth_terms) {
      DepthTerms dt;
      dt.source_slot = src_slot;
      dt.touched = touched;
      dt.pixel = std::move(pix);
      dt.h = std::move(hv);
      dt.g = std::move(gv);
      dt.B = B.leftCols(P);
      ne.depths.push_back(std::move(dt));
    }
  }
  return ne;
}

}  // namespace dbacov
