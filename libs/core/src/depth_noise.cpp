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

/// Per edge: rows and the sums of z² and z⁴ of the standardized residuals; the factors with both
/// axes measured, Σ z_x² z_y² and Σ z_x z_y (the axes' joint fourth moment and correlation).
struct EdgeMoments {
  double rows = 0, s2 = 0, s4 = 0;
  double pairs = 0, sxy = 0, cxy = 0;
};

/// The fourth cumulants the κ terms are formed with: γ₂ on each axis, γ_xy across the two axes
/// of one factor (depth_noise.h).
struct Cumulants {
  double gamma2 = 0, gamma_xy = 0;
  bool any() const { return gamma2 > 0 || gamma_xy > 0; }
};

struct SourceTerms {
  Eigen::MatrixXd M, N, Mk, Nk;
  Eigen::VectorXd bias;
  std::size_t depths = 0;
};

/// The pixel factors of one source keyframe's edges: its edges to other keyframes (their slot
/// among the source's touched ones, T_ji, Ad(T_ji)) and its stereo edges (src, src).
struct SourceEdges {
  struct Ref {
    int edge, target;
    Eigen::Matrix3d R;
    Eigen::Vector3d t;
    Matrix6d Ad;
  };
  std::vector<Ref> edges;
  std::vector<int> stereo;  ///< (src, src): the fixed rig, a factor on the depth alone
};

SourceEdges sourceEdges(const Snapshot& s, const DbaNormalEquations& ne, const DepthTerms& dt) {
  SourceEdges out;
  const int src = ne.keyframes[dt.source_slot];
  const Eigen::Isometry3d T_wc_src = s.T_cw(src).inverse();
  for (int e = 0; e < s.numEdges(); ++e) {
    if (s.ii[e] == src && s.jj[e] == src) out.stereo.push_back(e);
    if (s.ii[e] != src || s.jj[e] == src) continue;
    const int slot = ne.slot_of[s.jj[e]];
    const auto it = std::find(dt.touched.begin(), dt.touched.end(), slot);
    if (slot < 0 || it == dt.touched.end()) continue;
    const Eigen::Isometry3d T_ji = s.T_cw(s.jj[e]) * T_wc_src;
    out.edges.push_back({e, static_cast<int>(it - dt.touched.begin()), T_ji.linear(),
                         T_ji.translation(), adjoint(T_ji)});
  }
  return out;
}

/// One source keyframe's residual moments, per edge (edge, its moments; the stereo edges last).
/// Edge by edge over the kept depths, so that each edge's weight and target planes are read in
/// order (depth by depth across every edge, the terms' order below, the planes were a stream per
/// edge and plane). A factor's z = √Λ r / √(1 − Λ J_d² / h) per axis (the depth's leverage taken
/// out; the poses' is small and left in), 0 where the depth takes it all. A stereo factor counts
/// at the depths that have a factor of a pose edge too (those the terms are formed at).
std::vector<std::pair<int, EdgeMoments>> sourceMoments(const Snapshot& s, const DbaOptions& o,
                                                       const DbaNormalEquations& ne,
                                                       const DepthTerms& dt,
                                                       const SourceEdges& se) {
  const int src = ne.keyframes[dt.source_slot];
  const PinholeIntrinsics K = PinholeIntrinsics::fromVector(s.intrinsics);
  const std::size_t HW = s.pixelsPerFrame(), P = dt.pixel.size();
  const float* disps = &s.disps[static_cast<std::size_t>(src) * HW];
  std::vector<char> any(P, 0);
  std::vector<std::pair<int, EdgeMoments>> out;
  const auto factor = [&](int e, const Eigen::Matrix3d& R, const Eigen::Vector3d& t, std::size_t k,
                          EdgeMoments& m) {
    const int p = dt.pixel[k];
    const double d = disps[p], inv_h = 1.0 / dt.h[k];
    const Eigen::Vector3d Y = transferPoint(R, t, K, p % s.W, p / s.W, d);
    if (!keepPixelFactor(o, d, Y.z())) return false;
    const double lam[2] = {o.weight_scale * s.weightPlane(e, 0)[p],
                           o.weight_scale * s.weightPlane(e, 1)[p]};
    if (!(lam[0] > 0) && !(lam[1] > 0)) return false;
    PixelFactorLinearization f;
    linearizePixelFactorAt(Y, t, K, d, s.targetPlane(e, 0)[p], s.targetPlane(e, 1)[p], &f);
    double z[2] = {0.0, 0.0};
    bool measured[2] = {false, false};
    for (int ch = 0; ch < 2; ++ch) {
      if (!(lam[ch] > 0)) continue;
      const double lev = lam[ch] * f.J_d[ch] * f.J_d[ch] * inv_h;
      if (!(lev < 0.999)) continue;
      measured[ch] = true;
      z[ch] = std::sqrt(lam[ch] / (1.0 - lev)) * f.r[ch];
      const double z2 = z[ch] * z[ch];
      m.rows += 1;
      m.s2 += z2;
      m.s4 += z2 * z2;
    }
    if (measured[0] && measured[1]) {
      m.pairs += 1;
      m.sxy += z[0] * z[0] * z[1] * z[1];
      m.cxy += z[0] * z[1];
    }
    return true;
  };
  for (const SourceEdges::Ref& er : se.edges) {
    EdgeMoments m;
    for (std::size_t k = 0; k < P; ++k)
      if (factor(er.edge, er.R, er.t, k, m)) any[k] = 1;
    out.emplace_back(er.edge, m);
  }
  if (se.stereo.empty()) return out;
  const Eigen::Isometry3d rig = s.stereoRig();
  for (int e : se.stereo) {
    EdgeMoments m;
    for (std::size_t k = 0; k < P; ++k)
      if (any[k]) factor(e, rig.linear(), rig.translation(), k, m);
    out.emplace_back(e, m);
  }
  return out;
}

/// One source keyframe's terms, with the fourth cumulants `kc` (sourceMoments' estimates).
SourceTerms sourceTerms(const Snapshot& s, const DbaOptions& o, const DbaNormalEquations& ne,
                        const DepthTerms& dt, const SourceEdges& se, const Cumulants& kc) {
  SourceTerms out;
  const int src = ne.keyframes[dt.source_slot];
  const int T = static_cast<int>(dt.touched.size());
  const std::vector<SourceEdges::Ref>& edges = se.edges;
  const std::vector<int>& stereo = se.stereo;
  const int E = static_cast<int>(edges.size());
  const bool kappa = kc.any();
  const Eigen::Index T6 = 6 * T;
  out.M = Eigen::MatrixXd::Zero(T6, T6);
  out.N = Eigen::MatrixXd::Zero(T6, T6);
  out.Mk = Eigen::MatrixXd::Zero(T6, T6);
  out.Nk = Eigen::MatrixXd::Zero(T6, T6);
  out.bias = Eigen::VectorXd::Zero(T6);
  if (E == 0) return out;
  // Γ (6T × 6E): an edge's 6 coordinates on the touched slots, source −Adᵀ, target I.
  Eigen::MatrixXd Gamma = Eigen::MatrixXd::Zero(T6, 6 * E);
  for (int q = 0; q < E; ++q) {
    Gamma.block<6, 6>(0, 6 * q) = -edges[q].Ad.transpose();
    Gamma.block<6, 6>(6 * edges[q].target, 6 * q).setIdentity();
  }
  const PinholeIntrinsics K = PinholeIntrinsics::fromVector(s.intrinsics);
  const Eigen::Isometry3d rig = stereo.empty() ? Eigen::Isometry3d::Identity() : s.stereoRig();
  const std::size_t HW = s.pixelsPerFrame();
  const float* disps = &s.disps[static_cast<std::size_t>(src) * HW];
  std::vector<Matrix6d> A(E, Matrix6d::Zero()), Ak(E, Matrix6d::Zero());
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
  // The fourth-cumulant terms (depth_noise.h): Σ_{f,g} ω_fg β_f β_gᵀ over the pairs of rows with
  // a joint fourth cumulant (a row with itself, ω_ff = γ₂ J_d,f²/h²; the two axes of one factor,
  // ω_xx = γ_xy Λ_y J_d,y²/(Λ_x h²), ω_yy likewise, ω_xy = ω_yx = 2 γ_xy J_d,x J_d,y/h²), with
  // β_f = L_f − α_f c (L_f = Λ_f J'_f on its edge's 6 coordinates, α_f = Λ_f J_d,f/h), is
  // Σ ω L Lᵀ (per edge, Ak) − (ℓ cᵀ + c ℓᵀ) + s c cᵀ with ℓ = Σ ω_fg α_g L_f and
  // s = Σ ω_fg α_f α_g: rows h ℓ (against Cm's c/h) and √s c; N's rows v · ½√n4/h² with
  // n4 = Σ γ₂ Λ² J_d⁴ + 6 γ_xy Λ_x Λ_y J_d,x² J_d,y². Only formed when a cumulant is positive.
  const Eigen::Index Pk = kappa ? P : 0;
  Eigen::MatrixXd Lm(Pk, 6 * E), Sm(Pk, 6 * E), Vk(Pk, 6 * E);
  const double g2 = kc.gamma2, gxy = kc.gamma_xy;
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
    double sdd = 0;         // Σ J_dᵀ Λ r''
    double sk = 0, n4 = 0;  // s and n4 above
    bool any = false;
    // One factor's κ weights (above) as the 2 × 2 Ω = (ω_fg) over its two axes: s += αᵀΩα,
    // n4, and, for a factor with a pose part (L: its two axes' L_f, 6 × 2), its edge's
    // Ak += L Ω Lᵀ and ℓ += L Ω α. (An axis without weight has L_f = 0 and α_f = 0.)
    const auto kappaTerms = [&](const Eigen::Vector2d& lam, const Eigen::Vector2d& jd,
                                const Eigen::Matrix<double, 6, 2>* L, int q) {
      const double ih2 = inv_h * inv_h;
      const Eigen::Vector2d al(lam[0] * jd[0] * inv_h, lam[1] * jd[1] * inv_h);
      const double jx2 = jd[0] * jd[0], jy2 = jd[1] * jd[1];
      Eigen::Matrix2d W = Eigen::Matrix2d::Zero();
      for (int ch = 0; ch < 2; ++ch)
        if (lam[ch] > 0) {
          W(ch, ch) = g2 * jd[ch] * jd[ch] * ih2;
          n4 += g2 * lam[ch] * lam[ch] * jd[ch] * jd[ch] * jd[ch] * jd[ch];
        }
      if (gxy > 0 && lam[0] > 0 && lam[1] > 0) {
        W(0, 0) += gxy * lam[1] * jy2 / lam[0] * ih2;
        W(1, 1) += gxy * lam[0] * jx2 / lam[1] * ih2;
        W(0, 1) = W(1, 0) = 2.0 * gxy * jd[0] * jd[1] * ih2;
        n4 += 6.0 * gxy * lam[0] * lam[1] * jx2 * jy2;
      }
      const Eigen::Vector2d Wa = W * al;
      sk += al.dot(Wa);
      if (!L) return;
      const Eigen::Matrix<double, 6, 2> LW = *L * W;
      Ak[q].noalias() += LW * L->transpose();
      ell.segment<6>(6 * q).noalias() += *L * Wa;
    };
    for (int q = 0; q < E; ++q) {
      const SourceEdges::Ref& er = edges[q];
      const Eigen::Vector3d Y = transferPoint(er.R, er.t, K, x, y, d);
      if (!keepPixelFactor(o, d, Y.z())) continue;
      const double lx = o.weight_scale * s.weightPlane(er.edge, 0)[p];
      const double ly = o.weight_scale * s.weightPlane(er.edge, 1)[p];
      if (!(lx > 0) && !(ly > 0)) continue;
      const Eigen::Vector2d lam(lx, ly);
      PixelFactorLinearization f;
      linearizePixelFactorAt(Y, er.t, K, d, s.targetPlane(er.edge, 0)[p],
                             s.targetPlane(er.edge, 1)[p], &f);
      any = true;
      Eigen::Vector2d rdd;
      const Eigen::Matrix<double, 2, 6> Jp =
          pixelFactorJacobianDepthDerivative(Y, er.t, K.fx, K.fy, d, &rdd);
      const Eigen::Matrix<double, 6, 2> JpL = Jp.transpose() * lam.asDiagonal();
      const Eigen::Matrix<double, 6, 2> JjL = f.J_j.transpose() * lam.asDiagonal();
      A[q].noalias() += (JpL * inv_h) * Jp;  // one scaling of 12, not a division of 36
      if (kappa) kappaTerms(lam, f.J_d, &JpL, q);
      c.segment<6>(6 * q) = JpL * f.J_d;
      u.segment<6>(6 * q) = JjL * rdd;
      bq.segment<6>(6 * q) = JjL * f.J_d;
      sdd += f.J_d.dot(lam.asDiagonal() * rdd);
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
      if (kappa) kappaTerms(lam, f.J_d, nullptr, 0);  // no pose part: only α enters (s, n4)
    }
    ++out.depths;
    const Eigen::VectorXd v = u - bq * (sdd / h);  // the curvature score in edge coordinates
    Cm.row(cols) = c.transpose() / h;
    Vm.row(cols) = v.transpose() * (std::sqrt(0.5) / h);
    vsum.noalias() += v / (2.0 * h);
    if (kappa) {
      Lm.row(cols) = ell.transpose() * h;
      Sm.row(cols) = c.transpose() * std::sqrt(sk);
      Vk.row(cols) = v.transpose() * (0.5 * std::sqrt(n4) * inv_h * inv_h);
    }
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
  if (!kappa) return out;
  // The κ terms.
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
  return out;
}

/// γ₂ (each edge's m4 / m2², pooled by rows, minus 3) and γ_xy (each edge's E[z_x² z_y²] / m2² −
/// 1 − 2ρ², ρ the axes' correlation, pooled by pairs), clamped to [0, ∞) and [0, γ₂]; edges with
/// fewer than 8 rows or pairs are left out.
Cumulants pooledCumulants(const std::vector<EdgeMoments>& edge_moments) {
  Cumulants c;
  double rows = 0, ratio = 0, pairs = 0, joint = 0;
  for (const EdgeMoments& m : edge_moments) {
    if (m.rows < 8 || !(m.s2 > 0)) continue;
    const double m2 = m.s2 / m.rows, m4 = m.s4 / m.rows;
    ratio += m.rows * m4 / (m2 * m2);
    rows += m.rows;
    if (m.pairs < 8) continue;
    const double rho = m.cxy / m.pairs / m2;
    joint += m.pairs * (m.sxy / m.pairs / (m2 * m2) - 1.0 - 2.0 * rho * rho);
    pairs += m.pairs;
  }
  if (rows > 0) c.gamma2 = std::max(0.0, ratio / rows - 3.0);
  // At most γ₂: the per-factor 2 × 2 weights Ω are positive semi-definite only for
  // γ_xy <= γ₂ (a scale mixture has γ₂ / 3); above, M_κ could be indefinite. (γ_xy's estimate
  // has a small positive bias from the depth's own coupling of the two axes; with γ₂ at 0,
  // Gaussian noise, it is held at 0 here.)
  // (A non-finite estimate, which finite residuals cannot give, counts as none.)
  if (pairs > 0 && std::isfinite(joint / pairs))
    c.gamma_xy = std::clamp(joint / pairs, 0.0, c.gamma2);
  return c;
}

/// The moments of every edge (in edge order), from each source's (sourceMoments).
std::vector<EdgeMoments> edgeMoments(
    const std::vector<std::vector<std::pair<int, EdgeMoments>>>& per, int num_edges) {
  std::vector<EdgeMoments> out(static_cast<std::size_t>(num_edges));
  for (const auto& source : per)
    for (const auto& [e, m] : source) {
      EdgeMoments& a = out[static_cast<std::size_t>(e)];
      a.rows += m.rows;
      a.s2 += m.s2;
      a.s4 += m.s4;
      a.pairs += m.pairs;
      a.sxy += m.sxy;
      a.cxy += m.cxy;
    }
  return out;
}

}  // namespace

DepthNoiseTerms depthNoiseTerms(const Snapshot& s, const DbaOptions& o,
                                const DbaNormalEquations& ne, bool fourth_cumulants) {
  const int n = static_cast<int>(ne.keyframes.size());
  DepthNoiseTerms out;
  out.M = Eigen::MatrixXd::Zero(6 * n, 6 * n);
  out.N = Eigen::MatrixXd::Zero(6 * n, 6 * n);
  out.bias_score = Eigen::VectorXd::Zero(6 * n);
  out.M_kurtosis = Eigen::MatrixXd::Zero(6 * n, 6 * n);
  out.N_kurtosis = Eigen::MatrixXd::Zero(6 * n, 6 * n);
  // The cumulants first (a pass over the factors' residuals only), so that the κ terms are
  // formed once with them: per unit γ₂ and γ_xy they would be twice the products. (Without the
  // κ share they are still estimated, for the report.)
  std::vector<SourceEdges> edges(ne.depths.size());
  std::vector<std::vector<std::pair<int, EdgeMoments>>> per_moments(ne.depths.size());
  parallelFor(ne.depths.size(), [&](std::size_t i) {
    edges[i] = sourceEdges(s, ne, ne.depths[i]);
    per_moments[i] = sourceMoments(s, o, ne, ne.depths[i], edges[i]);
  });
  const Cumulants est = pooledCumulants(edgeMoments(per_moments, s.numEdges()));
  const Cumulants kc = fourth_cumulants ? est : Cumulants{};
  std::vector<SourceTerms> per(ne.depths.size());
  parallelFor(ne.depths.size(),
              [&](std::size_t i) { per[i] = sourceTerms(s, o, ne, ne.depths[i], edges[i], kc); });
  const bool kappa = kc.any();
  for (std::size_t i = 0; i < per.size(); ++i) {
    const std::vector<int>& touched = ne.depths[i].touched;
    const int T = static_cast<int>(touched.size());
    for (int a = 0; a < T; ++a) {
      out.bias_score.segment<6>(6 * touched[a]) += per[i].bias.segment<6>(6 * a);
      for (int b = 0; b < T; ++b) {
        out.M.block<6, 6>(6 * touched[a], 6 * touched[b]) += per[i].M.block<6, 6>(6 * a, 6 * b);
        out.N.block<6, 6>(6 * touched[a], 6 * touched[b]) += per[i].N.block<6, 6>(6 * a, 6 * b);
        if (!kappa) continue;
        out.M_kurtosis.block<6, 6>(6 * touched[a], 6 * touched[b]) +=
            per[i].Mk.block<6, 6>(6 * a, 6 * b);
        out.N_kurtosis.block<6, 6>(6 * touched[a], 6 * touched[b]) +=
            per[i].Nk.block<6, 6>(6 * a, 6 * b);
      }
    }
    out.depths += per[i].depths;
  }
  // The estimates are reported either way.
  out.kurtosis = est.gamma2;
  out.cross_kurtosis = est.gamma_xy;
  return out;
}

}  // namespace dbacov
