// The depths' second-order noise term (depth_noise.h). One scalar pass over the kept depths of
// every source keyframe, in the edges' coordinates (J_i = −J_j Ad(T_ji), as the kernel): per edge
// the 6 × 6 sum of J'_jᵀ Λ J'_j / h, per source the 6E × 6E sums of the depth couplings' and the
// curvature scores' outer products (blocked products over the kept depths), mapped to the
// touched slots once per source.
#include "dbacov/core/depth_noise.h"

#include <algorithm>
#include <cmath>

#include "dbacov/core/dba_factor.h"
#include "dbacov/core/dot_products.h"
#include "dbacov/core/parallel.h"
#include "dbacov/core/se3.h"

namespace dbacov {

Eigen::Matrix<double, 2, 6> pixelFactorJacobianDepthDerivative(const Eigen::Vector3d& Y,
                                                               const Eigen::Vector3d& t, double fx,
                                                               double fy, double d,
                                                               Eigen::Vector2d* r_dd) {
  const double iz = 1.0 / Y.z(), iz2 = iz * iz;
  // −∂π/∂Y and its derivative along ∂Y/∂d = t.
  Eigen::Matrix<double, 2, 3> mdPi, dmdPi;
  mdPi << -fx * iz, 0.0, fx * Y.x() * iz2, 0.0, -fy * iz, fy * Y.y() * iz2;
  dmdPi << fx * t.z() * iz2, 0.0, fx * (t.x() * iz2 - 2.0 * Y.x() * t.z() * iz2 * iz), 0.0,
      fy * t.z() * iz2, fy * (t.y() * iz2 - 2.0 * Y.y() * t.z() * iz2 * iz);
  // J_j = [−d·mdPi, mdPi [Y]×], J_d = mdPi t.
  Eigen::Matrix<double, 2, 6> out;
  out.leftCols<3>() = -mdPi - d * dmdPi;
  out.rightCols<3>() = dmdPi * hat(Y) + mdPi * hat(t);
  if (r_dd) *r_dd = dmdPi * t;
  return out;
}

namespace {

/// Per edge: rows and the sums of z² and z⁴ of the standardized residuals.
struct EdgeMoments {
  double rows = 0, s2 = 0, s4 = 0;
};

struct SourceTerms {
  Eigen::MatrixXd M, N, Mk, Nk;
  Eigen::VectorXd bias;
  std::size_t depths = 0;
  std::vector<std::pair<int, EdgeMoments>> moments;  ///< (edge, its moments)
};

SourceTerms sourceTerms(const Snapshot& s, const DbaOptions& o, const DbaNormalEquations& ne,
                        const DepthTerms& dt) {
  SourceTerms out;
  const int src = ne.keyframes[dt.source_slot];
  const int T = static_cast<int>(dt.touched.size());
  struct EdgeRef {
    int edge, target;
    Eigen::Matrix3d R;
    Eigen::Vector3d t;
    Matrix6d Ad;
  };
  std::vector<EdgeRef> edges;
  std::vector<int> stereo;  // (src, src): the fixed rig, a factor on the depth alone
  const Eigen::Isometry3d T_wc_src = s.T_cw(src).inverse();
  for (int e = 0; e < s.numEdges(); ++e) {
    if (s.ii[e] == src && s.jj[e] == src) stereo.push_back(e);
    if (s.ii[e] != src || s.jj[e] == src) continue;
    const int slot = ne.slot_of[s.jj[e]];
    const auto it = std::find(dt.touched.begin(), dt.touched.end(), slot);
    if (slot < 0 || it == dt.touched.end()) continue;
    const Eigen::Isometry3d T_ji = s.T_cw(s.jj[e]) * T_wc_src;
    edges.push_back({e, static_cast<int>(it - dt.touched.begin()), T_ji.linear(),
                     T_ji.translation(), adjoint(T_ji)});
  }
  const int E = static_cast<int>(edges.size());
  out.M = Eigen::MatrixXd::Zero(6 * T, 6 * T);
  out.N = Eigen::MatrixXd::Zero(6 * T, 6 * T);
  out.Mk = Eigen::MatrixXd::Zero(6 * T, 6 * T);
  out.Nk = Eigen::MatrixXd::Zero(6 * T, 6 * T);
  out.bias = Eigen::VectorXd::Zero(6 * T);
  if (E == 0) return out;
  // Γ (6T × 6E): an edge's 6 coordinates on the touched slots, source −Adᵀ, target I.
  Eigen::MatrixXd Gamma = Eigen::MatrixXd::Zero(6 * T, 6 * E);
  for (int q = 0; q < E; ++q) {
    Gamma.block<6, 6>(0, 6 * q) = -edges[q].Ad.transpose();
    Gamma.block<6, 6>(6 * edges[q].target, 6 * q).setIdentity();
  }
  const PinholeIntrinsics K = PinholeIntrinsics::fromVector(s.intrinsics);
  const Eigen::Isometry3d rig = stereo.empty() ? Eigen::Isometry3d::Identity() : s.stereoRig();
  const std::size_t HW = s.pixelsPerFrame();
  const float* disps = &s.disps[static_cast<std::size_t>(src) * HW];
  std::vector<Matrix6d> A(E, Matrix6d::Zero()), Ak(E, Matrix6d::Zero());
  std::vector<EdgeMoments> mom(E), mom_st(stereo.size());
  // Per kept depth, in the edges' coordinates: c/h (the coupling of M) and v/(√2 h) (the
  // curvature score g = Γ v of N), one row each (each column contiguous over the depths), so
  // that Σ c cᵀ/h² and Σ v vᵀ/(2h²) are two symmetric products over the depths in the kernel's
  // dot products, and Γ is applied once per source, not per pixel (rank-1 updates and Γ per
  // pixel were most of the term's cost).
  // The columns' stride: a multiple of 8 doubles plus 8, never a multiple of 4 KiB (with P =
  // 3072 depths it was 24 KiB, so the 6E entries one depth writes across a column-major matrix
  // all fell in one L1 set and evicted each other at every depth).
  const Eigen::Index P = (static_cast<Eigen::Index>(dt.pixel.size()) + 7) / 8 * 8 + 8;
  Eigen::MatrixXd Cm(P, 6 * E), Vm(P, 6 * E);
  // The fourth-cumulant terms (depth_noise.h), per unit γ₂: Σ_f w_f β_f β_fᵀ with w_f =
  // J_d,f²/h² and β_f = L_f − α_f c (L_f = Λ_f J'_f on its edge's 6 coordinates, α_f =
  // Λ_f J_d,f/h) is Σ w L Lᵀ (per edge, Ak) − (ℓ cᵀ + c ℓᵀ) + s c cᵀ with ℓ = Σ w α L and
  // s = Σ w α²: rows h ℓ (against Cm's c/h) and √s c; N's rows v · ½√(Σ Λ² J_d⁴)/h².
  Eigen::MatrixXd Lm(P, 6 * E), Sm(P, 6 * E), Vk(P, 6 * E);
  Eigen::VectorXd ell(6 * E);
  Eigen::VectorXd vsum = Eigen::VectorXd::Zero(6 * E);  // Σ v / (2h)
  Eigen::VectorXd c(6 * E), u(6 * E), bq(6 * E);
  Eigen::Index cols = 0;
  for (std::size_t k = 0; k < dt.pixel.size(); ++k) {
    const int p = dt.pixel[k];
    const double h = dt.h[k], inv_h = 1.0 / h, d = disps[p];
    const double x = p % s.W, y = p / s.W;
    c.setZero();
    u.setZero();
    bq.setZero();
    ell.setZero();
    double sdd = 0;           // Σ J_dᵀ Λ r''
    double sk = 0, l2j4 = 0;  // Σ w α², Σ Λ² J_d⁴
    bool any = false;
    // One axis of a flow factor: the κ sums and the residual's moments (z² = Λ r² / (1 − Λ J_d²
    // / h), the depth's leverage taken out; the poses' is small and left in).
    const auto axis = [&](double lam, double jd, double r, EdgeMoments& m) {
      const double alpha = lam * jd * inv_h, w = jd * jd * inv_h * inv_h;
      sk += w * alpha * alpha;
      l2j4 += lam * lam * jd * jd * jd * jd;
      const double lev = lam * jd * jd * inv_h;
      if (lev < 0.999) {
        const double z2 = lam * r * r / (1.0 - lev);
        m.rows += 1;
        m.s2 += z2;
        m.s4 += z2 * z2;
      }
      return w * alpha;
    };
    for (int q = 0; q < E; ++q) {
      const EdgeRef& er = edges[q];
      const Eigen::Vector3d Y = transferPoint(er.R, er.t, K, x, y, d);
      if (!keepPixelFactor(o, d, Y.z())) continue;
      const double lx = o.weight_scale * s.weightPlane(er.edge, 0)[p];
      const double ly = o.weight_scale * s.weightPlane(er.edge, 1)[p];
      if (!(lx > 0) && !(ly > 0)) continue;
      const Eigen::Vector2d lam(lx, ly);
      PixelFactorLinearization f;
      linearizePixelFactorAt(Y, er.t, K, d, s.targetPlane(er.edge, 0)[p],
                             s.targetPlane(er.edge, 1)[p], &f);
      Eigen::Vector2d rdd;
      const Eigen::Matrix<double, 2, 6> Jp =
          pixelFactorJacobianDepthDerivative(Y, er.t, K.fx, K.fy, d, &rdd);
      const Eigen::Matrix<double, 6, 2> JpL = Jp.transpose() * lam.asDiagonal();
      const Eigen::Matrix<double, 6, 2> JjL = f.J_j.transpose() * lam.asDiagonal();
      A[q].noalias() += (JpL * inv_h) * Jp;  // one scaling of 12, not a division of 36
      for (int ch = 0; ch < 2; ++ch) {
        if (!(lam[ch] > 0)) continue;
        const double wa = axis(lam[ch], f.J_d[ch], f.r[ch], mom[q]);
        const double w = f.J_d[ch] * f.J_d[ch] * inv_h * inv_h;
        Ak[q].noalias() += w * JpL.col(ch) * JpL.col(ch).transpose();
        ell.segment<6>(6 * q) += wa * JpL.col(ch);
      }
      c.segment<6>(6 * q) = JpL * f.J_d;
      u.segment<6>(6 * q) = JjL * rdd;
      bq.segment<6>(6 * q) = JjL * f.J_d;
      sdd += f.J_d.dot(lam.asDiagonal() * rdd);
      any = true;
    }
    if (!any) continue;
    // A stereo factor has no pose Jacobian (nothing in c, u, bq), but its curvature moves the
    // depth's second-order estimate as any other factor's does. (RGB-D readings are linear in
    // the inverse depth: nothing.)
    for (std::size_t si = 0; si < stereo.size(); ++si) {
      const int e = stereo[si];
      const Eigen::Vector3d Y = transferPoint(rig.linear(), rig.translation(), K, x, y, d);
      if (!keepPixelFactor(o, d, Y.z())) continue;
      const Eigen::Vector2d lam(o.weight_scale * s.weightPlane(e, 0)[p],
                                o.weight_scale * s.weightPlane(e, 1)[p]);
      if (!(lam[0] > 0) && !(lam[1] > 0)) continue;
      PixelFactorLinearization f;
      linearizePixelFactorAt(Y, rig.translation(), K, d, s.targetPlane(e, 0)[p],
                             s.targetPlane(e, 1)[p], &f);
      Eigen::Vector2d rdd;
      pixelFactorJacobianDepthDerivative(Y, rig.translation(), K.fx, K.fy, d, &rdd);
      sdd += f.J_d.dot(lam.asDiagonal() * rdd);
      for (int ch = 0; ch < 2; ++ch)  // no pose part: L = 0, only α enters (s, N's κ term)
        if (lam[ch] > 0) axis(lam[ch], f.J_d[ch], f.r[ch], mom_st[si]);
    }
    ++out.depths;
    const Eigen::VectorXd v = u - bq * (sdd / h);  // the curvature score in edge coordinates
    Cm.row(cols) = c.transpose() / h;
    Vm.row(cols) = v.transpose() * (std::sqrt(0.5) / h);
    vsum.noalias() += v / (2.0 * h);
    Lm.row(cols) = ell.transpose() * h;
    Sm.row(cols) = c.transpose() * std::sqrt(sk);
    Vk.row(cols) = v.transpose() * (0.5 * std::sqrt(l2j4) * inv_h * inv_h);
    ++cols;
  }
  const int m6 = 6 * E, kept = static_cast<int>(cols);
  // Σ over the kept depths of row rowᵀ, symmetric: gemmNT writes the row-major lower triangle
  // (Eigen's upper one), mirrored below.
  const auto gram = [&](const Eigen::MatrixXd& rows) {
    Eigen::MatrixXd G = Eigen::MatrixXd::Zero(m6, m6);
    kernel::gemmNT(m6, m6, kept, rows.data(), P, rows.data(), P, G.data(), m6, true);
    G.triangularView<Eigen::StrictlyLower>() = G.transpose();
    return G;
  };
  const Eigen::MatrixXd C = gram(Cm), V = gram(Vm);
  out.M.noalias() -= Gamma * C * Gamma.transpose();
  out.N.noalias() = Gamma * V * Gamma.transpose();
  out.bias.noalias() = -(Gamma * vsum);
  for (int q = 0; q < E; ++q) {
    const auto G = Gamma.middleCols<6>(6 * q);
    out.M.noalias() += G * A[q] * G.transpose();
  }
  out.M = 0.5 * (out.M + out.M.transpose()).eval();
  // The κ terms per unit γ₂.
  const Eigen::MatrixXd Sk = gram(Sm), Vkk = gram(Vk);
  Eigen::MatrixXd X = Eigen::MatrixXd::Zero(m6, m6);
  kernel::gemmNT(m6, m6, kept, Lm.data(), P, Cm.data(), P, X.data(), m6);  // row-major Σ ℓ cᵀ
  // X holds Σ ℓ cᵀ row-major, i.e. Σ c ℓᵀ in Eigen's column-major view: the symmetric sum
  // X + Xᵀ is the same either way.
  Eigen::MatrixXd Ke = Sk - X - X.transpose();
  for (int q = 0; q < E; ++q) Ke.block<6, 6>(6 * q, 6 * q) += Ak[q];
  out.Mk.noalias() = Gamma * Ke * Gamma.transpose();
  out.Mk = 0.5 * (out.Mk + out.Mk.transpose()).eval();
  out.Nk.noalias() = Gamma * Vkk * Gamma.transpose();
  for (int q = 0; q < E; ++q) out.moments.emplace_back(edges[q].edge, mom[q]);
  for (std::size_t si = 0; si < stereo.size(); ++si)
    out.moments.emplace_back(stereo[si], mom_st[si]);
  return out;
}

}  // namespace

DepthNoiseTerms depthNoiseTerms(const Snapshot& s, const DbaOptions& o,
                                const DbaNormalEquations& ne) {
  const int n = static_cast<int>(ne.keyframes.size());
  DepthNoiseTerms out;
  out.M = Eigen::MatrixXd::Zero(6 * n, 6 * n);
  out.N = Eigen::MatrixXd::Zero(6 * n, 6 * n);
  out.bias_score = Eigen::VectorXd::Zero(6 * n);
  out.M_kurtosis = Eigen::MatrixXd::Zero(6 * n, 6 * n);
  out.N_kurtosis = Eigen::MatrixXd::Zero(6 * n, 6 * n);
  std::vector<SourceTerms> per(ne.depths.size());
  parallelFor(ne.depths.size(),
              [&](std::size_t i) { per[i] = sourceTerms(s, o, ne, ne.depths[i]); });
  for (std::size_t i = 0; i < per.size(); ++i) {
    const std::vector<int>& touched = ne.depths[i].touched;
    const int T = static_cast<int>(touched.size());
    for (int a = 0; a < T; ++a) {
      out.bias_score.segment<6>(6 * touched[a]) += per[i].bias.segment<6>(6 * a);
      for (int b = 0; b < T; ++b) {
        out.M.block<6, 6>(6 * touched[a], 6 * touched[b]) += per[i].M.block<6, 6>(6 * a, 6 * b);
        out.N.block<6, 6>(6 * touched[a], 6 * touched[b]) += per[i].N.block<6, 6>(6 * a, 6 * b);
        out.M_kurtosis.block<6, 6>(6 * touched[a], 6 * touched[b]) +=
            per[i].Mk.block<6, 6>(6 * a, 6 * b);
        out.N_kurtosis.block<6, 6>(6 * touched[a], 6 * touched[b]) +=
            per[i].Nk.block<6, 6>(6 * a, 6 * b);
      }
    }
    out.depths += per[i].depths;
  }
  // γ₂ pooled over the edges (each edge's own scale: m4 / m2²), in edge order.
  std::vector<EdgeMoments> edge_moments(s.numEdges());
  for (const SourceTerms& st : per)
    for (const auto& [e, m] : st.moments) {
      edge_moments[e].rows += m.rows;
      edge_moments[e].s2 += m.s2;
      edge_moments[e].s4 += m.s4;
    }
  double rows = 0, ratio = 0;
  for (const EdgeMoments& m : edge_moments) {
    if (m.rows < 8 || !(m.s2 > 0)) continue;
    const double m2 = m.s2 / m.rows, m4 = m.s4 / m.rows;
    ratio += m.rows * m4 / (m2 * m2);
    rows += m.rows;
  }
  if (rows > 0) out.kurtosis = std::max(0.0, ratio / rows - 3.0);
  return out;
}

}  // namespace dbacov
