#include "dbacov/core/covariance.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <limits>
#include <numeric>
#include <sstream>
#include <stdexcept>
#include <utility>

#include "dbacov/core/conditioning.h"
#include "dbacov/core/gauge.h"
#include "dbacov/core/given_model.h"
#include "dbacov/core/linearization.h"
#include "dbacov/core/marginal_solver.h"
#include "given_marginal_solver.h"

namespace dbacov {

struct DbaCovariance::Impl {
  DbaNormalEquations ne;
  GaugeParameterization gauge;
  std::unique_ptr<MarginalSolver> solver;
  std::vector<Eigen::Isometry3d> T_wc;  // per keyframe index (identity for keyframes not in graph)
  bool depth_variances = false;
  int H = 0, W = 0;
  CovarianceSummary summary;

  int slot(int keyframe) const {
    if (keyframe < 0 || keyframe >= static_cast<int>(ne.slot_of.size()) || ne.slot_of[keyframe] < 0)
      throw std::invalid_argument("keyframe " + std::to_string(keyframe) +
                                  " is not in the snapshot's graph");
    return ne.slot_of[keyframe];
  }

  std::vector<int> reducedIndices(int s) const {
    std::vector<int> idx(gauge.dimOf(s));
    std::iota(idx.begin(), idx.end(), gauge.offset[s]);
    return idx;
  }

  /// Σ[ξ_a, ξ_b] = basis_a Σ_r[a, b] basis_bᵀ.
  Matrix6d crossBlock(int sa, int sb) const {
    if (gauge.dimOf(sa) == 0 || gauge.dimOf(sb) == 0) return Matrix6d::Zero();
    const Eigen::MatrixXd Sr = solver->covariance(reducedIndices(sa), reducedIndices(sb));
    return gauge.basis[sa] * Sr * gauge.basis[sb].transpose();
  }
};

namespace {

/// A free keyframe whose covariance is numerically singular is a numerical failure, never a
/// keyframe that looks gauge-fixed (conditioning.h).
void checkConditioning(const DbaCovariance& cov) {
  std::vector<int> singular;
  double worst = 0;
  for (int k : cov.keyframes()) {
    const double c = freeConditionNumber(cov.marginal(k), cov.freeDof(k));
    if (!(c <= kMaxConditionNumber)) {
      singular.push_back(k);
      worst = std::max(worst, c);
    }
  }
  if (singular.empty()) return;
  std::ostringstream cond;
  cond.precision(3);
  cond << worst;
  throw NumericalError("the covariances of keyframes " + joinKeyframes(singular) +
                           " are numerically singular (condition number " + cond.str() +
                           " > 1e14 over their free DoF): their poses are not determined in "
                           "double precision; check the scale of the inverse depths 'disps' and "
                           "of the focal lengths 'intrinsics'",
                       singular);
}

}  // namespace

DbaCovariance::DbaCovariance(const Snapshot& snapshot, const DbaOptions& options,
                             const CovarianceOptions& so)
    : DbaCovariance(snapshot, options, so, nullptr) {}

DbaCovariance::DbaCovariance(const Snapshot& snapshot, const DbaOptions& options,
                             const CovarianceOptions& so, const detail::GivenModel* given)
    : impl_(std::make_unique<Impl>()) {
  using Clock = std::chrono::steady_clock;
  auto seconds = [](Clock::time_point a, Clock::time_point b) {
    return std::chrono::duration<double>(b - a).count();
  };
  options.validate();
  snapshot.validate();  // the API boundary: InputError for an invalid snapshot (covariance.h)
  Impl& m = *impl_;
  const auto t0 = Clock::now();
  const std::shared_ptr<const DbaNormalEquations> linearization =
      given && !so.depth_variances ? given->linearization : nullptr;
  if (linearization &&
      (static_cast<int>(linearization->slot_of.size()) != snapshot.numKeyframes() ||
       linearization->keyframes != snapshot.graphKeyframes()))
    throw std::invalid_argument("the given linearization is not that of this snapshot (" +
                                snapshot.source + "): its keyframes differ");
  m.ne = linearization ? *linearization : linearizeDba(snapshot, options, so.depth_variances);
  m.H = snapshot.H;
  m.W = snapshot.W;
  finish(gaugeGraph(snapshot), snapshot.numKeyframes(), snapshot.numEdges(), options, so, given,
         seconds(t0, Clock::now()));
}

DbaCovariance::DbaCovariance(const PatchGraph& graph, const DbaOptions& options,
                             const CovarianceOptions& so)
    : impl_(std::make_unique<Impl>()) {
  options.validate();
  graph.validate();  // the API boundary, as for snapshots
  const auto t0 = std::chrono::steady_clock::now();
  impl_->ne = linearizePatchGraph(graph, options, so.depth_variances);
  impl_->H = 1;  // inverseDepthSigma answers one value per patch of the frame
  impl_->W = graph.M;
  finish(gaugeGraph(graph), graph.numFrames(), graph.numEdges(), options, so, nullptr,
         std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count());
}

void DbaCovariance::finish(const GaugeGraph& graph, int num_frames, int num_edges,
                           const DbaOptions& options, const CovarianceOptions& so,
                           const detail::GivenModel* given, double seconds_linearize) {
  using Clock = std::chrono::steady_clock;
  auto seconds = [](Clock::time_point a, Clock::time_point b) {
    return std::chrono::duration<double>(b - a).count();
  };
  Impl& m = *impl_;
  const std::shared_ptr<const Eigen::MatrixXd> reduced_covariance =
      given ? given->reduced_covariance : nullptr;
  const auto t1 = Clock::now();
  // Values that pass validation can still overflow double precision in the factor (e.g. a
  // principal point of 1e154): refuse before the solver turns them into NaN covariances.
  for (int a = 0; a < m.ne.S.numSlots(); ++a)
    for (const auto& [b, block] : m.ne.S.row(a))
      if (!block.allFinite()) {
        const int ka = m.ne.keyframes[a], kb = m.ne.keyframes[b];
        throw NumericalError(
            "the information matrix has non-finite entries " +
                (a == b
                     ? "at keyframe " + std::to_string(ka)
                     : "between keyframes " + std::to_string(ka) + " and " + std::to_string(kb)) +
                ": the snapshot's values overflow double precision in the DBA factor (intrinsics, "
                "poses or inverse depths far out of range)",
            a == b ? std::vector<int>{ka} : std::vector<int>{ka, kb});
      }
  m.depth_variances = so.depth_variances;
  m.gauge = makeGauge(options.gauge, graph, m.ne.keyframes);
  checkGaugeReachesAll(m.ne.S, m.gauge, m.ne.keyframes);
  // The reduced system lives only until it is factorized (it is as large as S).
  Eigen::SparseMatrix<double> S_reduced = m.gauge.dim() > 0 && !reduced_covariance
                                              ? reduceSystem(m.ne.S, m.gauge)
                                              : Eigen::SparseMatrix<double>();
  const auto t2 = Clock::now();
  m.T_wc.assign(num_frames, Eigen::Isometry3d::Identity());
  for (int k : m.ne.keyframes) m.T_wc[k] = graph.T_wc(k);

  if (reduced_covariance) {
    // A given covariance (the self-calibration's) instead of S⁻¹.
    m.solver = makeGivenMarginalSolver(*reduced_covariance, m.gauge.dim());
  } else {
    switch (so.kind) {
      case SolverKind::Sparse:
        m.solver = makeCholmodMarginalSolver(so.ordering);
        break;
      case SolverKind::Dense:
        m.solver = makeDenseMarginalSolver();
        break;
    }
  }
  try {
    // A gauge that fixes every keyframe (two keyframes, hard two-pose gauge) leaves nothing free:
    // every covariance is zero and there is nothing to factorize.
    if (m.gauge.dim() > 0 && !reduced_covariance) m.solver->factorize(S_reduced);
    S_reduced = Eigen::SparseMatrix<double>();
  } catch (const FactorizationError& e) {
    std::vector<int> kf;
    if (e.column() >= 0) kf.push_back(m.ne.keyframes[m.gauge.slotOfColumn(e.column())]);
    throw NumericalError(
        "the reduced information matrix S is not positive definite" +
            (kf.empty() ? std::string() : " (breakdown at keyframe " + joinKeyframes(kf) + ")") +
            ": some motion is unobservable (degenerate geometry, too few weighted pixels, or "
            "a gauge that does not fix every DoF)",
        kf);
  }
  const auto t3 = Clock::now();
  CovarianceSummary& sum = m.summary;
  sum.solver = m.solver->name();
  sum.ordering = toString(so.ordering);
  sum.keyframes = static_cast<int>(m.ne.keyframes.size());
  sum.edges = num_edges;
  sum.free_dof = m.gauge.dim();
  sum.factor_entries = m.gauge.dim() > 0 ? m.solver->factorEntries() : 0;
  sum.linearization = m.ne.stats;
  if (given) sum.self_calibration = given->calibration;
  sum.seconds_linearize = seconds_linearize;
  sum.seconds_gauge = seconds(t1, t2);
  sum.seconds_factorize = seconds(t2, t3);
  // A finite, positive definite S so ill-conditioned that its inverse overflows.
  std::vector<int> overflow;
  for (int k : m.ne.keyframes)
    if (!marginal(k).allFinite()) overflow.push_back(k);
  if (!overflow.empty())
    throw NumericalError("the covariances of keyframes " + joinKeyframes(overflow) +
                             " overflow double precision (the information matrix is numerically "
                             "singular)",
                         overflow);
  checkConditioning(*this);
}

DbaCovariance::~DbaCovariance() = default;
DbaCovariance::DbaCovariance(DbaCovariance&&) noexcept = default;
DbaCovariance& DbaCovariance::operator=(DbaCovariance&&) noexcept = default;

const std::vector<int>& DbaCovariance::keyframes() const {
  return impl_->ne.keyframes;
}

bool DbaCovariance::contains(int k) const {
  return k >= 0 && k < static_cast<int>(impl_->ne.slot_of.size()) && impl_->ne.slot_of[k] >= 0;
}

std::vector<int> DbaCovariance::gaugeKeyframes() const {
  std::vector<int> kf;
  for (int s : impl_->gauge.gauge_slots) kf.push_back(impl_->ne.keyframes[s]);
  return kf;
}

int DbaCovariance::freeDof(int k) const {
  return impl_->gauge.dimOf(impl_->slot(k));
}

Matrix6d DbaCovariance::marginal(int k) const {
  const int s = impl_->slot(k);
  const Matrix6d C = impl_->crossBlock(s, s);
  return 0.5 * (C + C.transpose());
}

Matrix12d DbaCovariance::joint(int a, int b) const {
  const int sa = impl_->slot(a), sb = impl_->slot(b);
  Matrix12d J;
  J.topLeftCorner<6, 6>() = marginal(a);
  J.bottomRightCorner<6, 6>() = marginal(b);
  J.topRightCorner<6, 6>() = impl_->crossBlock(sa, sb);
  J.bottomLeftCorner<6, 6>() = J.topRightCorner<6, 6>().transpose();
  return J;
}

Matrix6d DbaCovariance::relative(int a, int b) const {
  return relativeCovariance(T_wc(a), T_wc(b), joint(a, b));
}

std::vector<int> DbaCovariance::sourceKeyframes() const {
  std::vector<int> kf;
  for (const DepthTerms& d : impl_->ne.depths) kf.push_back(impl_->ne.keyframes[d.source_slot]);
  return kf;
}

std::vector<float> DbaCovariance::inverseDepthSigma(int k) const {
  const Impl& m = *impl_;
  if (!m.depth_variances)
    throw std::logic_error("inverseDepthSigma needs CovarianceOptions::depth_variances");
  const int slot = m.slot(k);
  std::vector<float> sigma(static_cast<std::size_t>(m.H) * m.W,
                           std::numeric_limits<float>::quiet_NaN());
  const auto it = std::find_if(m.ne.depths.begin(), m.ne.depths.end(),
                               [&](const DepthTerms& d) { return d.source_slot == slot; });
  if (it == m.ne.depths.end() || it->pixel.empty()) return sigma;
  const DepthTerms& dt = *it;

  // b_k in reduced coordinates of the touched slots: β_a = basis_aᵀ b_k[a].
  std::vector<int> idx;
  for (int a : dt.touched) {
    const std::vector<int> r = m.reducedIndices(a);
    idx.insert(idx.end(), r.begin(), r.end());
  }
  const int P = static_cast<int>(dt.pixel.size());
  Eigen::MatrixXd beta(idx.size(), P);
  for (std::size_t t = 0, row = 0; t < dt.touched.size(); ++t) {
    const int a = dt.touched[t], da = m.gauge.dimOf(a);
    beta.middleRows(row, da) = m.gauge.basis[a].transpose() * dt.B.middleRows(6 * t, 6);
    row += da;
  }
  // The touched slots form a clique of S, so this block lies on the factor's pattern. (None of
  // them may be free: then the poses are fixed and var(d) = 1/h.)
  const Eigen::MatrixXd Q = idx.empty() ? Eigen::MatrixXd::Zero(0, P)
                                        : Eigen::MatrixXd(m.solver->covariance(idx, idx) * beta);
  for (int c = 0; c < P; ++c) {
    const double h = dt.h[c];
    const double var = 1.0 / h + beta.col(c).dot(Q.col(c)) / (h * h);
    sigma[dt.pixel[c]] = static_cast<float>(std::sqrt(var));
  }
  return sigma;
}

const Eigen::Isometry3d& DbaCovariance::T_wc(int k) const {
  impl_->slot(k);
  return impl_->T_wc[k];
}

const LinearizationStats& DbaCovariance::stats() const {
  return impl_->ne.stats;
}

const CovarianceSummary& DbaCovariance::summary() const {
  return impl_->summary;
}

}  // namespace dbacov
