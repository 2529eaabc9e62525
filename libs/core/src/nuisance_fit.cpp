// The nuisance model's estimates and covariance (self_calibration.h, self_calibration_stages.h).
// Per edge, on the range of M_e (rank r), the whitened field score y = Λ^-½ Uᵀ t_e has
// Cov(y) = Σ_g σ_g² B_g + s_e I, B_g = W A_g Wᵀ (A_g = (M_s D_g M_s)_ee, W = Λ^-½ Uᵀ).
// The σ_g² maximize the likelihood of every edge's y (projected Fisher scoring, σ_g² >= 0); the
// white scale is the residual beyond the edge's own field fit |y|², corrected by what the fit is
// expected to take beyond the edge's field energy: s_e = (q_e − |y|² + Σ_g σ_g² (tr B_g −
// tr M_e,gg)) / (ρ_e − r); the two alternate. The covariance is
// Σ (S + Σ_e (s_e − 1) I_e + Σ_g σ_g² C_e,g C_e,gᵀ) Σ in the gauge's reduced coordinates.
#include <algorithm>
#include <cmath>
#include <limits>
#include <memory>
#include <stdexcept>

#include <Eigen/Cholesky>
#include <Eigen/Eigenvalues>

#include "dbacov/core/dot_products.h"
#include "dbacov/core/parallel.h"
#include "self_calibration_stages.h"

namespace dbacov::selfcal {

namespace {

/// The edge's field terms in the eigenbasis B_k = U diag(d) Uᵀ of one group k: while σ_k² is the
/// only non-zero variance component, Cv = s I + σ_k² B_k is diagonal there.
struct Eigenbasis {
  Eigen::VectorXd d, y;            ///< eigenvalues of B_k, Uᵀ y
  std::vector<Eigen::MatrixXd> B;  ///< Uᵀ B_g U (g ≠ k; empty for k)
};
struct FieldEdge {
  int edge;
  Eigen::VectorXd y;
  std::vector<Eigen::MatrixXd> B;
  Eigen::VectorXd excess;  ///< per group: tr B_g − tr M_e,gg
  double fit, dof;
  std::vector<std::unique_ptr<Eigenbasis>> basis;  ///< per group, formed when first used
};
/// One edge's log-likelihood terms at one θ.
struct EdgeTerms {
  double ll = 0;
  Eigen::VectorXd score;
  Eigen::MatrixXd info;
  RowMatrix Cinv;  ///< Cv⁻¹, kept between the score and the information
  bool ok = true;
};

class NuisanceFitter {
 public:
  NuisanceFitter(const DenseModel& m, const std::vector<EdgeAccum>& acc,
                 const std::vector<SourceTerms>& sources, const std::vector<EdgeAccum>& sensor,
                 double sensor_scale, int groups, double lo, double hi, SelfCalibration* out)
      : m_(m),
        acc_(acc),
        sources_(sources),
        sensor_(sensor),
        sensor_scale_(sensor_scale),
        G_(groups),
        lo_(lo),
        hi_(hi),
        out_(out),
        E_(static_cast<int>(acc.size())),
        se_(E_, 1.0),
        used_(E_, 0),
        theta_(Eigen::VectorXd::Zero(groups)) {}

  Eigen::MatrixXd run() {
    prepare();
    alternate();
    const int n6 = static_cast<int>(m_.Sigma.rows());
    Eigen::MatrixXd X = Eigen::MatrixXd::Zero(n6, n6);
    fieldMeat(X);
    whiteMeat(X);
    const Eigen::MatrixXd SX = m_.Sigma_r * (m_.basis.transpose() * X * m_.basis);
    Eigen::MatrixXd V = m_.Sigma_r + SX * m_.Sigma_r;
    V = 0.5 * (V + V.transpose());
    out_->nuisance_sigma = std::sqrt(theta_[0]);
    out_->nuisance_fine_sigma = G_ > 1 ? std::sqrt(theta_[1]) : 0.0;
    return V;
  }

 private:
  double clamp(double x) const { return clampScale(x, lo_, hi_); }

  /// Every edge's whitened field score and terms (FieldEdge), and its white scale without a field.
  void prepare() {
    // The field scores of the residual projected off the poses too, Φᵀ P⊥ r = t_e − C_eᵀ Σ g
    // (g the depth-reduced gradient of every row, the stereo edges' and the readings' included;
    // zero at the optimum, where this changes nothing).
    Eigen::VectorXd grad = Eigen::VectorXd::Zero(m_.Sigma.rows());
    for (const EdgeAccum& a : acc_) grad += a.g;
    for (const EdgeAccum& a : sensor_) grad += a.g;
    const Eigen::VectorXd Sg = m_.Sigma * grad;
    // Per edge in parallel (each writes only its own entries), kept in edge order.
    std::vector<std::unique_ptr<FieldEdge>> prepared(E_);
    parallelFor(static_cast<std::size_t>(E_),
                [&](std::size_t ei) { prepared[ei] = prepareEdge(static_cast<int>(ei), Sg); });
    for (std::unique_ptr<FieldEdge>& f : prepared)
      if (f) fe_.push_back(std::move(*f));
    terms_.resize(fe_.size());
  }

  std::unique_ptr<FieldEdge> prepareEdge(int e, const Eigen::VectorXd& Sg) {
    const EdgeAccum& a = acc_[e];
    const double rho = out_->edges[e].redundancy;
    if (a.depth_only) {  // a stereo edge: white noise only, its vce scale
      if (a.rows > 0 && rho > 0.5) {
        used_[e] = 1;
        se_[e] = clamp(a.q / rho);
      }
      return nullptr;
    }
    if (a.rows == 0 || !(rho > 0.5) || a.Mn.size() == 0) return nullptr;
    Eigen::VectorXd sg(6 * a.slots.size());
    for (std::size_t b = 0; b < a.slots.size(); ++b)
      sg.segment<6>(6 * b) = Sg.segment<6>(6 * a.slots[b]);
    const Eigen::VectorXd t = a.t - a.C.transpose() * sg;
    const Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd> eig(a.Mn);
    const Eigen::VectorXd& ev = eig.eigenvalues();
    // Directions that the poses and depths leave (almost) nothing of carry no information (and
    // the tents reproduce the affine field: those directions appear twice).
    const double cut = 1e-8 * std::max(ev.maxCoeff(), 0.0);
    int rank = 0;
    for (int k = 0; k < ev.size(); ++k) rank += ev[k] > cut && cut > 0;
    used_[e] = 1;
    se_[e] = clamp(a.q / rho);
    if (rank == 0) return nullptr;
    const int mn = static_cast<int>(ev.size());
    Eigen::MatrixXd W(rank, mn);
    for (int k = mn - rank, r = 0; k < mn; ++k, ++r)
      W.row(r) = eig.eigenvectors().col(k).transpose() / std::sqrt(ev[k]);
    auto f = std::make_unique<FieldEdge>();
    f->edge = e;
    f->y = W * t;
    f->excess = Eigen::VectorXd::Zero(G_);
    for (int g = 0; g < G_; ++g) {
      f->B.push_back(W * a.An[g] * W.transpose());
      double trMgg = 0;
      for (int k = 0; k < mn; ++k)
        if (a.group[k] == g) trMgg += a.Mn(k, k);
      f->excess[g] = f->B[g].trace() - trMgg;
    }
    f->fit = f->y.squaredNorm();
    f->dof = rho - rank;
    if (f->dof > 0.5) se_[e] = clamp(std::max(a.q - f->fit, 0.05 * a.q) / f->dof);
    return f;
  }

  /// The edge's eigenbasis of B_k, formed when first used (each edge only by its own index).
  const Eigenbasis& eigenbasis(FieldEdge& f, int k) const {
    if (f.basis.empty()) f.basis.resize(G_);
    if (!f.basis[k]) {
      const Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd> eig(f.B[k]);
      auto eb = std::make_unique<Eigenbasis>();
      eb->d = eig.eigenvalues();
      const Eigen::MatrixXd& U = eig.eigenvectors();
      eb->y = U.transpose() * f.y;
      eb->B.resize(G_);
      for (int g = 0; g < G_; ++g)
        if (g != k) eb->B[g] = U.transpose() * f.B[g] * U;
      f.basis[k] = std::move(eb);
    }
    return *f.basis[k];
  }

  /// One edge's log-likelihood and (with_score) score at θ; k >= 0: θ's only positive group.
  /// With Cv = L Lᵀ, z = L⁻¹ y and v = Cv⁻¹ y: yᵀCv⁻¹y = |z|², the score of σ_g² is
  /// ½ (vᵀ B_g v − ⟨Cv⁻¹, B_g⟩) (one product for Cv⁻¹ = L⁻ᵀL⁻¹ per edge, the rest quadratic).
  void edgeTerms(FieldEdge& f, EdgeTerms& et, const Eigen::VectorXd& th, int k,
                 bool with_score) const {
    if (k >= 0) {
      const Eigenbasis& eb = eigenbasis(f, k);
      const Eigen::ArrayXd c = se_[f.edge] + th[k] * eb.d.array();  // Cv's eigenvalues
      et.ok = (c > 0).all();
      if (!et.ok) return;
      const Eigen::ArrayXd ci = c.inverse(), v = eb.y.array() * ci;  // v = Cv⁻¹ y
      et.ll = -0.5 * (c.log().sum() + (eb.y.array() * v).sum());
      if (!with_score) return;
      et.score.setZero(G_);
      for (int g = 0; g < G_; ++g)
        et.score[g] = g == k ? 0.5 * ((eb.d.array() * v.square()).sum() - (eb.d.array() * ci).sum())
                             : 0.5 * (v.matrix().dot(eb.B[g] * v.matrix()) -
                                      (eb.B[g].diagonal().array() * ci).sum());
      return;
    }
    const int r = static_cast<int>(f.y.size());
    Eigen::MatrixXd Cv = se_[f.edge] * Eigen::MatrixXd::Identity(r, r);
    for (int g = 0; g < G_; ++g) Cv += th[g] * f.B[g];
    const Eigen::LLT<Eigen::MatrixXd> llt(Cv);
    et.ok = llt.info() == Eigen::Success;
    if (!et.ok) return;
    const double logdet = 2 * llt.matrixLLT().diagonal().array().log().sum();
    if (!with_score) {
      et.ll = -0.5 * (logdet + f.y.dot(llt.solve(f.y)));
      return;
    }
    // L⁻¹ (column-major: its transpose row by row, for the dot-product form of L⁻ᵀL⁻¹).
    Eigen::MatrixXd Linv = Eigen::MatrixXd::Identity(r, r);
    llt.matrixL().solveInPlace(Linv);
    const Eigen::VectorXd z = Linv * f.y;
    const Eigen::VectorXd v = Linv.transpose() * z;
    et.ll = -0.5 * (logdet + z.squaredNorm());
    et.Cinv.setZero(r, r);
    kernel::gemmNT(r, r, r, Linv.data(), r, Linv.data(), r, et.Cinv.data(), r, true);
    et.Cinv = et.Cinv.selfadjointView<Eigen::Lower>();
    et.score.setZero(G_);
    for (int g = 0; g < G_; ++g)
      et.score[g] = 0.5 * (v.dot(f.B[g] * v) - et.Cinv.cwiseProduct(f.B[g]).sum());
  }

  /// One edge's Fisher information on the free groups: ½ tr(Cv⁻¹B_g Cv⁻¹B_h) = ½ ⟨X_g, X_hᵀ⟩
  /// with X_g = Cv⁻¹ B_g (in the eigenbasis diag(1/c) B_g, B_k = diag(d); else one product).
  void edgeInformation(const FieldEdge& f, EdgeTerms& et, const Eigen::VectorXd& th, int k,
                       const std::vector<int>& free) const {
    const int r = static_cast<int>(f.y.size()), nf = static_cast<int>(free.size());
    std::vector<RowMatrix> X(nf);
    if (k >= 0) {
      const Eigenbasis& eb = *f.basis[k];
      const Eigen::VectorXd ci = (se_[f.edge] + th[k] * eb.d.array()).inverse().matrix();
      for (int a = 0; a < nf; ++a)
        X[a] = free[a] == k ? RowMatrix((ci.asDiagonal() * eb.d).asDiagonal())
                            : RowMatrix(ci.asDiagonal() * eb.B[free[a]]);
    } else {
      for (int a = 0; a < nf; ++a) {
        X[a].setZero(r, r);
        kernel::gemmNT(r, r, r, et.Cinv.data(), r, f.B[free[a]].data(), r, X[a].data(), r);
      }
    }
    et.info.setZero(G_, G_);
    for (int a = 0; a < nf; ++a)
      for (int b = 0; b <= a; ++b)
        et.info(free[a], free[b]) = et.info(free[b], free[a]) =
            0.5 * X[a].cwiseProduct(X[b].transpose()).sum();
  }

  /// The log-likelihood, its gradient and Fisher information in θ = (σ_g²) at fixed s_e: the
  /// edges' terms in parallel, summed in edge order (the same result for any number of threads).
  /// The X_g of the information only for the coordinates that the step can move (θ_g > 0 or a
  /// positive score: fisherStep's free set, the only entries it reads); info is only formed
  /// together with score (its free set needs the summed score).
  double evaluate(const Eigen::VectorXd& th, Eigen::VectorXd* score, Eigen::MatrixXd* info) {
    if (info && !score) throw std::logic_error("nuisance likelihood: information without score");
    // One variance component above zero (the others held there): every term is diagonal in
    // that group's eigenbasis (formed once per edge and group, then O(r²) per evaluation instead
    // of O(r³)). k = that group, or −1 (the general path).
    int k = -1, npositive = 0;
    for (int g = 0; g < G_; ++g)
      if (th[g] > 0) {
        k = g;
        ++npositive;
      }
    if (npositive != 1) k = -1;
    parallelFor(fe_.size(),
                [&](std::size_t fi) { edgeTerms(fe_[fi], terms_[fi], th, k, score != nullptr); });
    double ll = 0;
    if (score) *score = Eigen::VectorXd::Zero(G_);
    for (const EdgeTerms& et : terms_) {
      if (!et.ok) return -std::numeric_limits<double>::infinity();
      ll += et.ll;
      if (score) *score += et.score;
    }
    if (!info) return ll;
    *info = Eigen::MatrixXd::Zero(G_, G_);
    std::vector<int> free;
    for (int g = 0; g < G_; ++g)
      if (th[g] > 0 || (*score)[g] > 0) free.push_back(g);
    parallelFor(fe_.size(),
                [&](std::size_t fi) { edgeInformation(fe_[fi], terms_[fi], th, k, free); });
    for (const EdgeTerms& et : terms_) *info += et.info;
    return ll;
  }

  /// One projected Fisher-scoring step in θ at the current s_e (step halving: the likelihood
  /// must not drop); true when θ did not move (converged, or held at 0 by its score).
  bool fisherStep() {
    Eigen::VectorXd score;
    Eigen::MatrixXd info;
    // A covariance that is not positive definite ends the search where it is (it cannot happen
    // with s_e > 0; the partial score and information are not used). The evaluation with the
    // score also gives the likelihood at θ that the step must not lower.
    const double ll = evaluate(theta_, &score, &info);
    if (!std::isfinite(ll)) return true;
    // Coordinates held at 0 whose score points below 0 stay there.
    std::vector<int> free;
    for (int g = 0; g < G_; ++g)
      if (theta_[g] > 0 || score[g] > 0) free.push_back(g);
    if (free.empty()) return true;
    Eigen::MatrixXd F(free.size(), free.size());
    Eigen::VectorXd sc(free.size());
    for (std::size_t a = 0; a < free.size(); ++a) {
      sc[a] = score[free[a]];
      for (std::size_t b = 0; b < free.size(); ++b) F(a, b) = info(free[a], free[b]);
    }
    const Eigen::VectorXd step = F.ldlt().solve(sc);
    double alpha = 1, ll_new = ll;
    Eigen::VectorXd next = theta_;
    for (int half = 0; half < 30; ++half, alpha *= 0.5) {
      next = theta_;
      for (std::size_t a = 0; a < free.size(); ++a)
        next[free[a]] = std::max(0.0, theta_[free[a]] + alpha * step[a]);
      ll_new = evaluate(next, nullptr, nullptr);
      if (ll_new >= ll - 1e-12 * std::abs(ll)) break;
    }
    const double moved = (next - theta_).norm();
    theta_ = next;
    return ll_new - ll <= 1e-10 * std::max(1.0, std::abs(ll)) ||
           moved <= 1e-7 * std::max(theta_.norm(), 1e-300);
  }

  /// θ and the s_e jointly: one Fisher step in θ, then the s_e given θ, until neither moves. The
  /// fixed point is that of converging θ at each s_e in turn (the alternation's), reached with
  /// fewer likelihood evaluations (24 against 63 on the shared snapshot at the tolerance of 1e-8
  /// that the stop rule below had then; the covariances agreed to 3e-9).
  void alternate() {
    for (int round = 0; round < 500 && !fe_.empty(); ++round) {
      const bool theta_done = fisherStep();
      // The white scales given σ² (at least 5 % of the residual stays white: the field cannot
      // explain all of it).
      double change = 0;
      for (const FieldEdge& f : fe_) {
        if (!(f.dof > 0.5)) continue;
        const double q = acc_[f.edge].q;
        const double next =
            clamp(std::max(q - f.fit + theta_.head(G_).dot(f.excess), 0.05 * q) / f.dof);
        change = std::max(change, std::abs(next / se_[f.edge] - 1.0));
        se_[f.edge] = next;
      }
      // The alternation contracts by about 0.15 a round (shared snapshot): a last change below
      // 1e-6 leaves the s_e within about 2e-7 of the fixed point (1e-8 took three more rounds,
      // each a score evaluation on every edge, for digits far below the estimates' precision).
      if (change < 1e-6 && theta_done) break;
    }
  }

  /// The edges' results, and the fields' Σ_g σ_g² C_e,g C_e,gᵀ added to X.
  void fieldMeat(Eigen::MatrixXd& X) {
    for (int e = 0; e < E_; ++e) {
      const EdgeAccum& a = acc_[e];
      EdgeCalibration& ec = out_->edges[e];
      ec.inflation = used_[e] ? se_[e] : 1.0;
      double field_sc = 0;  // Σ_g σ_g² tr(C_gᵀ Σ C_g)
      for (int k = 0; k < static_cast<int>(a.group.size()); ++k)
        field_sc += theta_[a.group[k]] * a.CSC_diag[k];
      ec.correlation = used_[e] && a.tr_SI > 0 ? 1.0 + field_sc / (se_[e] * a.tr_SI) : 1.0;
      ec.effective_pixels = ec.pixels / ec.correlation;
      if (!used_[e]) continue;
      Eigen::MatrixXd Xe = Eigen::MatrixXd::Zero(a.C.rows(), a.C.rows());
      for (int k = 0; k < static_cast<int>(a.group.size()); ++k)
        Xe.noalias() += theta_[a.group[k]] * a.C.col(k) * a.C.col(k).transpose();
      const int T = static_cast<int>(a.slots.size());
      for (int p = 0; p < T; ++p)
        for (int q = 0; q < T; ++q)
          X.block<6, 6>(6 * a.slots[p], 6 * a.slots[q]) += Xe.block<6, 6>(6 * p, 6 * q);
    }
  }

  /// Σ_e (s_e − 1) I_e added to X, per source from the factors of its edges' I_e (EdgeAccum):
  /// with f_e = s_e − 1 and ω = Σ_e f_e w_e (per pixel), Σ_e f_e I_e = Σ_e f_e (P_e Auu_e P_eᵀ −
  /// P_e X_e − X_eᵀ P_eᵀ) + B diag(ω) Bᵀ: one 6T × HW × 6T product per source (its lower
  /// triangle). The factors on the depths alone (stereo edges, the sensor readings with the
  /// scale shared by all sources) add only to ω. The sources in parallel, added to X in source
  /// order (the same sums for any thread count).
  void whiteMeat(Eigen::MatrixXd& X) const {
    std::vector<Eigen::MatrixXd> per_source(sources_.size());
    parallelFor(sources_.size(), [&](std::size_t si) { per_source[si] = sourceWhiteMeat(si); });
    for (std::size_t si = 0; si < sources_.size(); ++si) {
      const SourceTerms& st = sources_[si];
      const Eigen::MatrixXd& Xs = per_source[si];
      if (Xs.size() == 0) continue;
      const int T = static_cast<int>(st.touched.size());
      for (int p = 0; p < T; ++p)
        for (int q = 0; q < T; ++q)
          X.block<6, 6>(6 * st.touched[p], 6 * st.touched[q]) += Xs.block<6, 6>(6 * p, 6 * q);
    }
  }

  /// One source's Σ_e (s_e − 1) I_e on its slots (6T × 6T; empty when nothing changes).
  Eigen::MatrixXd sourceWhiteMeat(std::size_t si) const {
    const SourceTerms& st = sources_[si];
    if (st.B.size() == 0) return {};
    const int T6 = static_cast<int>(st.B.rows()), HW = static_cast<int>(st.B.cols());
    Eigen::VectorXd omega = Eigen::VectorXd::Zero(HW);
    // f Σ_p w_p B_p B_pᵀ of a factor's depth share: f w on its pixels' ω.
    const auto addOmega = [&](const EdgeAccum& a, double f) {
      for (std::size_t pix = 0; pix < a.pixel_of.size(); ++pix)
        omega[a.pixel_of[pix]] += f * a.w[static_cast<Eigen::Index>(pix)];
    };
    Eigen::MatrixXd Xs = Eigen::MatrixXd::Zero(T6, T6);
    bool any = false;
    for (int e = 0; e < E_; ++e) {
      const EdgeAccum& a = acc_[e];
      if (a.source != static_cast<int>(si) || !used_[e]) continue;
      const double f = se_[e] - 1.0;
      if (f == 0) continue;
      any = true;
      addOmega(a, f);
      if (a.depth_only) continue;
      for (int i = 0; i < 12; ++i) {
        for (int j = 0; j < 12; ++j) Xs(a.idx[i], a.idx[j]) += f * a.Auu(i, j);
        Xs.row(a.idx[i]) -= f * a.cross.row(i);
        Xs.col(a.idx[i]) -= f * a.cross.row(i).transpose();
      }
    }
    if (si < sensor_.size() && sensor_[si].rows > 0 && sensor_scale_ != 1.0) {
      addOmega(sensor_[si], sensor_scale_ - 1.0);
      any = true;
    }
    if (!any) return {};
    const RowMatrix Bw = st.B * omega.asDiagonal();
    RowMatrix BwB = RowMatrix::Zero(T6, T6);
    kernel::gemmNT(T6, T6, HW, Bw.data(), HW, st.B.data(), HW, BwB.data(), T6, true);
    Xs += Eigen::MatrixXd(BwB.selfadjointView<Eigen::Lower>());
    return Xs;
  }

  const DenseModel& m_;
  const std::vector<EdgeAccum>& acc_;
  const std::vector<SourceTerms>& sources_;
  const std::vector<EdgeAccum>& sensor_;
  const double sensor_scale_;
  const int G_;  // variance components (every edge's group indices are below it)
  const double lo_, hi_;
  SelfCalibration* out_;
  const int E_;
  std::vector<double> se_;
  std::vector<char> used_;
  std::vector<FieldEdge> fe_;
  std::vector<EdgeTerms> terms_;
  Eigen::VectorXd theta_;
};

}  // namespace

Eigen::MatrixXd nuisanceCovariance(const DenseModel& m, const std::vector<EdgeAccum>& acc,
                                   const std::vector<SourceTerms>& sources,
                                   const std::vector<EdgeAccum>& sensor, double sensor_scale,
                                   int groups, double lo, double hi, SelfCalibration* out) {
  return NuisanceFitter(m, acc, sources, sensor, sensor_scale, groups, lo, hi, out).run();
}

}  // namespace dbacov::selfcal
