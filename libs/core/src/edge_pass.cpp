// The self-calibration's pass over every edge's residuals (self_calibration_stages.h): per source
// keyframe in parallel, the rows (pixel, axis) of each edge leaving it at the snapshot's state,
// their depth reduction, and per edge the sums of self_calibration.h's notation (q, leverage,
// tr(Σ I_e), the depth-reduced score) and, for the nuisance model, the field's sums. Σ is the
// model's dense pose covariance.
#include <algorithm>
#include <cmath>
#include <vector>

#include "dbacov/core/dba_factor.h"
#include "dbacov/core/dot_products.h"
#include "dbacov/core/parallel.h"
#include "dbacov/core/se3.h"
#include "depth_only_factors.h"
#include "self_calibration_stages.h"

namespace dbacov::selfcal {

namespace {

/// The nuisance sums run on at most kMono monomials per pixel and kMaxActive active basis
/// coordinates (NuisanceBasis), in fixed-capacity storage.
constexpr int kMono = 4, kMaxActive = 7;
using ActiveMatrix = Eigen::Matrix<double, kMaxActive, kMaxActive>;
/// A spline cell's T_cell (row-major, padded to kMaxActive × kMono with zeros: fixed-size
/// products; only the first active() rows are scattered).
using CellMap = Eigen::Map<const Eigen::Matrix<double, kMaxActive, kMono, Eigen::RowMajor>>;
using Matrix6x12 = Eigen::Matrix<double, 6, 12>;

/// One row (pixel, axis) of an edge. Only ∂r/∂ξ_j is kept: ∂r/∂ξ_i = −J_j Ad(T_ji) (as in the
/// kernel, dba_kernel.h), so the row's 12 pose coordinates are u = Eᵀ w with w = √λ J_jᵀ and the
/// edge's E = [−Ad(T_ji) | I] (6 × 12), and every per-row sum below runs on the 6 entries of w.
struct Row {
  int pixel, channel;
  double lam, r, jd;
  Eigen::Matrix<double, 1, 6> Jj;
};

/// Nuisance: every grid pixel's active basis coordinates, monomials and spline cell, and every
/// cell's map T from the monomials to the active values (NuisanceBasis; the sums run on the
/// monomials, so the values themselves are not kept).
struct FieldTable {
  std::vector<int> index, cell;
  std::vector<double> mono, T;
  std::vector<std::vector<int>> pixels_of_cell;

  FieldTable() = default;
  FieldTable(const NuisanceBasis& nuisance, int H, int W) {
    const int HW = H * W;
    const std::size_t na = static_cast<std::size_t>(nuisance.active());
    index.resize(na * HW);
    std::vector<double> value(na);
    cell.resize(HW);
    pixels_of_cell.resize(static_cast<std::size_t>(nuisance.cells()));
    for (int px = 0; px < HW; ++px) {
      cell[px] = nuisance.eval(px % W, px / W, &index[na * px], value.data());
      pixels_of_cell[cell[px]].push_back(px);
    }
    // Stored kMono wide (the affine basis's three monomials padded with a zero).
    const std::size_t nm = static_cast<std::size_t>(nuisance.monomials());
    mono.assign(kMono * HW, 0.0);
    for (int px = 0; px < HW; ++px) nuisance.monomial(px % W, px / W, &mono[kMono * px]);
    T.assign(kMaxActive * kMono * static_cast<std::size_t>(nuisance.cells()), 0.0);
    std::vector<double> Tn(na * nm);
    for (int c = 0; c < nuisance.cells(); ++c) {
      nuisance.cellTransform(c, Tn.data());
      for (std::size_t u = 0; u < na; ++u)
        for (std::size_t j = 0; j < nm; ++j) T[(kMaxActive * c + u) * kMono + j] = Tn[u * nm + j];
    }
  }
  CellMap cellMap(std::size_t c) const { return CellMap(&T[c * kMaxActive * kMono]); }
  /// The active coordinates of the pixels of cell c (the same for all of them).
  const int* active(std::size_t c, int na) const {
    return &index[static_cast<std::size_t>(pixels_of_cell[c][0]) * na];
  }
};

/// Per spline cell and channel (index 2·cell + channel), the sums of one edge's rows on the
/// pixels' monomials m: Σ √λ w mᵀ, Σ λ m mᵀ and the score's Σ m (√λ r − depth's share).
struct CellSums {
  std::vector<Eigen::Matrix<double, 6, kMono>> CUm;
  std::vector<Eigen::Matrix<double, kMono, kMono>> Nm;
  std::vector<Eigen::Matrix<double, kMono, 1>> tm;
  std::vector<char> in_cell;
  explicit CellSums(int ncell)
      : CUm(2 * ncell), Nm(2 * ncell), tm(2 * ncell), in_cell(static_cast<std::size_t>(ncell), 0) {
    for (int ic = 0; ic < 2 * ncell; ++ic) {
      CUm[ic].setZero();
      Nm[ic].setZero();
      tm[ic].setZero();
    }
  }
};

/// The edges leaving one source keyframe, their rows and depth reduction, and the sums of each.
class SourcePass {
 public:
  SourcePass(const Snapshot& s, const DbaOptions& o, const DenseModel& m,
             const NuisanceBasis* nuisance, const FieldTable& field, int src, int si)
      : s_(s),
        o_(o),
        m_(m),
        nuisance_(nuisance),
        field_(field),
        src_(src),
        si_(si),
        HW_(static_cast<int>(s.pixelsPerFrame())) {}

  void run(std::vector<EdgeAccum>& acc, std::vector<SourceTerms>* source_terms,
           std::vector<EdgeAccum>* sensor) {
    collectEdges();
    gatherRows();
    addDepthOnlyFactors();
    reduceDepths();
    for (std::size_t k = 0; k < stereo_.size(); ++k)
      depthOnlyAccum(depth_only_[k], acc[stereo_[k]]);
    if (sensor) depthOnlyAccum(depth_only_.back(), (*sensor)[si_]);
    if (nuisance_) {
      mn_ = 2 * nuisance_->perChannel();
      b_src_ = Eigen::MatrixXd::Zero(2 * Q_, HW_);
      n_raw_ = Eigen::MatrixXd::Zero(Q_ * mn_, Q_ * mn_);
    }
    for (int q = 0; q < Q_; ++q) edgeSums(q, acc[edges_[q]]);
    if (nuisance_) {
      coupleFields(acc);
      if (source_terms) (*source_terms)[si_] = SourceTerms{touched_, std::move(B_rows_)};
    }
  }

 private:
  /// The source's edges (a stereo edge (k, k) apart), the slots they touch, Σ on those slots
  /// and each edge's relative pose.
  void collectEdges() {
    const int E = s_.numEdges();
    touched_ = {m_.ne.slot_of[src_]};
    for (int e = 0; e < E; ++e) {
      if (s_.ii[e] != src_) continue;
      // A stereo edge (k, k) is a factor on the depths alone (fixed rig transform; conventions
      // §2, depth_only_factors.h): it has no pose rows; its depth information enters every
      // pixel's h and gradient below, as in the linearization, and its residuals give it a
      // variance component of its own (depthOnlyAccum).
      if (s_.jj[e] == src_) {
        stereo_.push_back(e);
        continue;
      }
      const int slot = m_.ne.slot_of[s_.jj[e]];
      auto it = std::find(touched_.begin(), touched_.end(), slot);
      tpos_.push_back(static_cast<int>(it - touched_.begin()));
      if (it == touched_.end()) touched_.push_back(slot);
      edges_.push_back(e);
    }
    T_ = static_cast<int>(touched_.size());
    Q_ = static_cast<int>(edges_.size());
    Sig_.resize(6 * T_, 6 * T_);
    for (int a = 0; a < T_; ++a)
      for (int b = 0; b < T_; ++b)
        Sig_.block<6, 6>(6 * a, 6 * b) = m_.Sigma.block<6, 6>(6 * touched_[a], 6 * touched_[b]);
    R_.resize(Q_);
    t_.resize(Q_);
    Em_.resize(Q_);  // E = [−Ad(T_ji) | I]: u = Eᵀ w
    const Eigen::Isometry3d T_wc_i = s_.T_wc(src_);
    for (int q = 0; q < Q_; ++q) {
      const Eigen::Isometry3d T_ji = s_.T_cw(static_cast<int>(s_.jj[edges_[q]])) * T_wc_i;
      R_[q] = T_ji.linear();
      t_[q] = T_ji.translation();
      Em_[q].leftCols<6>() = -adjoint(T_ji);
      Em_[q].rightCols<6>().setIdentity();
    }
  }

  /// Rows of every edge, and the depth terms h, b of every pixel. The pixels' depth columns
  /// B_p = Σ λ J_d [J_i | J_j]ᵀ: the target slot's half Σ λ J_d J_jᵀ per edge (Bj, one 6 × HW
  /// block per edge, added to B below), the source slot's half −Ad(T_ji)ᵀ times it (one 6 × 6 ×
  /// HW product per edge).
  void gatherRows() {
    const PinholeIntrinsics K = PinholeIntrinsics::fromVector(s_.intrinsics);
    rows_.resize(Q_);
    for (auto& r : rows_) r.reserve(static_cast<std::size_t>(2 * HW_));
    first_rows_.resize(Q_);  // per edge, where each pixel's rows begin
    for (auto& f : first_rows_) f.reserve(static_cast<std::size_t>(HW_) + 1);
    h_.assign(HW_, 0.0);   // depth information
    gd_.assign(HW_, 0.0);  // and gradient Σ λ J_d r
    B_ = Eigen::MatrixXd::Zero(6 * T_, HW_);
    Eigen::MatrixXd Bj = Eigen::MatrixXd::Zero(6 * Q_, HW_);
    PixelFactorLinearization f;  // (its J_i is not formed: above)
    for (int p = 0; p < HW_; ++p) {
      const double d = s_.disps[static_cast<std::size_t>(src_) * HW_ + p];
      if (!(d > 0)) continue;
      const double x = p % s_.W, y = p / s_.W;
      for (int q = 0; q < Q_; ++q) {
        const int e = edges_[q];
        const double lam[2] = {o_.weight_scale * s_.weightPlane(e, 0)[p],
                               o_.weight_scale * s_.weightPlane(e, 1)[p]};
        if (!(lam[0] > 0 || lam[1] > 0)) continue;
        const Eigen::Vector3d Y = transferPoint(R_[q], t_[q], K, x, y, d);
        if (!keepPixelFactor(o_, d, Y.z())) continue;
        linearizePixelFactorAt(Y, t_[q], K, d, s_.targetPlane(e, 0)[p], s_.targetPlane(e, 1)[p],
                               &f);
        first_rows_[q].push_back(static_cast<int>(rows_[q].size()));
        double* bj = &Bj(6 * q, p);
        for (int c = 0; c < 2; ++c) {
          if (!(lam[c] > 0)) continue;
          Row r{p, c, lam[c], f.r[c], f.J_d[c], f.J_j.row(c)};
          h_[p] += lam[c] * r.jd * r.jd;
          gd_[p] += lam[c] * r.jd * r.r;
          const double lj = lam[c] * r.jd;
          for (int i = 0; i < 6; ++i) bj[i] += lj * r.Jj[i];
          rows_[q].push_back(r);
        }
      }
    }
    for (int q = 0; q < Q_; ++q) {
      B_.middleRows<6>(6 * tpos_[q]) += Bj.middleRows<6>(6 * q);
      B_.topRows<6>().noalias() += Em_[q].leftCols<6>().transpose() * Bj.middleRows<6>(6 * q);
    }
  }

  /// The factors on the depths alone (stereo edges, RGB-D sensor depths): information and
  /// gradient of the pixel's depth, as linearizeDba adds them before eliminating it; each stereo
  /// edge and the sensor readings apart (the sensor's last), for their variance components.
  void addDepthOnlyFactors() {
    // The stereo edges' terms without the sensor's (each factor on the depths alone on its own).
    DbaOptions o_stereo = o_;
    o_stereo.sensor_depth_weight = 0;
    for (int e : stereo_) depth_only_.push_back(detail::depthOnlyTerms(s_, o_stereo, src_, {e}));
    depth_only_.push_back(detail::depthOnlyTerms(s_, o_, src_, {}));
    for (const detail::DepthOnlyTerms& terms : depth_only_)
      if (terms.any)
        for (int p = 0; p < HW_; ++p) {
          h_[p] += terms.h[p];
          gd_[p] += terms.g[p];
        }
  }

  /// Every depth-reduced row is v_k = u_k − c_k B_p (u_k = √λ [J_i | J_j] on two slots, c_k =
  /// √λ J_d / h_p, B_p the pixel's depth column shared by all its rows), so the products with Σ
  /// are done once per source (ΣB) and per row on the 6 entries of w (Row), and the edge's 6T ×
  /// 6T sums are a 12 × 12 block, a 12 × 6T cross term and one rank update over the edge's
  /// pixels, instead of dense 6T × rows products (≈ 10× fewer flops on DROID-sized windows). (The
  /// products over pixels here and below run in dot-product form, dot_products.h.)
  void reduceDepths() {
    SB_ = Eigen::MatrixXd::Zero(6 * T_, HW_);  // column p: Σ B_p
    kernel::gemmNT(HW_, 6 * T_, 6 * T_, B_.data(), 6 * T_, Sig_.data(), 6 * T_, SB_.data(), 6 * T_);
    // Nuisance: B with its rows along the pixels, for the cross terms X_e and SourceTerms.
    if (nuisance_) B_rows_ = RowMatrix(B_);
    bSb_.resize(HW_);
    for (int p = 0; p < HW_; ++p) bSb_[p] = B_.col(p).dot(SB_.col(p));
  }

  /// A factor on the depths alone, in the notation above with u = 0: its rows at pixel p (depth
  /// information h_t = Σ λ J_d², gradient Σ λ J_d r) have v = −(√λ J_d / h_p) B_p, so
  /// lev = h_t (1/h_p + B_pᵀ Σ B_p / h_p²), g = −Σ_p (Σ λ J_d r / h_p) B_p, I = Σ_p w_p B_p B_pᵀ
  /// with w_p = h_t / h_p².
  void depthOnlyAccum(const detail::DepthOnlyTerms& dt, EdgeAccum& a) const {
    a.depth_only = true;
    a.rows = dt.rows;
    a.pixels = dt.factors_used;
    a.q = dt.chi2;
    a.sum_r2 = dt.sum_r2;
    a.source = si_;
    if (!dt.any) return;
    Eigen::VectorXd g = Eigen::VectorXd::Zero(6 * T_);
    std::vector<double> w;
    for (int p = 0; p < HW_; ++p) {
      const double hp = h_[p];
      if (!(dt.h[p] > 0) || !(hp > o_.depth_info_eps)) continue;
      a.lev += dt.h[p] / hp * (1.0 + bSb_[p] / hp);
      g.noalias() -= (dt.g[p] / hp) * B_.col(p);
      a.pixel_of.push_back(p);
      w.push_back(dt.h[p] / (hp * hp));
      a.tr_SI += w.back() * bSb_[p];
    }
    a.w = Eigen::Map<const Eigen::VectorXd>(w.data(), static_cast<Eigen::Index>(w.size()));
    for (int b = 0; b < T_; ++b) a.g.segment<6>(6 * touched_[b]) = g.segment<6>(6 * b);
  }

  /// One edge's sums: q, the leverages, tr(Σ I_e) from I's factors, the depth-reduced score g and
  /// (nuisance) the field's sums, cell by cell.
  void edgeSums(int q, EdgeAccum& a) {
    const std::vector<Row>& rq = rows_[q];
    const int M = static_cast<int>(rq.size());
    if (M == 0) return;
    // The 12 coordinates of u within the 6T of the source's slots (every sum below scatters by
    // adding, so a repeated coordinate would add up).
    std::array<int, 12> idx;
    for (int i = 0; i < 6; ++i) {
      idx[i] = i;
      idx[6 + i] = 6 * tpos_[q] + i;
    }
    Matrix12d S12;
    for (int r = 0; r < 12; ++r)
      for (int c = 0; c < 12; ++c) S12(r, c) = Sig_(idx[r], idx[c]);
    std::vector<int>& first_row = first_rows_[q];  // the edge's pixels (rows come pixel by pixel)
    const int P = static_cast<int>(first_row.size());
    first_row.push_back(M);
    // Everything per row and pixel runs on w_k = √λ J_jᵀ (u_k = Eᵀ w_k, Row) and is mapped to the
    // 12 coordinates by E once per edge: Σ u uᵀ = Eᵀ (Σ w wᵀ) E, uᵀ x = wᵀ (E x).
    const Matrix6x12& E12 = Em_[q];
    const Matrix6d S6 = E12 * S12 * E12.transpose();
    // The rows' w_k, one column each (stored row by row: Σ w wᵀ is then one product in
    // dot-product form instead of 6 × 6 per row), and the per-pixel sums: Σ_k c_k w_k, the
    // square root of Σ c_k², (Σ c_k u_k)ᵀ (ΣB_p)_idx as wᵀ E (ΣB_p)_idx, Σ √λ r c_k.
    Eigen::Matrix<double, 6, Eigen::Dynamic, Eigen::RowMajor> Wm(6, M);
    Eigen::VectorXd sr(M), lev(M);
    Eigen::Matrix<double, 6, Eigen::Dynamic> Acr(6, P);
    Eigen::VectorXd wsq(P), acr_sb(P), gamma(P);
    // Nuisance: the field's whitened columns φ_k = √λ Φ(x, y) on the row's channel, on each
    // pixel's active coordinates. Per spline cell and channel the sums run on the pixels'
    // monomials m (the active values are T_cell m), mapped to the cell's active coordinates by
    // T_cell once per cell (nuisanceEdge); per pixel the depth's share b_c = Σ_{rows of channel c}
    // λ J_d.
    CellSums cells(nuisance_ ? nuisance_->cells() : 0);
    for (int pix = 0; pix < P; ++pix) {
      const int px = rq[first_row[pix]].pixel;
      const double hp = h_[px];
      const bool reduced = hp > o_.depth_info_eps;
      Vector12d sb12;
      for (int i = 0; i < 12; ++i) sb12[i] = SB_(idx[i], px);
      const Vector6d sb = E12 * sb12;
      Vector6d acr = Vector6d::Zero();
      double w = 0, gam = 0;
      double bc[2] = {0.0, 0.0};  // nuisance: Σ λ J_d per channel
      const double* mono = nuisance_ ? &field_.mono[static_cast<std::size_t>(kMono) * px] : nullptr;
      for (int k = first_row[pix]; k < first_row[pix + 1]; ++k) {
        const Row& r = rq[k];
        const double sl = std::sqrt(r.lam);
        const Vector6d u = sl * r.Jj.transpose();  // w_k (u_k = Eᵀ w_k)
        Wm.col(k) = u;
        const double c = reduced ? sl * r.jd / hp : 0.0;
        sr[k] = sl * r.r;
        a.sum_r2 += r.r * r.r;
        lev[k] = -2 * c * u.dot(sb) + c * c * bSb_[px] + (reduced ? r.lam * r.jd * r.jd / hp : 0.0);
        acr += c * u;
        w += c * c;
        gam += sr[k] * c;
        if (nuisance_) {
          const int ic = 2 * field_.cell[px] + r.channel;
          const Eigen::Map<const Eigen::Matrix<double, kMono, 1>> mo(mono);
          cells.CUm[ic].noalias() += u * (sl * mo).transpose();
          cells.tm[ic] += sr[k] * sl * mo;
          cells.Nm[ic].noalias() += (r.lam * mo) * mo.transpose();
          bc[r.channel] += r.lam * r.jd;
        }
      }
      if (nuisance_) {
        const int cell = field_.cell[px];
        cells.in_cell[cell] = 1;
        if (reduced) {
          const Eigen::Map<const Eigen::Matrix<double, kMono, 1>> mo(mono);
          for (int c = 0; c < 2; ++c) {
            cells.tm[2 * cell + c] -= (bc[c] * gd_[px] / hp) * mo;
            b_src_(2 * q + c, px) = bc[c] / std::sqrt(hp);
          }
        }
      }
      Acr.col(pix) = acr;
      acr_sb[pix] = acr.dot(sb);
      wsq[pix] = std::sqrt(w);
      gamma[pix] = gam;
    }
    // Σ w wᵀ in dot-product form on the rows of Wm, written row-major below the diagonal, i.e.
    // above it in Matrix6d's column order; Σ u uᵀ = Eᵀ (Σ w wᵀ) E.
    Matrix6d Aww = Matrix6d::Zero();
    kernel::gemmNT(6, 6, M, Wm.data(), M, Wm.data(), M, Aww.data(), 6, true);
    Aww = Aww.selfadjointView<Eigen::Upper>();
    const Matrix12d Auu = E12.transpose() * Aww * E12;
    // The leverages' u_kᵀ Σ₁₂ u_k = w_kᵀ S6 w_k, summed: tr(S6 Σ w wᵀ).
    const double tr_Sww = S6.cwiseProduct(Aww).sum();
    const Vector12d gu = E12.transpose() * (Wm * sr);
    a.rows = M;
    a.pixels = P;
    a.q = sr.squaredNorm();
    a.lev = lev.sum() + tr_Sww;
    // g = Σ sr_k v_k; tr(Σ I) from I's factors, I = Σ v_k v_kᵀ = [Σ u uᵀ] − [Σ c u Bᵀ + transpose]
    // + Σ (Σ c²) B Bᵀ: tr(S6 Σ w wᵀ) − 2 Σ_p acr_pᵀ E (ΣB_p)_idx + Σ_p w_p B_pᵀ Σ B_p (acr_p = Σ c
    // w, 6 entries). The nuisance model needs I itself only as Σ_e (s_e − 1) I_e, formed per
    // source once the s_e are known (nuisanceCovariance).
    Eigen::VectorXd g = Eigen::VectorXd::Zero(6 * T_);
    for (int pix = 0; pix < P; ++pix) g.noalias() -= gamma[pix] * B_.col(rq[first_row[pix]].pixel);
    for (int i = 0; i < 12; ++i) g[idx[i]] += gu[i];
    double tr = tr_Sww;
    for (int pix = 0; pix < P; ++pix) {
      const int px = rq[first_row[pix]].pixel;
      tr += wsq[pix] * wsq[pix] * bSb_[px] - 2 * acr_sb[pix];
    }
    a.tr_SI = tr;
    for (int b = 0; b < T_; ++b) a.g.segment<6>(6 * touched_[b]) = g.segment<6>(6 * b);
    if (!nuisance_) return;
    a.source = si_;
    a.idx = idx;
    a.Auu = Auu;
    a.w = wsq.cwiseAbs2();
    a.pixel_of.resize(P);
    for (int pix = 0; pix < P; ++pix) a.pixel_of[pix] = rq[first_row[pix]].pixel;
    a.slots = touched_;
    {
      RowMatrix acr_all = RowMatrix::Zero(6, HW_);  // the edge's Σ c w on every pixel
      for (int pix = 0; pix < P; ++pix) acr_all.col(a.pixel_of[pix]) = Acr.col(pix);
      RowMatrix cross = RowMatrix::Zero(6, 6 * T_);
      kernel::gemmNT(6, 6 * T_, HW_, acr_all.data(), HW_, B_rows_.data(), HW_, cross.data(),
                     6 * T_);
      a.cross = E12.transpose() * cross;
    }
    fieldSums(q, cells, a);
  }

  /// The edge's field sums from its cell sums: C = Σ_k v_k φ_kᵀ = Σ u φᵀ − Σ_p B_p (b_c(p) / h_p)
  /// φ(p)ᵀ (the first term here, the second per source in coupleFields: one product per spline
  /// cell for all the source's edges), the score t and the block Σ φφᵀ of M_s.
  void fieldSums(int q, const CellSums& cells, EdgeAccum& a) {
    const int mb = nuisance_->perChannel(), na = nuisance_->active();
    const Matrix6x12& E12 = Em_[q];
    Eigen::MatrixXd Cn = Eigen::MatrixXd::Zero(6 * T_, mn_);
    Eigen::VectorXd tn = Eigen::VectorXd::Zero(mn_);
    Eigen::MatrixXd Nn = Eigen::MatrixXd::Zero(mn_, mn_);
    for (int ci = 0; ci < nuisance_->cells(); ++ci) {
      if (!cells.in_cell[ci]) continue;
      const CellMap Tc = field_.cellMap(static_cast<std::size_t>(ci));
      const int* act = field_.active(static_cast<std::size_t>(ci), na);
      for (int c = 0; c < 2; ++c) {
        const int ic = 2 * ci + c;
        const Eigen::Matrix<double, 12, kMaxActive> cu =
            E12.transpose() * (cells.CUm[ic] * Tc.transpose());
        const ActiveMatrix nn = Tc * cells.Nm[ic] * Tc.transpose();
        const Eigen::Matrix<double, kMaxActive, 1> tt = Tc * cells.tm[ic];
        for (int u = 0; u < na; ++u) {
          const int col = c * mb + act[u];
          for (int i = 0; i < 12; ++i) Cn(a.idx[i], col) += cu(i, u);
          tn[col] += tt[u];
          for (int w = 0; w < na; ++w) Nn(col, c * mb + act[w]) += nn(u, w);
        }
      }
    }
    n_raw_.block(q * mn_, q * mn_, mn_, mn_) = Nn;
    a.C = std::move(Cn);
    a.t = tn;
    a.group.resize(mn_);
    for (int k = 0; k < mn_; ++k) a.group[k] = nuisance_->groupOf(k);
  }

  /// The fields' information after the poses and depths, jointly over the source's edges:
  /// M_s = blockdiag(Σ φφᵀ) − Σ_p β_p β_pᵀ / h_p − C_sᵀ Σ C_s. Each edge keeps its diagonal block
  /// M_e and (M_s D_g M_s)_ee, the covariance of its field score per unit σ_g² including what the
  /// other edges' fields put into it.
  void coupleFields(std::vector<EdgeAccum>& acc) {
    Eigen::MatrixXd Ms = n_raw_;
    subtractDepthShares(acc, Ms);
    Eigen::MatrixXd Cs = Eigen::MatrixXd::Zero(6 * T_, Q_ * mn_);
    for (int q = 0; q < Q_; ++q)
      if (acc[edges_[q]].C.size() > 0) Cs.middleCols(q * mn_, mn_) = acc[edges_[q]].C;
    {
      const Eigen::MatrixXd SC = Sig_ * Cs;
      RowMatrix CSC = RowMatrix::Zero(Q_ * mn_, Q_ * mn_);
      kernel::gemmNT(Q_ * mn_, Q_ * mn_, 6 * T_, Cs.data(), 6 * T_, SC.data(), 6 * T_, CSC.data(),
                     Q_ * mn_, true);
      Ms -= RowMatrix(CSC.selfadjointView<Eigen::Lower>());
      // diag(C_eᵀ Σ C_e): the diagonal of the edge's block of C_sᵀ Σ C_s.
      for (int q = 0; q < Q_; ++q) {
        EdgeAccum& a = acc[edges_[q]];
        if (a.C.size() > 0) a.CSC_diag = CSC.diagonal().segment(q * mn_, mn_);
      }
    }
    Ms = 0.5 * (Ms + Ms.transpose()).eval();
    const int G = nuisance_->groups();
    for (int q = 0; q < Q_; ++q) {
      EdgeAccum& a = acc[edges_[q]];
      if (a.C.size() == 0) continue;
      a.Mn = Ms.block(q * mn_, q * mn_, mn_, mn_);
      a.An.assign(G, Eigen::MatrixXd::Zero(mn_, mn_));
      for (int g = 0; g < G; ++g) {
        // The edge's rows of M_s on group g's columns, gathered column by column into row-major
        // storage for the product.
        std::vector<int> cols;
        for (int k = 0; k < Q_ * mn_; ++k)
          if (nuisance_->groupOf(k % mn_) == g) cols.push_back(k);
        const int ng = static_cast<int>(cols.size());
        RowMatrix Rg(mn_, ng);
        for (int j = 0; j < ng; ++j) Rg.col(j) = Ms.col(cols[j]).segment(q * mn_, mn_);
        kernel::gemmNT(mn_, mn_, ng, Rg.data(), ng, Rg.data(), ng, a.An[g].data(), mn_, true);
        a.An[g] = a.An[g].selfadjointView<Eigen::Upper>();  // row-major lower = upper here
      }
    }
  }

  /// The depths' share of M_s and of every edge's C, cell by cell (the cell's pixels touch the
  /// same coordinates of every edge, (q, c, active u) -> q·mn + c·mb + index[u]), on the
  /// monomials with Z = [b_p ⊗ m_p] (2Q·4 × the cell's pixels, b = b_c / √h): Σ_p β_p β_pᵀ / h_p
  /// from Z Zᵀ, and C's depth term Σ_p B_p (b_c(p) / h_p) φ(p)ᵀ from B_c diag(1/√h) Zᵀ (B_c: the
  /// cell's columns of B), each (qc, rc) block mapped by T_cell.
  void subtractDepthShares(std::vector<EdgeAccum>& acc, Eigen::MatrixXd& Ms) const {
    const int mb = nuisance_->perChannel(), na = nuisance_->active();
    RowMatrix Zc, Lm, Zb;
    for (std::size_t ci = 0; ci < field_.pixels_of_cell.size(); ++ci) {
      const std::vector<int>& cell = field_.pixels_of_cell[ci];
      if (cell.empty()) continue;
      const int np = static_cast<int>(cell.size()), nz = 2 * Q_ * kMono;
      Zc.resize(nz, np);
      RowMatrix Bc(6 * T_, np);
      for (int col = 0; col < np; ++col) {
        const int px = cell[col];
        const double* mo = &field_.mono[static_cast<std::size_t>(px) * kMono];
        for (int qc = 0; qc < 2 * Q_; ++qc)
          for (int j = 0; j < kMono; ++j) Zc(qc * kMono + j, col) = b_src_(qc, px) * mo[j];
        Bc.col(col) = h_[px] > o_.depth_info_eps ? (B_.col(px) / std::sqrt(h_[px])).eval()
                                                 : Eigen::VectorXd::Zero(6 * T_).eval();
      }
      Lm.setZero(nz, nz);
      kernel::gemmNT(nz, nz, np, Zc.data(), np, Zc.data(), np, Lm.data(), nz, true);
      Lm = Lm.selfadjointView<Eigen::Lower>();
      Zb.setZero(6 * T_, nz);  // 6T × 2Q·4
      kernel::gemmNT(6 * T_, nz, np, Bc.data(), np, Zc.data(), np, Zb.data(), nz);
      const CellMap Tc = field_.cellMap(ci);
      const int* act = field_.active(ci, na);
      for (int qc = 0; qc < 2 * Q_; ++qc) {
        const int r0 = (qc / 2) * mn_ + (qc % 2) * mb;
        for (int rc = 0; rc < 2 * Q_; ++rc) {
          const ActiveMatrix blk =
              Tc * Lm.block<kMono, kMono>(qc * kMono, rc * kMono) * Tc.transpose();
          const int c0 = (rc / 2) * mn_ + (rc % 2) * mb;
          for (int w = 0; w < na; ++w)
            for (int u = 0; u < na; ++u) Ms(r0 + act[u], c0 + act[w]) -= blk(u, w);
        }
        EdgeAccum& a = acc[edges_[qc / 2]];
        if (a.C.size() == 0) continue;
        const Eigen::Matrix<double, Eigen::Dynamic, kMaxActive> zc =
            Zb.middleCols<kMono>(qc * kMono) * Tc.transpose();
        for (int u = 0; u < na; ++u) a.C.col((qc % 2) * mb + act[u]) -= zc.col(u);
      }
    }
  }

  const Snapshot& s_;
  const DbaOptions& o_;
  const DenseModel& m_;
  const NuisanceBasis* nuisance_;
  const FieldTable& field_;
  const int src_, si_, HW_;
  int T_ = 0, Q_ = 0, mn_ = 0;
  std::vector<int> touched_, edges_, tpos_, stereo_;
  Eigen::MatrixXd Sig_;  ///< Σ on the touched slots, 6T × 6T
  std::vector<Eigen::Matrix3d> R_;
  std::vector<Eigen::Vector3d> t_;
  std::vector<Matrix6x12> Em_;
  std::vector<std::vector<Row>> rows_;
  std::vector<std::vector<int>> first_rows_;
  std::vector<double> h_, gd_;
  Eigen::MatrixXd B_, SB_;
  RowMatrix B_rows_;
  Eigen::VectorXd bSb_;
  std::vector<detail::DepthOnlyTerms> depth_only_;
  // Nuisance: the depth's share of every edge's field at every pixel of the source, b_c / √h per
  // edge and channel (the shared depths couple the fields of edges that leave the same
  // keyframe), and the blocks Σ φφᵀ.
  Eigen::MatrixXd b_src_, n_raw_;
};

}  // namespace

std::vector<EdgeAccum> edgePass(const Snapshot& s, const DbaOptions& o, const DenseModel& m,
                                const NuisanceBasis* nuisance,
                                std::vector<SourceTerms>* source_terms,
                                std::vector<EdgeAccum>* sensor) {
  const int E = s.numEdges(), n = static_cast<int>(m.ne.keyframes.size());
  std::vector<EdgeAccum> acc(E);
  for (EdgeAccum& a : acc) a.g = Eigen::VectorXd::Zero(6 * n);
  std::vector<int> sources;
  for (int k : m.ne.keyframes)
    if (std::find(s.ii.begin(), s.ii.end(), k) != s.ii.end()) sources.push_back(k);
  if (source_terms) source_terms->assign(sources.size(), SourceTerms{});
  if (sensor) {
    sensor->assign(sources.size(), EdgeAccum{});
    for (EdgeAccum& a : *sensor) a.g = Eigen::VectorXd::Zero(6 * n);
  }
  const FieldTable field = nuisance ? FieldTable(*nuisance, s.H, s.W) : FieldTable();
  parallelFor(sources.size(), [&](std::size_t si) {
    SourcePass(s, o, m, nuisance, field, sources[si], static_cast<int>(si))
        .run(acc, source_terms, sensor);
  });
  return acc;
}

Pooled pooled(const std::vector<EdgeAccum>& accs) {
  Pooled p;
  for (const EdgeAccum& a : accs) {
    p.q += a.q;
    p.redundancy += a.rows - a.lev;
    p.rows += a.rows;
  }
  return p;
}

}  // namespace dbacov::selfcal
