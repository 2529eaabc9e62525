#include "dbacov/core/linearization.h"

#include <algorithm>
#include <stdexcept>

#include "dba_kernel.h"
#include "dbacov/core/dba_factor.h"
#include "dbacov/core/parallel.h"
#include "dbacov/core/se3.h"
#include "depth_only_factors.h"
#include "source_system.h"

namespace dbacov {
namespace {

/// One edge leaving the current source keyframe.
struct EdgeRef {
  int edge;    ///< index into ii/jj
  int target;  ///< position of the target slot in the source's touched list (>= 1)
  Eigen::Matrix3d R_ji;
  Eigen::Vector3d t_ji;
};

/// The linearization of one source keyframe's pixels: a dense local system over the slots it
/// touches (itself and its edge targets), merged into the block matrices afterwards.
detail::SourceSystem linearizeSource(const Snapshot& s, const DbaOptions& o,
                                     const PinholeIntrinsics& K, const std::vector<double>& xn,
                                     const std::vector<double>& yn, int src_slot, int src,
                                     std::vector<int> touched, const std::vector<EdgeRef>& edges,
                                     bool keep_depth_terms,
                                     const detail::DepthOnlyTerms& depth_only, kernel::Isa isa) {
  detail::SourceSystem res;
  const bool caller_keeps = keep_depth_terms;
  keep_depth_terms |= depth_only.any;  // the correction needs the kernel's depth terms
  const int T = static_cast<int>(touched.size()), E = static_cast<int>(edges.size());
  const int HW = static_cast<int>(s.pixelsPerFrame());

  // The pixel kernel (dba_kernel.h) accumulates, chunk by chunk, the per-edge normal equations
  // and the Schur terms; nothing per pixel is stored unless the depth terms are requested.
  const kernel::Camera cam{K.fx, K.fy, K.cx, K.cy};
  const kernel::Filter flt{o.weight_scale, o.min_depth_ratio.value_or(0.0), o.near.value_or(0.0),
                           o.far.value_or(0.0), o.depth_info_eps};
  std::vector<kernel::Edge> kedges(E);
  for (int q = 0; q < E; ++q) {
    kernel::Edge& k = kedges[q];
    Eigen::Map<Eigen::Matrix<double, 3, 3, Eigen::RowMajor>>(k.R) = edges[q].R_ji;
    Eigen::Map<Eigen::Vector3d>(k.t) = edges[q].t_ji;
    k.wx = s.weightPlane(edges[q].edge, 0);
    k.wy = s.weightPlane(edges[q].edge, 1);
    k.tx = s.targetPlane(edges[q].edge, 0);
    k.ty = s.targetPlane(edges[q].edge, 1);
  }
  thread_local kernel::Accumulator acc;  // reused: no allocation per snapshot in steady state
  acc.reset(E, keep_depth_terms);
  double d[kernel::kChunk];
  const float* disps = &s.disps[static_cast<std::size_t>(src) * HW];
  for (int p0 = 0; p0 < HW; p0 += kernel::kChunk) {
    const int n = std::min(kernel::kChunk, HW - p0);
    for (int p = 0; p < n; ++p) d[p] = disps[p0 + p];
    kernel::processChunk(isa, cam, flt, p0, n, &xn[p0], &yn[p0], d, kedges.data(), acc);
  }
  res.stats.factors_used = acc.factors_used;
  res.stats.factors_filtered = acc.factors_filtered;
  res.stats.depths_used = acc.depths_used;
  res.stats.depths_unobservable = acc.depths_unobservable;

  // Local system of the touched slots from the per-edge blocks (lower triangles of aug).
  res.Hloc = Eigen::MatrixXd::Zero(6 * T, 6 * T);
  res.g_loc = Eigen::VectorXd::Zero(6 * T);
  // The kernel works in the edges' coordinates (dba_kernel.h): J_i = −J_j Ad_q with
  // Ad_q = Ad(T_ji) = [R [t]×R; 0 R] (the source's perturbation moved through T_ji), so
  // H_ii = Adᵀ H_jj Ad, H_ij = −Adᵀ H_jj, g_i = −Adᵀ g_j per edge, and Γ (6T × 6E) maps the depth
  // terms to the touched slots: block (0, q) = −Ad_qᵀ, block (target_q, q) = I.
  Eigen::MatrixXd Gamma = Eigen::MatrixXd::Zero(6 * T, 6 * E);
  for (int q = 0; q < E; ++q) {
    const int t = edges[q].target;
    Eigen::Matrix<double, 7, 7> A =
        Eigen::Map<const Eigen::Matrix<double, 7, 7, Eigen::RowMajor>>(&acc.aug[49 * q]);
    A.triangularView<Eigen::StrictlyUpper>() = A.transpose();  // the kernel fills the lower
    Eigen::Isometry3d T_ji = Eigen::Isometry3d::Identity();
    T_ji.linear() = edges[q].R_ji;
    T_ji.translation() = edges[q].t_ji;
    const Matrix6d Ad = adjoint(T_ji);
    const Matrix6d Hjj = A.topLeftCorner<6, 6>();
    const Matrix6d Hij = -Ad.transpose() * Hjj;
    const Matrix6d Hii = -Hij * Ad;
    res.Hloc.block<6, 6>(0, 0) += 0.5 * (Hii + Hii.transpose());  // symmetric to the bit
    res.Hloc.block<6, 6>(6 * t, 6 * t) += Hjj;
    res.Hloc.block<6, 6>(0, 6 * t) += Hij;
    res.Hloc.block<6, 6>(6 * t, 0) += Hij.transpose();
    res.g_loc.segment<6>(0) -= Ad.transpose() * A.block<6, 1>(0, 6);
    res.g_loc.segment<6>(6 * t) += A.block<6, 1>(0, 6);
    res.stats.chi2 += A(6, 6);
    Gamma.block<6, 6>(0, 6 * q) = -Ad.transpose();
    Gamma.block<6, 6>(6 * t, 6 * q).setIdentity();
  }
  // S = H − Γ C Γᵀ and g_S = g − Γ g_C over the eliminated depths.
  Eigen::MatrixXd C =
      Eigen::Map<const Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor>>(
          acc.C.data(), 6 * E, 6 * E);
  C.triangularView<Eigen::StrictlyUpper>() = C.transpose();
  const Eigen::MatrixXd GC = Gamma * C;
  res.Sloc = res.Hloc - GC * Gamma.transpose();
  res.gS_loc = res.g_loc - Gamma * Eigen::Map<const Eigen::VectorXd>(acc.gC.data(), 6 * E);
  // The kept depths' couplings b_k = Γ c_k (6T each), as the depth-only terms and callers use them:
  // the source's rows −Σ_q Ad_qᵀ c_q, each target's rows the sum of its edges' c_q.
  thread_local std::vector<double> B;  // reused, as the accumulator
  B.assign(static_cast<std::size_t>(6) * T * acc.pixel.size(), 0.0);
  if (!acc.pixel.empty()) {
    const auto np = static_cast<Eigen::Index>(acc.pixel.size());
    Eigen::Map<Eigen::MatrixXd> Bt(B.data(), 6 * T, np);
    const Eigen::Map<const Eigen::MatrixXd> Bc(acc.B.data(), 6 * E, np);
    for (int q = 0; q < E; ++q) {
      Bt.middleRows<6>(0).noalias() += Gamma.block<6, 6>(0, 6 * q) * Bc.middleRows<6>(6 * q);
      Bt.middleRows<6>(6 * edges[q].target) += Bc.middleRows<6>(6 * q);
    }
  }
  if (depth_only.any) {  // RGB-D sensor / stereo factors on the depths (depth_only_factors.h)
    res.stats.depths_used += detail::applyDepthOnlyTerms(
        depth_only, o.depth_info_eps, 6 * T, acc.pixel, acc.h, acc.g, B, res.Sloc, res.gS_loc);
  }
  res.Sloc = 0.5 * (res.Sloc + res.Sloc.transpose()).eval();  // symmetric to the bit
  res.stats.factors_used += depth_only.factors_used;
  res.stats.factors_filtered += depth_only.factors_filtered;
  res.stats.chi2 += depth_only.chi2;
  if (caller_keeps) {
    res.depth.source_slot = src_slot;
    res.depth.touched = touched;
    res.depth.pixel = acc.pixel;
    res.depth.h = acc.h;
    res.depth.g = acc.g;
    res.depth.B = Eigen::Map<const Eigen::MatrixXd>(B.data(), 6 * T, acc.pixel.size());
  }
  res.touched = std::move(touched);
  return res;
}

}  // namespace

bool keepPixelFactor(const DbaOptions& o, double d, double Y2) {
  if (!(Y2 > 0)) return false;
  if (o.min_depth_ratio && Y2 < *o.min_depth_ratio) return false;
  if (o.near && !(d * *o.near < 1.0 && Y2 / d > *o.near)) return false;
  if (o.far && !(d * *o.far > 1.0)) return false;
  return true;
}

DbaNormalEquations linearizeDba(const Snapshot& s, const DbaOptions& o, bool keep_depth_terms) {
  if (o.max_residual || o.image_margin)
    throw std::invalid_argument(
        "the maximum residual and the image margin (preset dpvo) apply to patch graphs only, not "
        "to "
        "a dense DROID snapshot (" +
        s.source + ")");
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
  std::vector<double> xn(HW), yn(HW);  // normalized image coordinates, shared by every keyframe
  for (int p = 0; p < HW; ++p) {
    xn[p] = (p % s.W - K.cx) / K.fx;
    yn[p] = (p / s.W - K.cy) / K.fy;
  }

  // The sources and their edges; the work per source is independent.
  struct Task {
    int slot;
    std::vector<int> touched;
    std::vector<EdgeRef> edges;
    std::vector<int> stereo;  ///< edges with ii == jj (fixed rig transform, depths only)
  };
  std::vector<Task> tasks;
  for (int src_slot = 0; src_slot < n; ++src_slot) {
    const int src = ne.keyframes[src_slot];
    Task t{src_slot, {src_slot}, {}, {}};
    for (int e = 0; e < s.numEdges(); ++e) {
      if (s.ii[e] != src) continue;
      if (s.jj[e] == src) {
        t.stereo.push_back(e);
        continue;
      }
      const int tgt_slot = ne.slot_of[s.jj[e]];
      auto it = std::find(t.touched.begin(), t.touched.end(), tgt_slot);
      const int pos = static_cast<int>(it - t.touched.begin());
      if (it == t.touched.end()) t.touched.push_back(tgt_slot);
      const Eigen::Isometry3d T_ji = T_cw[s.jj[e]] * T_wc[src];
      t.edges.push_back({e, pos, T_ji.linear(), T_ji.translation()});
    }
    if (!t.edges.empty()) tasks.push_back(std::move(t));
  }
  std::vector<detail::SourceSystem> results(tasks.size());
  // The kernel's instruction set, chosen here: a wrong DBACOV_KERNEL_ISA is the caller's error.
  const kernel::Isa isa = kernel::selectedIsa();
  parallelFor(tasks.size(), [&](std::size_t i) {
    const Task& t = tasks[i];
    const int src = ne.keyframes[t.slot];
    results[i] = linearizeSource(s, o, K, xn, yn, t.slot, src, t.touched, t.edges, keep_depth_terms,
                                 detail::depthOnlyTerms(s, o, src, t.stereo), isa);
  });

  detail::mergeSourceSystems(results, keep_depth_terms, ne);
  return ne;
}

namespace detail {

void mergeSourceSystems(std::vector<SourceSystem>& systems, bool keep_depth_terms,
                        DbaNormalEquations& ne) {
  for (SourceSystem& r : systems) {
    const int T = static_cast<int>(r.touched.size());
    for (int a = 0; a < T; ++a) {
      ne.g_p.segment<6>(6 * r.touched[a]) += r.g_loc.segment<6>(6 * a);
      ne.g_S.segment<6>(6 * r.touched[a]) += r.gS_loc.segment<6>(6 * a);
      for (int c = a; c < T; ++c) {
        const Matrix6d Hb = r.Hloc.block<6, 6>(6 * a, 6 * c);
        if (!Hb.isZero(0)) ne.Hpp.add(r.touched[a], r.touched[c], Hb);
        const Matrix6d Sb = r.Sloc.block<6, 6>(6 * a, 6 * c);
        if (a == c || !Sb.isZero(0)) ne.S.add(r.touched[a], r.touched[c], Sb);
      }
    }
    ne.stats.factors_used += r.stats.factors_used;
    ne.stats.factors_filtered += r.stats.factors_filtered;
    ne.stats.depths_used += r.stats.depths_used;
    ne.stats.depths_unobservable += r.stats.depths_unobservable;
    ne.stats.chi2 += r.stats.chi2;
    if (keep_depth_terms) ne.depths.push_back(std::move(r.depth));
  }
}

}  // namespace detail

}  // namespace dbacov
