// Self-calibration from the residuals (self_calibration.h). The residuals, scores and leverages
// are computed in a scalar pass of their own (dba_factor.h), per source keyframe in parallel; the
// pose covariance it needs is dense (K×K in the gauge's reduced coordinates, K = free pose DoF),
// which is cheap for DROID-sized windows.
#include "dbacov/core/self_calibration.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <limits>
#include <memory>
#include <stdexcept>

#include <Eigen/Cholesky>
#include <Eigen/Eigenvalues>

#include "dbacov/core/dba_factor.h"
#include "dbacov/core/depth_noise.h"
#include "dbacov/core/dot_products.h"
#include "dbacov/core/errors.h"
#include "dbacov/core/gauge.h"
#include "dbacov/core/linearization.h"
#include "dbacov/core/marginal_solver.h"
#include "dbacov/core/nuisance_basis.h"
#include "dbacov/core/parallel.h"
#include "depth_only_factors.h"

namespace dbacov {

void SelfCalibrationOptions::validate() const {
  if (iterations < 1) throw std::invalid_argument("self-calibration iterations must be >= 1");
  if (autocorr_lag < 1) throw std::invalid_argument("self-calibration autocorr lag must be >= 1");
  if (!(min_inflation > 0) || !(max_inflation >= min_inflation) || !std::isfinite(max_inflation))
    throw std::invalid_argument("self-calibration inflation bounds must satisfy 0 < min <= max");
  if (bootstrap_replicates < 4)
    throw std::invalid_argument("self-calibration bootstrap replicates must be >= 4");
  if (nuisance_nodes != 0 && !(nuisance_nodes >= 2 && nuisance_nodes <= 8))
    throw std::invalid_argument(
        "self-calibration nuisance nodes must be 0 (affine) or 2..8 (G x G bilinear tents)");
}

std::vector<double> SelfCalibration::inflations() const {
  std::vector<double> c;
  c.reserve(edges.size());
  for (const EdgeCalibration& e : edges) c.push_back(e.inflation);
  return c;
}

Snapshot inflateWeights(const Snapshot& s, const std::vector<double>& inflation) {
  if (static_cast<int>(inflation.size()) != s.numEdges())
    throw std::invalid_argument("inflateWeights: " + std::to_string(inflation.size()) +
                                " inflations for " + std::to_string(s.numEdges()) + " edges");
  Snapshot out = s;
  const std::size_t plane = 2 * s.pixelsPerFrame();
  for (int e = 0; e < s.numEdges(); ++e) {
    if (!(inflation[e] > 0) || !std::isfinite(inflation[e]))
      throw std::invalid_argument("inflateWeights: inflation of edge " + std::to_string(e) +
                                  " is not a positive finite number");
    const float f = static_cast<float>(1.0 / inflation[e]);
    float* w = &out.weight[e * plane];
    for (std::size_t p = 0; p < plane; ++p) w[p] *= f;
  }
  return out;
}

namespace {

/// Every method's inflations and white scales are clamped to the options' bounds; a non-finite
/// value (no information to estimate it from) becomes the upper bound.
double clampInflation(double x, double lo, double hi) {
  return std::clamp(std::isfinite(x) ? x : hi, lo, hi);
}

/// The options with the sensor readings' information α divided by their variance factor.
DbaOptions sensorCalibratedOptions(const DbaOptions& o, double sensor_scale) {
  DbaOptions out = o;
  if (sensor_scale != 1.0) out.sensor_depth_weight /= sensor_scale;
  return out;
}

/// The linearization, gauge and dense pose covariance of one state and weighting.
struct DenseModel {
  DbaNormalEquations ne;
  GaugeParameterization gauge;
  Eigen::MatrixXd basis;    ///< 6n × K, block diagonal
  Eigen::MatrixXd Sr;       ///< K × K reduced information
  Eigen::MatrixXd L_r;      ///< K × K, lower Cholesky factor of Sr (Sr = L Lᵀ)
  Eigen::MatrixXd Sigma_r;  ///< K × K
  Eigen::MatrixXd Sigma;    ///< 6n × 6n, full tangent
};

DenseModel buildModel(const Snapshot& s, const DbaOptions& o, bool keep_depth_terms = false) {
  DenseModel m;
  m.ne = linearizeDba(s, o, keep_depth_terms);
  m.gauge = makeGauge(o.gauge, s, m.ne.keyframes);
  checkGaugeReachesAll(m.ne.S, m.gauge, m.ne.keyframes);
  const int n = static_cast<int>(m.ne.keyframes.size()), K = m.gauge.dim();
  m.basis = Eigen::MatrixXd::Zero(6 * n, K);
  for (int a = 0; a < n; ++a)
    if (m.gauge.dimOf(a) > 0)  // (a block of an empty matrix would offset a null pointer)
      m.basis.block(6 * a, m.gauge.offset[a], 6, m.gauge.dimOf(a)) = m.gauge.basis[a];
  m.Sr = Eigen::MatrixXd::Zero(K, K);
  m.Sigma_r = Eigen::MatrixXd::Zero(K, K);
  if (K > 0) {
    const Eigen::MatrixXd upper(reduceSystem(m.ne.S, m.gauge));
    m.Sr = upper.selfadjointView<Eigen::Upper>();
    if (!m.Sr.allFinite())
      throw NumericalError("the information matrix has non-finite entries (self-calibration)", {});
    const Eigen::LLT<Eigen::MatrixXd> llt(m.Sr);
    if (llt.info() != Eigen::Success) {
      // Name the keyframe where it breaks down, as the covariance's own factorization does.
      std::vector<int> kf;
      if (const int col = firstBadPivot(m.Sr); col >= 0)
        kf.push_back(m.ne.keyframes[m.gauge.slotOfColumn(col)]);
      throw NumericalError(
          // (no source prefix: the callers name the snapshot, as for the covariance's own)
          "the reduced information matrix S is not positive definite in the self-calibration" +
              (kf.empty() ? std::string() : " (breakdown at keyframe " + joinKeyframes(kf) + ")") +
              ": some motion is unobservable (degenerate geometry, too few weighted pixels, a "
              "gauge that does not fix every DoF, or a scale fixed only by sensor depths whose "
              "weight is negligible)",
          kf.empty() ? m.ne.keyframes : kf);
    }
    m.L_r = llt.matrixL();
    m.Sigma_r = llt.solve(Eigen::MatrixXd::Identity(K, K));
    m.Sigma_r = 0.5 * (m.Sigma_r + m.Sigma_r.transpose());
  }
  m.Sigma = m.basis * m.Sigma_r * m.basis.transpose();
  return m;
}

/// The nuisance sums run on at most kMono monomials per pixel and kMaxActive active basis
/// coordinates (NuisanceBasis), in fixed-capacity storage.
constexpr int kMono = 4, kMaxActive = 7;
using ActiveMatrix = Eigen::Matrix<double, kMaxActive, kMaxActive>;
/// A spline cell's T_cell (row-major, padded to kMaxActive × kMono with zeros: fixed-size
/// products; only the first active() rows are scattered).
using CellMap = Eigen::Map<const Eigen::Matrix<double, kMaxActive, kMono, Eigen::RowMajor>>;

/// Per-edge sums of one pass.
using Vector12d = Eigen::Matrix<double, 12, 1>;
using RowMatrix = Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor>;

struct EdgeAccum {
  std::size_t pixels = 0, rows = 0;
  double sum_r2 = 0;  ///< Σ r², px²
  double q = 0;       ///< Σ λ r²
  double lev = 0;     ///< Σ leverage
  double tr_SI = 0, tr_SD = 0, tr_SISI = 0, gSg = 0;
  double gIg = 0, expected_info = 0;  ///< g_eᵀ I_e⁺ g_e and its expectation
  double tau = 1;
  /// A factor on the depths alone (a stereo edge, a source's sensor readings): its rows have no
  /// pose Jacobian, v = −(J_d / h) B_p; of the nuisance fields below only source, w and
  /// pixel_of are set.
  bool depth_only = false;
  Eigen::VectorXd g;  ///< 6n, depth-reduced score
  // Nuisance only, on the edge's source slots (slots[a] = the a-th 6-block's keyframe slot):
  std::vector<int> slots;
  // Nuisance: the factors of I_e, the edge's 6T × 6T share of S (not formed), I = P(Auu)Pᵀ −
  // (P X + transpose) + B diag(w) Bᵀ over the source's depth columns B (SourceTerms), P
  // scattering the edge's 12 coordinates idx into the 6T and X = Σ_p acr_p B_pᵀ (12 × 6T: small,
  // where the acr_p themselves would be 12 per pixel and edge, 17 MB on the shared snapshot).
  int source = -1;            ///< index into the pass's SourceTerms
  std::array<int, 12> idx{};  ///< the edge's 12 coordinates within the source's 6T
  Matrix12d Auu;              ///< Σ u uᵀ
  Eigen::Matrix<double, 12, Eigen::Dynamic> cross;  ///< 12 × 6T, Σ_p (Σ_k c_k u_k) B_pᵀ
  Eigen::VectorXd w;                                ///< P, Σ_k c_k² per pixel
  std::vector<int> pixel_of;                        ///< P, the pixels
  Eigen::MatrixXd C;                                ///< 6T × m, Σ_{rows of e} v φᵀ
  Eigen::MatrixXd Mn;  ///< m × m, the field's information after poses and depths
  /// Per field group g, m × m: (M_s D_g M_s)_ee, Cov(t) per unit σ_g² (the source's fields).
  std::vector<Eigen::MatrixXd> An;
  std::vector<int> group;    ///< the group of each of the m coordinates
  Eigen::VectorXd t;         ///< m, the field's depth-reduced score Φ̃ᵀ Λ r
  Eigen::VectorXd CSC_diag;  ///< diag(Cᵀ Σ C)
};

/// Nuisance: what the edges leaving one source keyframe share, so that Σ_e f_e I_e is one
/// product per source once the white scales f_e + 1 are known (instead of one I_e per edge).
struct SourceTerms {
  std::vector<int> touched;  ///< the source's slots (its 6-blocks)
  RowMatrix B;               ///< 6T × HW, every pixel's depth column (rows along pixels)
};

/// One row (pixel, axis) of an edge. Only ∂r/∂ξ_j is kept: ∂r/∂ξ_i = −J_j Ad(T_ji) (as in the
/// kernel, dba_kernel.h), so the row's 12 pose coordinates are u = Eᵀ w with w = √λ J_jᵀ and the
/// edge's E = [−Ad(T_ji) | I] (6 × 12), and every per-row sum below runs on the 6 entries of w.
struct Row {
  int pixel, channel;
  double lam, r, jd;
  Eigen::Matrix<double, 1, 6> Jj;
};
using Matrix6x12 = Eigen::Matrix<double, 6, 12>;

/// The tapered sum of the 2-D autocorrelation of the fields z[c] (mask: rows present).
double autocorrelationSum(const std::vector<double> z[2], const std::vector<char> mask[2], int H,
                          int W, int L) {
  double var = 0, n = 0;
  for (int c = 0; c < 2; ++c)
    for (int p = 0; p < H * W; ++p)
      if (mask[c][p]) {
        var += z[c][p] * z[c][p];
        n += 1;
      }
  if (n < 2 || !(var > 0)) return 1.0;
  var /= n;
  double tau = 0;
  for (int dy = -L; dy <= L; ++dy)
    for (int dx = -L; dx <= L; ++dx) {
      const double taper =
          (1.0 - std::abs(dx) / double(L + 1)) * (1.0 - std::abs(dy) / double(L + 1));
      double num = 0, cnt = 0;
      for (int c = 0; c < 2; ++c)
        for (int y = std::max(0, -dy); y < std::min(H, H - dy); ++y)
          for (int x = std::max(0, -dx); x < std::min(W, W - dx); ++x) {
            const int p = y * W + x, q = (y + dy) * W + x + dx;
            if (mask[c][p] && mask[c][q]) {
              num += z[c][p] * z[c][q];
              cnt += 1;
            }
          }
      if (cnt > 0) tau += taper * (num / cnt) / var;
    }
  return tau;
}

/// One pass over every edge at the snapshot's state and weights, with the model's Σ: one
/// EdgeAccum per edge and, in `sensor` (when given), one per source keyframe in the pass's source
/// order for its sensor readings (RGB-D; rows = 0 without).
std::vector<EdgeAccum> edgePass(const Snapshot& s, const DbaOptions& o, const DenseModel& m,
                                bool autocorr, int L, bool info_metric,
                                const NuisanceBasis* nuisance = nullptr,
                                std::vector<SourceTerms>* source_terms = nullptr,
                                std::vector<EdgeAccum>* sensor = nullptr) {
  const int E = s.numEdges(), n = static_cast<int>(m.ne.keyframes.size());
  const int HW = static_cast<int>(s.pixelsPerFrame());
  const PinholeIntrinsics K = PinholeIntrinsics::fromVector(s.intrinsics);
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
  // The stereo edges' terms without the sensor's (each factor on the depths alone on its own).
  DbaOptions o_stereo = o;
  o_stereo.sensor_depth_weight = 0;
  // Nuisance: every grid pixel's active basis coordinates, monomials and spline cell, and every
  // cell's map T from the monomials to the active values (NuisanceBasis; the sums run on the
  // monomials, so the values themselves are not kept).
  struct FieldTable {
    std::vector<int> index, cell;
    std::vector<double> mono, T;
    std::vector<std::vector<int>> pixels_of_cell;
  } field;
  if (nuisance) {
    const std::size_t na = static_cast<std::size_t>(nuisance->active());
    field.index.resize(na * HW);
    std::vector<double> value(na);
    field.cell.resize(HW);
    field.pixels_of_cell.resize(static_cast<std::size_t>(nuisance->cells()));
    for (int px = 0; px < HW; ++px) {
      field.cell[px] = nuisance->eval(px % s.W, px / s.W, &field.index[na * px], value.data());
      field.pixels_of_cell[field.cell[px]].push_back(px);
    }
    // Stored kMono wide (the affine basis's three monomials padded with a zero).
    const std::size_t nm = static_cast<std::size_t>(nuisance->monomials());
    field.mono.assign(kMono * HW, 0.0);
    for (int px = 0; px < HW; ++px) nuisance->monomial(px % s.W, px / s.W, &field.mono[kMono * px]);
    field.T.assign(kMaxActive * kMono * static_cast<std::size_t>(nuisance->cells()), 0.0);
    std::vector<double> Tn(na * nm);
    for (int c = 0; c < nuisance->cells(); ++c) {
      nuisance->cellTransform(c, Tn.data());
      for (std::size_t u = 0; u < na; ++u)
        for (std::size_t j = 0; j < nm; ++j)
          field.T[(kMaxActive * c + u) * kMono + j] = Tn[u * nm + j];
    }
  }

  parallelFor(sources.size(), [&](std::size_t si) {
    const int src = sources[si];
    std::vector<int> touched{m.ne.slot_of[src]}, edges, tpos, stereo;
    for (int e = 0; e < E; ++e) {
      if (s.ii[e] != src) continue;
      // A stereo edge (k, k) is a factor on the depths alone (fixed rig transform; conventions
      // §2, depth_only_factors.h): it has no pose rows; its depth information enters every
      // pixel's h and gradient below, as in the linearization, and its residuals give it a
      // variance component of its own (depthOnlyAccum).
      if (s.jj[e] == src) {
        stereo.push_back(e);
        continue;
      }
      const int slot = m.ne.slot_of[s.jj[e]];
      auto it = std::find(touched.begin(), touched.end(), slot);
      tpos.push_back(static_cast<int>(it - touched.begin()));
      if (it == touched.end()) touched.push_back(slot);
      edges.push_back(e);
    }
    const int T = static_cast<int>(touched.size()), Q = static_cast<int>(edges.size());
    Eigen::MatrixXd Sig(6 * T, 6 * T);
    for (int a = 0; a < T; ++a)
      for (int b = 0; b < T; ++b)
        Sig.block<6, 6>(6 * a, 6 * b) = m.Sigma.block<6, 6>(6 * touched[a], 6 * touched[b]);
    std::vector<Eigen::Matrix3d> R(Q);
    std::vector<Eigen::Vector3d> t(Q);
    std::vector<Matrix6x12> Em(Q);  // E = [−Ad(T_ji) | I]: u = Eᵀ w
    const Eigen::Isometry3d T_wc_i = s.T_wc(src);
    for (int q = 0; q < Q; ++q) {
      const Eigen::Isometry3d T_ji = s.T_cw(static_cast<int>(s.jj[edges[q]])) * T_wc_i;
      R[q] = T_ji.linear();
      t[q] = T_ji.translation();
      Em[q].leftCols<6>() = -adjoint(T_ji);
      Em[q].rightCols<6>().setIdentity();
    }

    // Rows of every edge, and the depth terms h, b of every pixel.
    std::vector<std::vector<Row>> rows(Q);
    for (auto& r : rows) r.reserve(static_cast<std::size_t>(2 * HW));
    std::vector<std::vector<int>> first_rows(Q);  // per edge, where each pixel's rows begin
    for (auto& f : first_rows) f.reserve(static_cast<std::size_t>(HW) + 1);
    std::vector<double> h(HW, 0.0), gd(HW, 0.0);  // depth information and gradient Σ λ J_d r
    Eigen::MatrixXd B = Eigen::MatrixXd::Zero(6 * T, HW);
    // The pixels' depth columns B_p = Σ λ J_d [J_i | J_j]ᵀ: the target slot's half Σ λ J_d J_jᵀ
    // per edge (Bj, one 6 × HW block per edge, added to B below), the source slot's half
    // −Ad(T_ji)ᵀ times it (one 6 × 6 × HW product per edge).
    Eigen::MatrixXd Bj = Eigen::MatrixXd::Zero(6 * Q, HW);
    PixelFactorLinearization f;  // (its J_i is not formed: above)
    for (int p = 0; p < HW; ++p) {
      const double d = s.disps[static_cast<std::size_t>(src) * HW + p];
      if (!(d > 0)) continue;
      const double x = p % s.W, y = p / s.W;
      for (int q = 0; q < Q; ++q) {
        const int e = edges[q];
        const double lam[2] = {o.weight_scale * s.weightPlane(e, 0)[p],
                               o.weight_scale * s.weightPlane(e, 1)[p]};
        if (!(lam[0] > 0 || lam[1] > 0)) continue;
        const Eigen::Vector3d Y = transferPoint(R[q], t[q], K, x, y, d);
        if (!keepPixelFactor(o, d, Y.z())) continue;
        linearizePixelFactorAt(Y, t[q], K, d, s.targetPlane(e, 0)[p], s.targetPlane(e, 1)[p], &f);
        first_rows[q].push_back(static_cast<int>(rows[q].size()));
        double* bj = &Bj(6 * q, p);
        for (int c = 0; c < 2; ++c) {
          if (!(lam[c] > 0)) continue;
          Row r{p, c, lam[c], f.r[c], f.J_d[c], f.J_j.row(c)};
          h[p] += lam[c] * r.jd * r.jd;
          gd[p] += lam[c] * r.jd * r.r;
          const double lj = lam[c] * r.jd;
          for (int i = 0; i < 6; ++i) bj[i] += lj * r.Jj[i];
          rows[q].push_back(r);
        }
      }
    }
    for (int q = 0; q < Q; ++q) {
      B.middleRows<6>(6 * tpos[q]) += Bj.middleRows<6>(6 * q);
      B.topRows<6>().noalias() += Em[q].leftCols<6>().transpose() * Bj.middleRows<6>(6 * q);
    }
    // The factors on the depths alone (stereo edges, RGB-D sensor depths): information and
    // gradient of the pixel's depth, as linearizeDba adds them before eliminating it; each
    // stereo edge and the sensor readings apart, for their variance components.
    std::vector<detail::DepthOnlyTerms> depth_only;
    for (int e : stereo) depth_only.push_back(detail::depthOnlyTerms(s, o_stereo, src, {e}));
    depth_only.push_back(detail::depthOnlyTerms(s, o, src, {}));  // the sensor's (last)
    for (const detail::DepthOnlyTerms& terms : depth_only)
      if (terms.any)
        for (int p = 0; p < HW; ++p) {
          h[p] += terms.h[p];
          gd[p] += terms.g[p];
        }

    // Every depth-reduced row is v_k = u_k − c_k B_p (u_k = √λ [J_i | J_j] on two slots, c_k =
    // √λ J_d / h_p, B_p the pixel's depth column shared by all its rows), so the products with
    // Σ are done once per source (ΣB) and per row on the 6 entries of w (Row), and the edge's 6T ×
    // 6T sums are a 12 × 12 block, a 12 × 6T cross term and one rank update over the edge's pixels,
    // instead of dense 6T × rows products (≈ 10× fewer flops on DROID-sized windows). (The products
    // over pixels here and below run in dot-product form, dot_products.h.)
    Eigen::MatrixXd SB = Eigen::MatrixXd::Zero(6 * T, HW);  // column p: Σ B_p
    kernel::gemmNT(HW, 6 * T, 6 * T, B.data(), 6 * T, Sig.data(), 6 * T, SB.data(), 6 * T);
    // Nuisance: B with its rows along the pixels, for the cross terms X_e and SourceTerms.
    RowMatrix B_rows = nuisance ? RowMatrix(B) : RowMatrix();
    Eigen::VectorXd bSb(HW);
    for (int p = 0; p < HW; ++p) bSb[p] = B.col(p).dot(SB.col(p));

    // A factor on the depths alone, in the notation above with u = 0: its rows at pixel p (depth
    // information h_t = Σ λ J_d², gradient Σ λ J_d r) have v = −(√λ J_d / h_p) B_p, so
    // lev = h_t (1/h_p + B_pᵀ Σ B_p / h_p²), g = −Σ_p (Σ λ J_d r / h_p) B_p, I = Σ_p w_p B_p B_pᵀ
    // with w_p = h_t / h_p², and D's c_p = −(h_t / h_p) B_p.
    const auto depthOnlyAccum = [&](const detail::DepthOnlyTerms& dt, EdgeAccum& a) {
      a.depth_only = true;
      a.rows = dt.rows;
      a.pixels = dt.factors_used;
      a.q = dt.chi2;
      a.sum_r2 = dt.sum_r2;
      a.source = static_cast<int>(si);
      if (!dt.any) return;
      Eigen::VectorXd g = Eigen::VectorXd::Zero(6 * T);
      std::vector<double> w;
      for (int p = 0; p < HW; ++p) {
        const double hp = h[p];
        if (!(dt.h[p] > 0) || !(hp > o.depth_info_eps)) continue;
        a.lev += dt.h[p] / hp * (1.0 + bSb[p] / hp);
        g.noalias() -= (dt.g[p] / hp) * B.col(p);
        a.pixel_of.push_back(p);
        w.push_back(dt.h[p] / (hp * hp));
        a.tr_SI += w.back() * bSb[p];
        a.tr_SD += (dt.h[p] / hp) * (dt.h[p] / hp) * bSb[p] / hp;
      }
      a.w = Eigen::Map<const Eigen::VectorXd>(w.data(), static_cast<Eigen::Index>(w.size()));
      if (!nuisance || info_metric) {  // I itself: the score's expectation, the sandwich's f
        Eigen::MatrixXd Bw(6 * T, a.pixel_of.size());
        for (std::size_t k = 0; k < a.pixel_of.size(); ++k)
          Bw.col(static_cast<Eigen::Index>(k)) = std::sqrt(w[k]) * B.col(a.pixel_of[k]);
        Eigen::MatrixXd I = Eigen::MatrixXd::Zero(6 * T, 6 * T);
        I.selfadjointView<Eigen::Lower>().rankUpdate(Bw);
        I = I.selfadjointView<Eigen::Lower>();
        const Eigen::MatrixXd SI = Sig * I;
        a.tr_SISI = SI.cwiseProduct(SI.transpose()).sum();
        a.gSg = g.dot(Sig * g);
      }
      for (int b = 0; b < T; ++b) a.g.segment<6>(6 * touched[b]) = g.segment<6>(6 * b);
    };
    for (std::size_t k = 0; k < stereo.size(); ++k) depthOnlyAccum(depth_only[k], acc[stereo[k]]);
    if (sensor) depthOnlyAccum(depth_only.back(), (*sensor)[si]);

    std::vector<double> z[2];
    std::vector<char> mask[2];
    // Nuisance: the depth's share of every edge's field at every pixel of the source, b_c / √h
    // per edge and channel (the shared depths couple the fields of edges that leave the same
    // keyframe), and the blocks Σ φφᵀ.
    const int mn = nuisance ? 2 * nuisance->perChannel() : 0;
    Eigen::MatrixXd b_src, n_raw;
    if (nuisance) {
      b_src = Eigen::MatrixXd::Zero(2 * Q, HW);
      n_raw = Eigen::MatrixXd::Zero(Q * mn, Q * mn);
    }
    for (int q = 0; q < Q; ++q) {
      EdgeAccum& a = acc[edges[q]];
      const std::vector<Row>& rq = rows[q];
      const int M = static_cast<int>(rq.size());
      if (M == 0) continue;
      // The 12 coordinates of u within the 6T of the source's slots (every sum below scatters
      // by adding, so a repeated coordinate would add up).
      std::array<int, 12> idx;
      for (int i = 0; i < 6; ++i) {
        idx[i] = i;
        idx[6 + i] = 6 * tpos[q] + i;
      }
      Matrix12d S12;
      for (int r = 0; r < 12; ++r)
        for (int c = 0; c < 12; ++c) S12(r, c) = Sig(idx[r], idx[c]);
      std::vector<int>& first_row = first_rows[q];  // the edge's pixels (rows come pixel by pixel)
      const int P = static_cast<int>(first_row.size());
      first_row.push_back(M);
      // Everything per row and pixel runs on w_k = √λ J_jᵀ (u_k = Eᵀ w_k, Row) and is mapped to
      // the 12 coordinates by E once per edge: Σ u uᵀ = Eᵀ (Σ w wᵀ) E, uᵀ x = wᵀ (E x).
      const Matrix6x12& E12 = Em[q];
      const Matrix6d S6 = E12 * S12 * E12.transpose();
      // The rows' w_k, one column each (stored row by row: Σ w wᵀ is then one product in
      // dot-product form instead of 6 × 6 per row), c_k, and the per-pixel sums.
      Eigen::Matrix<double, 6, Eigen::Dynamic, Eigen::RowMajor> Wm(6, M);
      Eigen::VectorXd sr(M), cr(M), lev(M);
      // Σ_k c_k w_k per pixel; the pixels' B_p (gathered only where I_e or C_p are formed).
      const bool form_I = !nuisance || info_metric, score_terms = form_I;
      Eigen::Matrix<double, 6, Eigen::Dynamic> Acr(6, P);
      Eigen::MatrixXd Bp(6 * T, form_I ? P : 0);
      Eigen::VectorXd wsq(P);  // √(Σ c_k²) per pixel
      Eigen::VectorXd gamma(P), hk(P);
      Eigen::Matrix<double, 6, Eigen::Dynamic> alpha(6, P);  // Σ √λ J_d w_k per pixel
      Eigen::VectorXd beta(P);                               // Σ √λ J_d c_k per pixel
      // (Σ c_k u_k)ᵀ (ΣB_p)_idx and (Σ √λ J_d u_k)ᵀ (ΣB_p)_idx per pixel, as wᵀ E (ΣB_p)_idx.
      Eigen::VectorXd acr_sb(P), al_sb(P);
      // Nuisance: the field's whitened columns φ_k = √λ Φ(x, y) on the row's channel, on each
      // pixel's active coordinates. Per spline cell and channel the sums run on the pixels'
      // monomials m (the active values are T_cell m): Σ √λ w mᵀ (6 × 4, mapped by Eᵀ), Σ λ m mᵀ and
      // the score's Σ m (√λ r − depth's share), mapped to the cell's active coordinates by T_cell
      // once per cell (below); per pixel the depth's share b_c = Σ_{rows of channel c} λ J_d.
      const int ncell = nuisance ? nuisance->cells() : 0;
      std::vector<Eigen::Matrix<double, 6, kMono>> CUm(2 * ncell);
      std::vector<Eigen::Matrix<double, kMono, kMono>> Nm(2 * ncell);
      std::vector<Eigen::Matrix<double, kMono, 1>> tm(2 * ncell);
      for (int ic = 0; ic < 2 * ncell; ++ic) {
        CUm[ic].setZero();
        Nm[ic].setZero();
        tm[ic].setZero();
      }
      std::vector<char> in_cell(static_cast<std::size_t>(ncell), 0);
      for (int pix = 0; pix < P; ++pix) {
        const int px = rq[first_row[pix]].pixel;
        const double hp = h[px];
        const bool reduced = hp > o.depth_info_eps;
        hk[pix] = hp;
        Vector12d sb12;
        for (int i = 0; i < 12; ++i) sb12[i] = SB(idx[i], px);
        const Vector6d sb = E12 * sb12;
        Vector6d acr = Vector6d::Zero(), al = Vector6d::Zero();
        double w = 0, gam = 0, be = 0;
        double bc[2] = {0.0, 0.0};  // nuisance: Σ λ J_d per channel
        const double* mono = nuisance ? &field.mono[static_cast<std::size_t>(kMono) * px] : nullptr;
        for (int k = first_row[pix]; k < first_row[pix + 1]; ++k) {
          const Row& r = rq[k];
          const double sl = std::sqrt(r.lam);
          const Vector6d u = sl * r.Jj.transpose();  // w_k (u_k = Eᵀ w_k)
          Wm.col(k) = u;
          const double c = reduced ? sl * r.jd / hp : 0.0;
          cr[k] = c;
          sr[k] = sl * r.r;
          a.sum_r2 += r.r * r.r;
          lev[k] =
              -2 * c * u.dot(sb) + c * c * bSb[px] + (reduced ? r.lam * r.jd * r.jd / hp : 0.0);
          acr += c * u;
          w += c * c;
          gam += sr[k] * c;
          if (reduced && score_terms) {
            al += sl * r.jd * u;
            be += sl * r.jd * c;
          }
          if (nuisance) {
            const int ic = 2 * field.cell[px] + r.channel;
            const Eigen::Map<const Eigen::Matrix<double, kMono, 1>> mo(mono);
            CUm[ic].noalias() += u * (sl * mo).transpose();
            tm[ic] += sr[k] * sl * mo;
            Nm[ic].noalias() += (r.lam * mo) * mo.transpose();
            bc[r.channel] += r.lam * r.jd;
          }
        }
        if (nuisance) {
          const int cell = field.cell[px];
          in_cell[cell] = 1;
          if (reduced) {
            const Eigen::Map<const Eigen::Matrix<double, kMono, 1>> mo(mono);
            for (int c = 0; c < 2; ++c) {
              tm[2 * cell + c] -= (bc[c] * gd[px] / hp) * mo;
              b_src(2 * q + c, px) = bc[c] / std::sqrt(hp);
            }
          }
        }
        Acr.col(pix) = acr;
        acr_sb[pix] = acr.dot(sb);
        al_sb[pix] = al.dot(sb);
        if (form_I) Bp.col(pix) = B.col(px);
        wsq[pix] = std::sqrt(w);
        gamma[pix] = gam;
        alpha.col(pix) = al;
        beta[pix] = be;
      }
      // Σ w wᵀ in dot-product form on the rows of Wm, written row-major below the diagonal,
      // i.e. above it in Matrix6d's column order; Σ u uᵀ = Eᵀ (Σ w wᵀ) E.
      Matrix6d Aww = Matrix6d::Zero();
      kernel::gemmNT(6, 6, M, Wm.data(), M, Wm.data(), M, Aww.data(), 6, true);
      Aww = Aww.selfadjointView<Eigen::Upper>();
      const Matrix12d Auu = E12.transpose() * Aww * E12;
      // The leverages' u_kᵀ Σ₁₂ u_k = w_kᵀ S6 w_k: per row only where the rows' own leverages are
      // used (the autocorrelation's whitened residuals); their sum is tr(S6 Σ w wᵀ).
      const double tr_Sww = S6.cwiseProduct(Aww).sum();
      double uSu = 0;
      if (autocorr)
        lev += ((S6 * Wm).cwiseProduct(Wm)).colwise().sum().transpose();
      else
        uSu = tr_Sww;
      const Vector12d gu = E12.transpose() * (Wm * sr);
      a.rows = M;
      a.pixels = P;
      a.q = sr.squaredNorm();
      a.lev = lev.sum() + uSu;
      // g = Σ sr_k v_k;  I = Σ v_k v_kᵀ = [Σ u uᵀ] − [Σ c u Bᵀ + transpose] + Σ (Σ c²) B Bᵀ.
      Eigen::VectorXd g;
      if (form_I) {
        g = -(Bp * gamma);
      } else {
        g = Eigen::VectorXd::Zero(6 * T);
        for (int pix = 0; pix < P; ++pix)
          g.noalias() -= gamma[pix] * B.col(rq[first_row[pix]].pixel);
      }
      for (int i = 0; i < 12; ++i) g[idx[i]] += gu[i];
      // The nuisance method needs I only as Σ_e (s_e − 1) I_e, formed per source once the s_e
      // are known (nuisanceCovariance), and tr(Σ I) from I's factors: tr(S6 Σ w wᵀ) −
      // 2 Σ_p acr_pᵀ E (ΣB_p)_idx + Σ_p w_p B_pᵀ Σ B_p (acr_p = Σ c w, 6 entries). The other
      // methods need I itself.
      Eigen::MatrixXd I;
      if (form_I) {
        I = Eigen::MatrixXd::Zero(6 * T, 6 * T);
        I.selfadjointView<Eigen::Lower>().rankUpdate(Bp * wsq.asDiagonal());
        I = I.selfadjointView<Eigen::Lower>();
        const Eigen::MatrixXd cross = E12.transpose() * (Acr * Bp.transpose());  // 12 × 6T
        for (int i = 0; i < 12; ++i) {
          I.row(idx[i]) -= cross.row(i);
          I.col(idx[i]) -= cross.row(i).transpose();
          for (int j = 0; j < 12; ++j) I(idx[i], idx[j]) += Auu(i, j);
        }
        const Eigen::MatrixXd SI = Sig * I;
        a.tr_SI = SI.trace();
        a.tr_SISI = SI.cwiseProduct(SI.transpose()).sum();
      } else {
        double tr = tr_Sww;
        for (int pix = 0; pix < P; ++pix) {
          const int px = rq[first_row[pix]].pixel;
          tr += wsq[pix] * wsq[pix] * bSb[px] - 2 * acr_sb[pix];
        }
        a.tr_SI = tr;
      }
      // The score statistic and its expectation's depth share (the nuisance method uses
      // neither).
      if (score_terms) {
        a.gSg = g.dot(Sig * g);
        // The depth's share: C_p = Σ_k √λ J_d v_k = α_p − β_p B_p (pixels with depth
        // information; α_p lifted by Eᵀ); Σ_p α_pᵀ S6 α_p / h_p as tr(S6 Σ_p α_p α_pᵀ / h_p), one
        // rank update on the 6-entry α_p.
        Eigen::Matrix<double, 6, Eigen::Dynamic> alpha_h(6, P);
        for (int pix = 0; pix < P; ++pix) {
          if (!(hk[pix] > o.depth_info_eps)) {
            alpha_h.col(pix).setZero();
            continue;
          }
          const int px = rq[first_row[pix]].pixel;
          alpha_h.col(pix) = alpha.col(pix) / std::sqrt(hk[pix]);
          a.tr_SD += (beta[pix] * beta[pix] * bSb[px] - 2 * beta[pix] * al_sb[pix]) / hk[pix];
        }
        Matrix6d Aal = Matrix6d::Zero();
        Aal.selfadjointView<Eigen::Lower>().rankUpdate(alpha_h);
        a.tr_SD += S6.cwiseProduct(Matrix6d(Aal.selfadjointView<Eigen::Lower>())).sum();
      }
      // The same statistic in the edge's own information metric: g_eᵀ I_e⁺ g_e, expectation
      // rank(I_e) − tr(I_e⁺ D_e) − tr(Σ I_e), with tr(I_e⁺ D_e) = tr(I_e⁺ X), X = Σ_p C_p C_pᵀ /
      // h_p.
      if (info_metric) {
        const Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd> eig(I);
        const Eigen::VectorXd& ev = eig.eigenvalues();
        const double cut = 1e-10 * std::max(ev.maxCoeff(), 0.0);
        int rank = 0;
        Eigen::VectorXd inv = Eigen::VectorXd::Zero(ev.size());
        for (int k = 0; k < ev.size(); ++k)
          if (ev[k] > cut && cut > 0) {
            inv[k] = 1.0 / ev[k];
            ++rank;
          }
        const Eigen::MatrixXd U = eig.eigenvectors() * inv.cwiseSqrt().asDiagonal();
        a.gIg = (U.transpose() * g).squaredNorm();
        Eigen::MatrixXd Cm = Eigen::MatrixXd::Zero(6 * T, P);  // C_p / √h_p, depth pixels only
        for (int pix = 0; pix < P; ++pix) {
          if (!(hk[pix] > o.depth_info_eps)) continue;
          const double sh = 1.0 / std::sqrt(hk[pix]);
          Cm.col(pix) = -beta[pix] * sh * Bp.col(pix);
          const Vector12d al = E12.transpose() * alpha.col(pix);
          for (int i = 0; i < 12; ++i) Cm(idx[i], pix) += sh * al[i];
        }
        a.expected_info = rank - (U.transpose() * Cm).squaredNorm() - a.tr_SI;
      }
      for (int b = 0; b < T; ++b) a.g.segment<6>(6 * touched[b]) = g.segment<6>(6 * b);
      if (nuisance) {
        const int mb = nuisance->perChannel(), na = nuisance->active();
        // C = Σ_k v_k φ_kᵀ = Σ u φᵀ − Σ_p B_p (b_c(p) / h_p) φ(p)ᵀ: the first term here, the
        // second per source below (one product per spline cell for all the source's edges).
        Eigen::MatrixXd Cn = Eigen::MatrixXd::Zero(6 * T, mn);
        Eigen::VectorXd tn = Eigen::VectorXd::Zero(mn);
        Eigen::MatrixXd Nn = Eigen::MatrixXd::Zero(mn, mn);
        for (int ci = 0; ci < ncell; ++ci) {
          if (!in_cell[ci]) continue;
          const CellMap Tc(&field.T[static_cast<std::size_t>(ci) * kMaxActive * kMono]);
          const int* act = &field.index[static_cast<std::size_t>(field.pixels_of_cell[ci][0]) * na];
          for (int c = 0; c < 2; ++c) {
            const int ic = 2 * ci + c;
            const Eigen::Matrix<double, 12, kMaxActive> cu =
                E12.transpose() * (CUm[ic] * Tc.transpose());
            const ActiveMatrix nn = Tc * Nm[ic] * Tc.transpose();
            const Eigen::Matrix<double, kMaxActive, 1> tt = Tc * tm[ic];
            for (int u = 0; u < na; ++u) {
              const int col = c * mb + act[u];
              for (int i = 0; i < 12; ++i) Cn(idx[i], col) += cu(i, u);
              tn[col] += tt[u];
              for (int w = 0; w < na; ++w) Nn(col, c * mb + act[w]) += nn(u, w);
            }
          }
        }
        n_raw.block(q * mn, q * mn, mn, mn) = Nn;
        a.C = std::move(Cn);
        a.source = static_cast<int>(si);
        a.idx = idx;
        a.Auu = Auu;
        {
          RowMatrix acr_all = RowMatrix::Zero(6, HW);  // the edge's Σ c w on every pixel
          for (int pix = 0; pix < P; ++pix) acr_all.col(rq[first_row[pix]].pixel) = Acr.col(pix);
          RowMatrix cross = RowMatrix::Zero(6, 6 * T);
          kernel::gemmNT(6, 6 * T, HW, acr_all.data(), HW, B_rows.data(), HW, cross.data(), 6 * T);
          a.cross = E12.transpose() * cross;
        }
        a.w = wsq.cwiseAbs2();
        a.pixel_of.resize(P);
        for (int pix = 0; pix < P; ++pix) a.pixel_of[pix] = rq[first_row[pix]].pixel;
        a.t = tn;
        a.slots = touched;
        a.group.resize(mn);
        for (int k = 0; k < mn; ++k) a.group[k] = nuisance->groupOf(k);
      }
      if (autocorr) {
        for (int c = 0; c < 2; ++c) {
          z[c].assign(HW, 0.0);
          mask[c].assign(HW, 0);
        }
        for (int k = 0; k < M; ++k) {
          const Row& r = rq[k];
          z[r.channel][r.pixel] = sr[k] / std::sqrt(std::max(1.0 - lev[k], 0.05));
          mask[r.channel][r.pixel] = 1;
        }
        a.tau = autocorrelationSum(z, mask, s.H, s.W, L);
      }
    }
    if (nuisance) {
      // The fields' information after the poses and depths, jointly over the source's edges:
      // M_s = blockdiag(Σ φφᵀ) − Σ_p β_p β_pᵀ / h_p − C_sᵀ Σ C_s. Each edge keeps its diagonal
      // block M_e and (M_s D_g M_s)_ee, the covariance of its field score per unit σ_g² including
      // what the other edges' fields put into it. Cell by cell (the cell's pixels touch the same
      // coordinates of every edge, (q, c, active u) -> q·mn + c·mb + index[u]), on the monomials
      // with Z = [b_p ⊗ m_p] (2Q·4 × the cell's pixels, b = b_c / √h): Σ_p β_p β_pᵀ / h_p from
      // Z Zᵀ, and C's depth term Σ_p B_p (b_c(p) / h_p) φ(p)ᵀ from B_c diag(1/√h) Zᵀ (B_c: the
      // cell's columns of B), each (qc, rc) block mapped by T_cell.
      const int mb = nuisance->perChannel(), na = nuisance->active();
      Eigen::MatrixXd Ms = n_raw;
      RowMatrix Zc, Lm, Zb;
      for (std::size_t ci = 0; ci < field.pixels_of_cell.size(); ++ci) {
        const std::vector<int>& cell = field.pixels_of_cell[ci];
        if (cell.empty()) continue;
        const int np = static_cast<int>(cell.size()), nz = 2 * Q * kMono;
        Zc.resize(nz, np);
        RowMatrix Bc(6 * T, np);
        for (int col = 0; col < np; ++col) {
          const int px = cell[col];
          const double* mo = &field.mono[static_cast<std::size_t>(px) * kMono];
          for (int qc = 0; qc < 2 * Q; ++qc)
            for (int j = 0; j < kMono; ++j) Zc(qc * kMono + j, col) = b_src(qc, px) * mo[j];
          Bc.col(col) = h[px] > o.depth_info_eps ? (B.col(px) / std::sqrt(h[px])).eval()
                                                 : Eigen::VectorXd::Zero(6 * T).eval();
        }
        Lm.setZero(nz, nz);
        kernel::gemmNT(nz, nz, np, Zc.data(), np, Zc.data(), np, Lm.data(), nz, true);
        Lm = Lm.selfadjointView<Eigen::Lower>();
        Zb.setZero(6 * T, nz);  // 6T × 2Q·4
        kernel::gemmNT(6 * T, nz, np, Bc.data(), np, Zc.data(), np, Zb.data(), nz);
        const CellMap Tc(&field.T[ci * static_cast<std::size_t>(kMaxActive * kMono)]);
        const int* act = &field.index[static_cast<std::size_t>(cell[0]) * na];
        for (int qc = 0; qc < 2 * Q; ++qc) {
          const int r0 = (qc / 2) * mn + (qc % 2) * mb;
          for (int rc = 0; rc < 2 * Q; ++rc) {
            const ActiveMatrix blk =
                Tc * Lm.block<kMono, kMono>(qc * kMono, rc * kMono) * Tc.transpose();
            const int c0 = (rc / 2) * mn + (rc % 2) * mb;
            for (int w = 0; w < na; ++w)
              for (int u = 0; u < na; ++u) Ms(r0 + act[u], c0 + act[w]) -= blk(u, w);
          }
          EdgeAccum& a = acc[edges[qc / 2]];
          if (a.C.size() == 0) continue;
          const Eigen::Matrix<double, Eigen::Dynamic, kMaxActive> zc =
              Zb.middleCols<kMono>(qc * kMono) * Tc.transpose();
          for (int u = 0; u < na; ++u) a.C.col((qc % 2) * mb + act[u]) -= zc.col(u);
        }
      }
      Eigen::MatrixXd Cs = Eigen::MatrixXd::Zero(6 * T, Q * mn);
      for (int q = 0; q < Q; ++q)
        if (acc[edges[q]].C.size() > 0) Cs.middleCols(q * mn, mn) = acc[edges[q]].C;
      {
        const Eigen::MatrixXd SC = Sig * Cs;
        RowMatrix CSC = RowMatrix::Zero(Q * mn, Q * mn);
        kernel::gemmNT(Q * mn, Q * mn, 6 * T, Cs.data(), 6 * T, SC.data(), 6 * T, CSC.data(),
                       Q * mn, true);
        Ms -= RowMatrix(CSC.selfadjointView<Eigen::Lower>());
        // diag(C_eᵀ Σ C_e): the diagonal of the edge's block of C_sᵀ Σ C_s.
        for (int q = 0; q < Q; ++q) {
          EdgeAccum& a = acc[edges[q]];
          if (a.C.size() > 0) a.CSC_diag = CSC.diagonal().segment(q * mn, mn);
        }
      }
      Ms = 0.5 * (Ms + Ms.transpose()).eval();
      const int G = nuisance->groups();
      for (int q = 0; q < Q; ++q) {
        EdgeAccum& a = acc[edges[q]];
        if (a.C.size() == 0) continue;
        a.Mn = Ms.block(q * mn, q * mn, mn, mn);
        a.An.assign(G, Eigen::MatrixXd::Zero(mn, mn));
        for (int g = 0; g < G; ++g) {
          // The edge's rows of M_s on group g's columns, gathered column by column into
          // row-major storage for the product.
          std::vector<int> cols;
          for (int k = 0; k < Q * mn; ++k)
            if (nuisance->groupOf(k % mn) == g) cols.push_back(k);
          const int ng = static_cast<int>(cols.size());
          RowMatrix Rg(mn, ng);
          for (int j = 0; j < ng; ++j) Rg.col(j) = Ms.col(cols[j]).segment(q * mn, mn);
          kernel::gemmNT(mn, mn, ng, Rg.data(), ng, Rg.data(), ng, a.An[g].data(), mn, true);
          a.An[g] = a.An[g].selfadjointView<Eigen::Upper>();  // row-major lower = upper here
        }
      }
      if (source_terms) (*source_terms)[si] = SourceTerms{touched, std::move(B_rows)};
    }
  });
  return acc;
}

OptimumDistance optimumDistance(const DenseModel& m) {
  OptimumDistance d;
  d.free_dof = m.gauge.dim();
  if (m.gauge.dim() == 0) return d;
  const Eigen::VectorXd gr = m.basis.transpose() * m.ne.g_S;
  const Eigen::VectorXd step = m.Sigma_r * gr;
  d.gradient_norm = gr.norm();
  d.step_sigma = std::sqrt(std::max(0.0, gr.dot(step)));
  for (std::size_t a = 0; a + 1 < m.gauge.offset.size(); ++a) {
    const int off = m.gauge.offset[a], dim = m.gauge.dimOf(static_cast<int>(a));
    if (dim == 0) continue;
    const Eigen::LDLT<Eigen::MatrixXd> ldlt(m.Sigma_r.block(off, off, dim, dim));
    const Eigen::VectorXd da = step.segment(off, dim);
    d.max_step_sigma = std::max(d.max_step_sigma, std::sqrt(std::max(0.0, da.dot(ldlt.solve(da)))));
  }
  return d;
}

/// Σ q, Σ (rows − lev) and Σ rows over accumulators: a pooled vce scale's numerator and
/// denominator.
struct Pooled {
  double q = 0, redundancy = 0, rows = 0;
};
Pooled pooled(const std::vector<EdgeAccum>& accs) {
  Pooled p;
  for (const EdgeAccum& a : accs) {
    p.q += a.q;
    p.redundancy += a.rows - a.lev;
    p.rows += a.rows;
  }
  return p;
}

double expectedScore(const EdgeAccum& a) {
  return a.tr_SI - a.tr_SD - a.tr_SISI;
}

/// The nuisance method's estimates and covariance (self_calibration.h). Per edge, on the range
/// of M_e (rank r), the whitened field score y = Λ^-½ Uᵀ t_e has
/// Cov(y) = Σ_g σ_g² B_g + s_e I, B_g = W A_g Wᵀ (A_g = (M_s D_g M_s)_ee, W = Λ^-½ Uᵀ).
/// The σ_g² maximize the likelihood of every edge's y (projected Fisher scoring, σ_g² >= 0); the
/// white scale is the residual beyond the edge's own field fit |y|², corrected by what the fit is
/// expected to take beyond the edge's field energy: s_e = (q_e − |y|² + Σ_g σ_g² (tr B_g −
/// tr M_e,gg)) / (ρ_e − r); the two alternate. The covariance is
/// Σ (S + Σ_e (s_e − 1) I_e + Σ_g σ_g² C_e,g C_e,gᵀ) Σ in the gauge's reduced coordinates.
/// The s_e are clamped to [lo, hi] (the options' inflation bounds, as every method's inflations).
void nuisanceCovariance(const DenseModel& m, const std::vector<EdgeAccum>& acc,
                        const std::vector<SourceTerms>& sources,
                        const std::vector<EdgeAccum>& sensor, double sensor_scale, int groups,
                        double lo, double hi, SelfCalibration* out) {
  const int E = static_cast<int>(acc.size());
  const auto clamp = [&](double x) { return clampInflation(x, lo, hi); };
  /// The edge's field terms in the eigenbasis B_k = U diag(d) Uᵀ of one group k: while σ_k² is
  /// the only non-zero variance component, Cv = s I + σ_k² B_k is diagonal there.
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
  std::vector<FieldEdge> fe;
  std::vector<double> se(E, 1.0);
  std::vector<char> used(E, 0);
  const int G = groups;  // variance components (every edge's group indices are below it)
  // The field scores of the residual projected off the poses too, Φᵀ P⊥ r = t_e − C_eᵀ Σ g
  // (g the depth-reduced gradient of every row, the stereo edges' and the readings' included;
  // zero at the optimum, where this changes nothing).
  Eigen::VectorXd grad = Eigen::VectorXd::Zero(m.Sigma.rows());
  for (const EdgeAccum& a : acc) grad += a.g;
  for (const EdgeAccum& a : sensor) grad += a.g;
  const Eigen::VectorXd Sg = m.Sigma * grad;
  // Per edge in parallel (each writes only its own entries), kept in edge order.
  std::vector<std::unique_ptr<FieldEdge>> prepared(E);
  parallelFor(static_cast<std::size_t>(E), [&](std::size_t ei) {
    const int e = static_cast<int>(ei);
    const EdgeAccum& a = acc[e];
    const double rho = out->edges[e].redundancy;
    if (a.depth_only) {  // a stereo edge: white noise only, its vce scale
      if (a.rows > 0 && rho > 0.5) {
        used[e] = 1;
        se[e] = clamp(a.q / rho);
      }
      return;
    }
    if (a.rows == 0 || !(rho > 0.5) || a.Mn.size() == 0) return;
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
    used[e] = 1;
    se[e] = clamp(a.q / rho);
    if (rank == 0) return;
    const int mn = static_cast<int>(ev.size());
    Eigen::MatrixXd W(rank, mn);
    for (int k = mn - rank, r = 0; k < mn; ++k, ++r)
      W.row(r) = eig.eigenvectors().col(k).transpose() / std::sqrt(ev[k]);
    FieldEdge f;
    f.edge = e;
    f.y = W * t;
    f.excess = Eigen::VectorXd::Zero(G);
    for (int g = 0; g < G; ++g) {
      f.B.push_back(W * a.An[g] * W.transpose());
      double trMgg = 0;
      for (int k = 0; k < mn; ++k)
        if (a.group[k] == g) trMgg += a.Mn(k, k);
      f.excess[g] = f.B[g].trace() - trMgg;
    }
    f.fit = f.y.squaredNorm();
    f.dof = rho - rank;
    if (f.dof > 0.5) se[e] = clamp(std::max(a.q - f.fit, 0.05 * a.q) / f.dof);
    prepared[e] = std::make_unique<FieldEdge>(std::move(f));
  });
  for (std::unique_ptr<FieldEdge>& f : prepared)
    if (f) fe.push_back(std::move(*f));
  Eigen::VectorXd theta = Eigen::VectorXd::Zero(G);
  // The log-likelihood, its gradient and Fisher information in θ = (σ_g²) at fixed s_e: the
  // edges' terms in parallel, summed in edge order (the same result for any number of threads).
  struct EdgeTerms {
    double ll = 0;
    Eigen::VectorXd score;
    Eigen::MatrixXd info;
    RowMatrix Cinv;  ///< Cv⁻¹, kept between the score and the information
    bool ok = true;
  };
  std::vector<EdgeTerms> terms(fe.size());
  // With Cv = L Lᵀ, z = L⁻¹ y and v = Cv⁻¹ y: yᵀCv⁻¹y = |z|², the score of σ_g² is
  // ½ (vᵀ B_g v − ⟨Cv⁻¹, B_g⟩) and its Fisher information ½ tr(Cv⁻¹B_g Cv⁻¹B_h) = ½ ⟨X_g, X_hᵀ⟩
  // with X_g = Cv⁻¹ B_g. The scores come first (one product for Cv⁻¹ = L⁻ᵀL⁻¹ per edge, the
  // rest is quadratic); the X_g, one product each, only for the coordinates that the step can
  // move (θ_g > 0 or a positive score: fisherStep's free set, the only entries it reads).
  // (info is only formed together with score: its free set needs the summed score.)
  const auto evaluate = [&](const Eigen::VectorXd& th, Eigen::VectorXd* score,
                            Eigen::MatrixXd* info) {
    if (info && !score) throw std::logic_error("nuisance likelihood: information without score");
    // One variance component above zero (the others held there): every term is diagonal in
    // that group's eigenbasis (formed once per edge and group, then O(r²) per evaluation instead
    // of O(r³)). k = that group, or −1 (the general path).
    int k = -1, npositive = 0;
    for (int g = 0; g < G; ++g)
      if (th[g] > 0) {
        k = g;
        ++npositive;
      }
    if (npositive != 1) k = -1;
    // The edge's eigenbasis of B_k, formed when first used (each edge only by its own index).
    const auto eigenbasis = [&](FieldEdge& f) -> const Eigenbasis& {
      if (f.basis.empty()) f.basis.resize(G);
      if (!f.basis[k]) {
        const Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd> eig(f.B[k]);
        auto eb = std::make_unique<Eigenbasis>();
        eb->d = eig.eigenvalues();
        const Eigen::MatrixXd& U = eig.eigenvectors();
        eb->y = U.transpose() * f.y;
        eb->B.resize(G);
        for (int g = 0; g < G; ++g)
          if (g != k) eb->B[g] = U.transpose() * f.B[g] * U;
        f.basis[k] = std::move(eb);
      }
      return *f.basis[k];
    };
    parallelFor(fe.size(), [&](std::size_t fi) {
      FieldEdge& f = fe[fi];
      EdgeTerms& et = terms[fi];
      if (k >= 0) {
        const Eigenbasis& eb = eigenbasis(f);
        const Eigen::ArrayXd c = se[f.edge] + th[k] * eb.d.array();  // Cv's eigenvalues
        et.ok = (c > 0).all();
        if (!et.ok) return;
        const Eigen::ArrayXd ci = c.inverse(), v = eb.y.array() * ci;  // v = Cv⁻¹ y
        et.ll = -0.5 * (c.log().sum() + (eb.y.array() * v).sum());
        if (!score) return;
        et.score.setZero(G);
        for (int g = 0; g < G; ++g)
          et.score[g] = g == k
                            ? 0.5 * ((eb.d.array() * v.square()).sum() - (eb.d.array() * ci).sum())
                            : 0.5 * (v.matrix().dot(eb.B[g] * v.matrix()) -
                                     (eb.B[g].diagonal().array() * ci).sum());
        return;
      }
      const int r = static_cast<int>(f.y.size());
      Eigen::MatrixXd Cv = se[f.edge] * Eigen::MatrixXd::Identity(r, r);
      for (int g = 0; g < G; ++g) Cv += th[g] * f.B[g];
      const Eigen::LLT<Eigen::MatrixXd> llt(Cv);
      et.ok = llt.info() == Eigen::Success;
      if (!et.ok) return;
      const double logdet = 2 * llt.matrixLLT().diagonal().array().log().sum();
      if (!score) {
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
      et.score.setZero(G);
      for (int g = 0; g < G; ++g)
        et.score[g] = 0.5 * (v.dot(f.B[g] * v) - et.Cinv.cwiseProduct(f.B[g]).sum());
    });
    double ll = 0;
    if (score) *score = Eigen::VectorXd::Zero(G);
    for (const EdgeTerms& et : terms) {
      if (!et.ok) return -std::numeric_limits<double>::infinity();
      ll += et.ll;
      if (score) *score += et.score;
    }
    if (!info) return ll;
    *info = Eigen::MatrixXd::Zero(G, G);
    std::vector<int> free;
    for (int g = 0; g < G; ++g)
      if (th[g] > 0 || (*score)[g] > 0) free.push_back(g);
    const int nf = static_cast<int>(free.size());
    parallelFor(fe.size(), [&](std::size_t fi) {
      const FieldEdge& f = fe[fi];
      EdgeTerms& et = terms[fi];
      const int r = static_cast<int>(f.y.size());
      // X_g = Cv⁻¹ B_g: in the eigenbasis diag(1/c) B_g (B_k = diag(d)), else one product.
      std::vector<RowMatrix> X(nf);
      if (k >= 0) {
        const Eigenbasis& eb = *f.basis[k];
        const Eigen::VectorXd ci = (se[f.edge] + th[k] * eb.d.array()).inverse().matrix();
        for (int a = 0; a < nf; ++a)
          X[a] = free[a] == k ? RowMatrix((ci.asDiagonal() * eb.d).asDiagonal())
                              : RowMatrix(ci.asDiagonal() * eb.B[free[a]]);
      } else {
        for (int a = 0; a < nf; ++a) {
          X[a].setZero(r, r);
          kernel::gemmNT(r, r, r, et.Cinv.data(), r, f.B[free[a]].data(), r, X[a].data(), r);
        }
      }
      et.info.setZero(G, G);
      for (int a = 0; a < nf; ++a)
        for (int b = 0; b <= a; ++b)
          et.info(free[a], free[b]) = et.info(free[b], free[a]) =
              0.5 * X[a].cwiseProduct(X[b].transpose()).sum();
    });
    for (const EdgeTerms& et : terms) *info += et.info;
    return ll;
  };
  // One projected Fisher-scoring step in θ at the current s_e (step halving: the likelihood
  // must not drop); true when θ did not move (converged, or held at 0 by its score).
  const auto fisherStep = [&]() {
    Eigen::VectorXd score;
    Eigen::MatrixXd info;
    // A covariance that is not positive definite ends the search where it is (it cannot happen
    // with s_e > 0; the partial score and information are not used). The evaluation with the
    // score also gives the likelihood at θ that the step must not lower.
    const double ll = evaluate(theta, &score, &info);
    if (!std::isfinite(ll)) return true;
    // Coordinates held at 0 whose score points below 0 stay there.
    std::vector<int> free;
    for (int g = 0; g < G; ++g)
      if (theta[g] > 0 || score[g] > 0) free.push_back(g);
    if (free.empty()) return true;
    Eigen::MatrixXd F(free.size(), free.size());
    Eigen::VectorXd sc(free.size());
    for (std::size_t a = 0; a < free.size(); ++a) {
      sc[a] = score[free[a]];
      for (std::size_t b = 0; b < free.size(); ++b) F(a, b) = info(free[a], free[b]);
    }
    const Eigen::VectorXd step = F.ldlt().solve(sc);
    double alpha = 1, ll_new = ll;
    Eigen::VectorXd next = theta;
    for (int half = 0; half < 30; ++half, alpha *= 0.5) {
      next = theta;
      for (std::size_t a = 0; a < free.size(); ++a)
        next[free[a]] = std::max(0.0, theta[free[a]] + alpha * step[a]);
      ll_new = evaluate(next, nullptr, nullptr);
      if (ll_new >= ll - 1e-12 * std::abs(ll)) break;
    }
    const double moved = (next - theta).norm();
    theta = next;
    return ll_new - ll <= 1e-10 * std::max(1.0, std::abs(ll)) ||
           moved <= 1e-7 * std::max(theta.norm(), 1e-300);
  };
  // θ and the s_e jointly: one Fisher step in θ, then the s_e given θ, until neither moves. The
  // fixed point is that of converging θ at each s_e in turn (the alternation's), reached with
  // fewer likelihood evaluations (24 against 63 on the shared snapshot at the tolerance of 1e-8
  // that the stop rule below had then; the covariances agreed to 3e-9).
  for (int round = 0; round < 500 && !fe.empty(); ++round) {
    const bool theta_done = fisherStep();
    // The white scales given σ² (at least 5 % of the residual stays white: the field cannot
    // explain all of it).
    double change = 0;
    for (const FieldEdge& f : fe) {
      if (!(f.dof > 0.5)) continue;
      const double q = acc[f.edge].q;
      const double next =
          clamp(std::max(q - f.fit + theta.head(G).dot(f.excess), 0.05 * q) / f.dof);
      change = std::max(change, std::abs(next / se[f.edge] - 1.0));
      se[f.edge] = next;
    }
    // The alternation contracts by about 0.15 a round (shared snapshot): a last change below
    // 1e-6 leaves the s_e within about 2e-7 of the fixed point (1e-8 took three more rounds,
    // each a score evaluation on every edge, for digits far below the estimates' precision).
    if (change < 1e-6 && theta_done) break;
  }
  const int n6 = static_cast<int>(m.Sigma.rows());
  Eigen::MatrixXd X = Eigen::MatrixXd::Zero(n6, n6);
  for (int e = 0; e < E; ++e) {
    const EdgeAccum& a = acc[e];
    EdgeCalibration& ec = out->edges[e];
    ec.inflation = used[e] ? se[e] : 1.0;
    double field_sc = 0;  // Σ_g σ_g² tr(C_gᵀ Σ C_g)
    for (int k = 0; k < static_cast<int>(a.group.size()); ++k)
      field_sc += theta[a.group[k]] * a.CSC_diag[k];
    ec.correlation = used[e] && a.tr_SI > 0 ? 1.0 + field_sc / (se[e] * a.tr_SI) : 1.0;
    ec.effective_pixels = ec.pixels / ec.correlation;
    if (!used[e]) continue;
    Eigen::MatrixXd Xe = Eigen::MatrixXd::Zero(a.C.rows(), a.C.rows());
    for (int k = 0; k < static_cast<int>(a.group.size()); ++k)
      Xe.noalias() += theta[a.group[k]] * a.C.col(k) * a.C.col(k).transpose();
    const int T = static_cast<int>(a.slots.size());
    for (int p = 0; p < T; ++p)
      for (int q = 0; q < T; ++q)
        X.block<6, 6>(6 * a.slots[p], 6 * a.slots[q]) += Xe.block<6, 6>(6 * p, 6 * q);
  }
  // Σ_e (s_e − 1) I_e, per source from the factors of its edges' I_e (EdgeAccum): with
  // f_e = s_e − 1 and ω = Σ_e f_e w_e (per pixel), Σ_e f_e I_e = Σ_e f_e (P_e Auu_e P_eᵀ −
  // P_e X_e − X_eᵀ P_eᵀ) + B diag(ω) Bᵀ: one 6T × HW × 6T product per source (its lower
  // triangle). The factors on the depths alone (stereo edges, the sensor readings with the
  // scale shared by all sources) add only to ω. The sources in parallel, added to X in source
  // order (the same sums for any thread count).
  std::vector<Eigen::MatrixXd> per_source(sources.size());
  parallelFor(sources.size(), [&](std::size_t si) {
    const SourceTerms& st = sources[si];
    if (st.B.size() == 0) return;
    const int T6 = static_cast<int>(st.B.rows()), HW = static_cast<int>(st.B.cols());
    Eigen::VectorXd omega = Eigen::VectorXd::Zero(HW);
    // f Σ_p w_p B_p B_pᵀ of a factor's depth share: f w on its pixels' ω.
    const auto addOmega = [&](const EdgeAccum& a, double f) {
      for (std::size_t pix = 0; pix < a.pixel_of.size(); ++pix)
        omega[a.pixel_of[pix]] += f * a.w[static_cast<Eigen::Index>(pix)];
    };
    Eigen::MatrixXd Xs = Eigen::MatrixXd::Zero(T6, T6);
    bool any = false;
    for (int e = 0; e < E; ++e) {
      const EdgeAccum& a = acc[e];
      if (a.source != static_cast<int>(si) || !used[e]) continue;
      const double f = se[e] - 1.0;
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
    if (si < sensor.size() && sensor[si].rows > 0 && sensor_scale != 1.0) {
      addOmega(sensor[si], sensor_scale - 1.0);
      any = true;
    }
    if (!any) return;
    const RowMatrix Bw = st.B * omega.asDiagonal();
    RowMatrix BwB = RowMatrix::Zero(T6, T6);
    kernel::gemmNT(T6, T6, HW, Bw.data(), HW, st.B.data(), HW, BwB.data(), T6, true);
    Xs += Eigen::MatrixXd(BwB.selfadjointView<Eigen::Lower>());
    per_source[si] = std::move(Xs);
  });
  for (std::size_t si = 0; si < sources.size(); ++si) {
    const SourceTerms& st = sources[si];
    const Eigen::MatrixXd& Xs = per_source[si];
    if (Xs.size() == 0) continue;
    const int T = static_cast<int>(st.touched.size());
    for (int p = 0; p < T; ++p)
      for (int q = 0; q < T; ++q)
        X.block<6, 6>(6 * st.touched[p], 6 * st.touched[q]) += Xs.block<6, 6>(6 * p, 6 * q);
  }
  const Eigen::MatrixXd SX = m.Sigma_r * (m.basis.transpose() * X * m.basis);
  Eigen::MatrixXd V = m.Sigma_r + SX * m.Sigma_r;
  V = 0.5 * (V + V.transpose());
  out->nuisance_sigma = std::sqrt(theta[0]);
  out->nuisance_fine_sigma = G > 1 ? std::sqrt(theta[1]) : 0.0;
  out->reduced_covariance = std::make_shared<const Eigen::MatrixXd>(std::move(V));
}

}  // namespace

SelfCalibration selfCalibrate(const Snapshot& s, const DbaOptions& o,
                              const SelfCalibrationOptions& c) {
  o.validate();
  c.validate();
  if (c.method == SelfCalibrationMethod::Bootstrap)
    throw std::invalid_argument(
        "the bootstrap self-calibration re-solves the DBA: run it with runSelfCalibration "
        "(dbacov/study/bootstrap.h)");
  s.validate();
  const int E = s.numEdges();
  SelfCalibration out;
  out.method = c.method;
  out.depth_noise = c.depth_noise;
  out.depth_noise_kurtosis = c.depth_noise_kurtosis;
  out.edges.resize(E);
  for (int e = 0; e < E; ++e) {
    out.edges[e].edge = e;
    out.edges[e].i = static_cast<int>(s.ii[e]);
    out.edges[e].j = static_cast<int>(s.jj[e]);
  }
  std::vector<double> infl(E, 1.0);
  const bool single_pass =
      c.method == SelfCalibrationMethod::Sandwich || c.method == SelfCalibrationMethod::Nuisance;
  const int passes = single_pass ? 1 : c.iterations;
  const NuisanceBasis basis{c.nuisance_nodes, s.H, s.W};
  const auto clamp = [&](double x) { return clampInflation(x, c.min_inflation, c.max_inflation); };
  for (int it = 0; it < passes; ++it) {
    const bool last = it + 1 == passes;
    const Snapshot inflated = it == 0 ? Snapshot() : inflateWeights(s, infl);
    const Snapshot& cur = it == 0 ? s : inflated;
    const DbaOptions oi = it == 0 ? o : sensorCalibratedOptions(o, out.sensor_depth_scale);
    DenseModel model = buildModel(cur, oi);
    // The gauge holds every pose: every covariance is 0 whatever the noise, and there is no
    // free direction for the residuals to calibrate (selfCalibratedCovariance: the engine's).
    if (model.gauge.dim() == 0) {
      out.passes = 1;
      out.optimum.free_dof = 0;
      return out;
    }
    const bool nuisance = c.method == SelfCalibrationMethod::Nuisance;
    std::vector<SourceTerms> sources;
    std::vector<EdgeAccum> sensor;
    const std::vector<EdgeAccum> acc =
        edgePass(cur, oi, model, last && c.method == SelfCalibrationMethod::Autocorr,
                 c.autocorr_lag, c.score_metric == ScoreMetric::Information,
                 nuisance ? &basis : nullptr, nuisance ? &sources : nullptr, &sensor);
    ++out.passes;
    // The sensor readings' variance component, one for all sources (DROID's α is one number):
    // Σ q / Σ redundancy, iterated like vce's.
    const Pooled readings = pooled(sensor);
    out.sensor_depth_rows = static_cast<std::size_t>(readings.rows);
    out.sensor_depth_redundancy = readings.redundancy;
    if (readings.redundancy > 0.5)
      out.sensor_depth_scale = clamp(out.sensor_depth_scale * readings.q / readings.redundancy);
    if (it == 0) {
      out.optimum = optimumDistance(model);
      const Pooled edges = pooled(acc);
      out.global_scale = edges.redundancy > 0 ? edges.q / edges.redundancy : 1.0;
    }
    // Per edge: the scale (vce) and the score ratio κ / scale beyond it, with its effective
    // number of degrees of freedom ν = tr(ΣI)² / tr((ΣI)²); the pooled ratio over all edges.
    std::vector<double> ratio(E, 1.0), nu(E, 0.0);
    double pooled_num = 0, pooled_den = 0;
    for (int e = 0; e < E; ++e) {
      const EdgeAccum& a = acc[e];
      EdgeCalibration& ec = out.edges[e];
      ec.pixels = a.pixels;
      ec.rows = a.rows;
      ec.residual_rms = a.rows ? std::sqrt(a.sum_r2 / a.rows) : 0.0;
      ec.chi2 = a.q * infl[e];
      ec.redundancy = a.rows - a.lev;
      // Without redundancy (no used rows, or everything absorbed) the edge keeps its factor.
      ec.vce_scale = ec.redundancy > 0.5 ? a.q / ec.redundancy : 1.0;
      const bool info = c.score_metric == ScoreMetric::Information;
      const double expected = info ? a.expected_info : expectedScore(a);
      const double stat = info ? a.gIg : a.gSg;
      if (expected > (info ? 0.5 : 1e-9 * std::max(1.0, a.tr_SI)) && a.tr_SISI > 0) {
        ratio[e] = stat / (expected * ec.vce_scale);
        nu[e] = info ? expected : a.tr_SI * a.tr_SI / a.tr_SISI;
        pooled_num += stat;
        pooled_den += expected * ec.vce_scale;
      }
    }
    const double pooled = pooled_den > 0 ? pooled_num / pooled_den : 1.0;
    for (int e = 0; e < E; ++e) {
      const EdgeAccum& a = acc[e];
      EdgeCalibration& ec = out.edges[e];
      // The edge's own ratio, shrunk towards the pooled one by its precision.
      const double shrunk =
          nu[e] + c.score_prior_dof > 0
              ? (nu[e] * ratio[e] + c.score_prior_dof * pooled) / (nu[e] + c.score_prior_dof)
              : ratio[e];
      switch (c.method) {
        case SelfCalibrationMethod::Vce:
          infl[e] = clamp(infl[e] * ec.vce_scale);
          ec.correlation = 1.0;
          break;
        case SelfCalibrationMethod::Autocorr:
          infl[e] = clamp(infl[e] * ec.vce_scale);
          ec.correlation = last ? std::max(a.tau, 0.05) : 1.0;
          if (last) infl[e] = clamp(infl[e] * ec.correlation);
          break;
        case SelfCalibrationMethod::Score:
          ec.correlation = std::max(shrunk, 0.05);
          infl[e] = clamp(infl[e] * ec.vce_scale * ec.correlation);
          break;
        case SelfCalibrationMethod::Sandwich:
          ec.correlation = ratio[e];
          break;
        case SelfCalibrationMethod::Nuisance:
        case SelfCalibrationMethod::Bootstrap:  // refused above
          break;                                // below
      }
      ec.inflation = infl[e];
      ec.effective_pixels = ec.pixels / ec.correlation;
    }
    if (c.method == SelfCalibrationMethod::Sandwich) {
      const int K = model.gauge.dim();
      int clusters = 0;
      Eigen::MatrixXd meat = Eigen::MatrixXd::Zero(K, K);
      // Clusters: the edges (stereo ones too) and each source's sensor readings.
      std::vector<const EdgeAccum*> all;
      for (const EdgeAccum& a : acc) all.push_back(&a);
      for (const EdgeAccum& a : sensor) all.push_back(&a);
      for (const EdgeAccum* ap : all) {
        const EdgeAccum& a = *ap;
        if (a.rows == 0) continue;
        ++clusters;
        const double f = a.tr_SI > 0 ? std::clamp(expectedScore(a) / a.tr_SI, 0.05, 1.0) : 1.0;
        const Eigen::VectorXd gr = model.basis.transpose() * a.g;
        meat.noalias() += gr * gr.transpose() / f;
      }
      if (clusters <= K)
        // (no source prefix here or below: the callers name the snapshot)
        throw NumericalError(
            "the sandwich self-calibration needs more clusters (edges, "
            "and sources with sensor readings: " +
                std::to_string(clusters) + ") than free pose DoF (" + std::to_string(K) + ")",
            {});
      Eigen::MatrixXd V = model.Sigma_r * meat * model.Sigma_r;
      V = 0.5 * (V + V.transpose());
      out.reduced_covariance = std::make_shared<const Eigen::MatrixXd>(std::move(V));
    }
    if (c.method == SelfCalibrationMethod::Nuisance) {
      nuisanceCovariance(model, acc, sources, sensor, out.sensor_depth_scale, basis.groups(),
                         c.min_inflation, c.max_inflation, &out);
      out.linearization = std::make_shared<const DbaNormalEquations>(std::move(model.ne));
      out.nuisance_params = 2 * basis.perChannel();
    }
  }
  return out;
}

namespace {
/// The depths' term: the largest share ρ of a direction's information the depths' noise may take
/// before the second-order expansion is held (selfCalibratedCovariance).
constexpr double kMaxDepthShare = 0.9;

/// Each edge's white-noise variance factor: the inflation of vce and nuisance (nuisance: s_e, the
/// field is a term of its own), without the correlation factor of score and autocorr; sandwich
/// keeps the snapshot's weights, its white scale is vce's.
std::vector<double> whiteFactors(const SelfCalibration& cal) {
  std::vector<double> f;
  f.reserve(cal.edges.size());
  for (const EdgeCalibration& e : cal.edges) {
    double x = e.inflation;
    if (cal.method == SelfCalibrationMethod::Score || cal.method == SelfCalibrationMethod::Autocorr)
      x /= e.correlation;
    else if (cal.method == SelfCalibrationMethod::Sandwich)
      x = e.vce_scale;
    f.push_back(std::isfinite(x) && x > 0 ? x : e.inflation);
  }
  return f;
}
}  // namespace

DbaCovariance selfCalibratedCovariance(const Snapshot& s, const DbaOptions& o,
                                       const CovarianceOptions& solver,
                                       const SelfCalibration& cal) {
  // summary() says which self-calibration the covariance is the result of (it used to say
  // "none": nothing filled it).
  if (static_cast<int>(cal.edges.size()) != s.numEdges())
    throw std::invalid_argument(s.source + ": the self-calibration has " +
                                std::to_string(cal.edges.size()) + " edges, the snapshot " +
                                std::to_string(s.numEdges()) + ": it is of another snapshot");
  for (int e = 0; e < s.numEdges(); ++e)
    if (cal.edges[e].i != s.ii[e] || cal.edges[e].j != s.jj[e])
      throw std::invalid_argument(
          s.source + ": edge " + std::to_string(e) + " is (" + std::to_string(s.ii[e]) + ", " +
          std::to_string(s.jj[e]) + "), the self-calibration's (" + std::to_string(cal.edges[e].i) +
          ", " + std::to_string(cal.edges[e].j) + "): it is of another snapshot");
  SelfCalibrationSummary summary{toString(cal.method), cal.inflations()};
  summary.sensor_depth_scale = cal.sensor_depth_scale;
  if (cal.passes > 0 && cal.optimum.free_dof == 0) {  // the gauge holds every pose: all 0
    DbaCovariance cov(s, o, solver);
    cov.setSelfCalibrationSummary(std::move(summary));
    return cov;
  }
  // The sensor readings' information at their fitted scale, wherever the model is rebuilt.
  const DbaOptions oc = sensorCalibratedOptions(o, cal.sensor_depth_scale);
  if (cal.depth_noise && cal.method != SelfCalibrationMethod::Bootstrap) {
    // The depths' second-order term (depth_noise.h) of the white noise each edge was found to
    // have, added to the method's covariance in the gauge's reduced coordinates. The bootstrap
    // re-solves: its scale measures the nonlinearity itself.
    const std::vector<double> white_factors = whiteFactors(cal), infl = cal.inflations();
    Snapshot si = inflateWeights(s, white_factors);
    DenseModel m = buildModel(si, oc, true);
    const DepthNoiseTerms dn = depthNoiseTerms(si, oc, m.ne, cal.depth_noise_kurtosis);
    const Eigen::MatrixXd Mr = m.basis.transpose() * dn.M * m.basis;
    Eigen::MatrixXd Nr = m.basis.transpose() * dn.N * m.basis;
    // The variance's fourth-cumulant share (heavy tails: each row's, and the two axes' of a
    // factor jointly; depth_noise.h): in M + N only, H keeps the Gaussian M.
    Eigen::MatrixXd Mv = Mr;
    if (cal.depth_noise_kurtosis) {
      Mv += m.basis.transpose() * dn.M_kurtosis * m.basis;
      Nr += m.basis.transpose() * dn.N_kurtosis * m.basis;
    }
    // The information at the true depths, H = E[S(d̂)] − M, inverted; the score's variance
    // S + M + N around it (a sandwich). In S's whitened coordinates L⁻¹ M L⁻ᵀ = Q diag(ρ) Qᵀ
    // (ρ: the share of a direction's information the depths' noise takes) and
    // H⁻¹ = L⁻ᵀ Q diag(1/(1 − ρ)) Qᵀ L⁻¹ (L: buildModel's Cholesky factor of S). The expansion
    // is second order: beyond ρ = kMaxDepthShare it is not trusted and 1/(1 − ρ) is held at 10,
    // continuously (a switch to the first-order inverse where S − M stops being positive
    // definite made the covariance blow up just before it and drop at it; a cap at ½ made the
    // white-3× Monte Carlo over-confident, docs/studies/depth-noise.md).
    // Sigma1 stays 0 x 0 when the gauge holds every pose (no free DoF: every covariance is 0
    // whatever the noise; Eigen's eigensolver does not take an empty matrix).
    Eigen::MatrixXd Sigma1(0, 0);
    if (m.Sr.rows() > 0) {
      const Eigen::MatrixXd Li = m.L_r.triangularView<Eigen::Lower>().solve(
          Eigen::MatrixXd::Identity(m.Sr.rows(), m.Sr.cols()));  // L⁻¹
      Eigen::MatrixXd W = Li * Mr * Li.transpose();
      W = 0.5 * (W + W.transpose()).eval();
      const Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd> es(W);
      const Eigen::VectorXd f = es.eigenvalues().unaryExpr(
          [](double rho) { return 1.0 / (1.0 - std::clamp(rho, 0.0, kMaxDepthShare)); });
      const Eigen::MatrixXd QtLi = es.eigenvectors().transpose() * Li;
      Sigma1 = QtLi.transpose() * f.asDiagonal() * QtLi;
      if (es.eigenvalues().size() > 0) summary.depth_noise_max_rho = es.eigenvalues().maxCoeff();
    }
    // The method's own covariance and the snapshot and linearization the query API answers on:
    // sandwich's and nuisance's reduced one on the snapshot; else that of its inflations, which
    // are the white factors (vce) or go beyond them (score, autocorr: a model of their own).
    CovarianceOptions so = solver;
    const Snapshot* on = &s;
    Snapshot inflated;
    Eigen::MatrixXd V;
    if (cal.reduced_covariance) {
      V = *cal.reduced_covariance;
      so.linearization = cal.linearization;
    } else if (infl == white_factors) {
      V = m.Sigma_r;
      so.linearization = std::make_shared<const DbaNormalEquations>(std::move(m.ne));
      on = &si;
    } else {
      inflated = inflateWeights(s, infl);
      DenseModel mi = buildModel(inflated, oc);
      V = std::move(mi.Sigma_r);
      so.linearization = std::make_shared<const DbaNormalEquations>(std::move(mi.ne));
      on = &inflated;
    }
    const Eigen::MatrixXd term = Sigma1 + Sigma1 * (Mv + Nr) * Sigma1 - m.Sigma_r;
    if (V.trace() > 0) summary.depth_noise_share = term.trace() / V.trace();
    summary.depth_noise_kurtosis = cal.depth_noise_kurtosis ? dn.kurtosis : 0.0;
    summary.depth_noise_cross_kurtosis = cal.depth_noise_kurtosis ? dn.cross_kurtosis : 0.0;
    V += term;
    V = 0.5 * (V + V.transpose()).eval();
    so.reduced_covariance = std::make_shared<const Eigen::MatrixXd>(std::move(V));
    DbaCovariance cov(*on, on == &s ? o : oc, so);  // the options its linearization was at
    cov.setSelfCalibrationSummary(std::move(summary));
    return cov;
  }
  if (cal.reduced_covariance) {
    CovarianceOptions so = solver;
    so.reduced_covariance = cal.reduced_covariance;
    so.linearization = cal.linearization;
    DbaCovariance cov(s, o, so);
    cov.setSelfCalibrationSummary(std::move(summary));
    return cov;
  }
  DbaCovariance cov(inflateWeights(s, cal.inflations()), oc, solver);
  cov.setSelfCalibrationSummary(std::move(summary));
  return cov;
}

OptimumDistance distanceFromOptimum(const Snapshot& s, const DbaOptions& o) {
  o.validate();
  s.validate();
  return optimumDistance(buildModel(s, o));
}

}  // namespace dbacov
