#include "dbacov/core/sequence_information.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <numeric>
#include <set>

#include <Eigen/Eigenvalues>
#include <Eigen/SparseCholesky>

#include "dbacov/core/gauge.h"
#include "dbacov/core/marginal_solver.h"

namespace dbacov {

void SequenceProblem::add(const Snapshot& s) {
  if (H_ < 0) {
    H_ = s.H;
    W_ = s.W;
    intrinsics_ = s.intrinsics;
  } else if (s.H != H_ || s.W != W_ || s.intrinsics != intrinsics_) {
    throw InputError(s.name() +
                     ": its grid or intrinsics differ from the first snapshot's; one sequence "
                     "problem needs one camera");
  }
  // DROID's stereo edges (one rig for the run) and RGB-D readings go into the sequence too.
  if (s.stereo_rig) {
    if (!stereo_rig_)
      stereo_rig_ = s.stereo_rig;
    else if (*s.stereo_rig != *stereo_rig_)
      throw InputError(s.name() +
                       ": its stereo rig differs from the first stereo snapshot's; one sequence "
                       "problem needs one rig");
  }
  ++snapshots_;
  const std::size_t P = s.pixelsPerFrame();
  for (int k : s.graphKeyframes()) {
    const double ts = s.tstamp[k];
    const auto [i, new_ts] = index_of_.emplace(ts, k);
    const auto [j, new_k] = tstamp_of_.emplace(k, ts);
    if ((!new_ts && i->second != k) || (!new_k && j->second != ts)) consistent_indices_ = false;
    Keyframe& kf = keyframes_[ts];
    kf.pose_cw = s.poses_cw.row(k);
    kf.disp.assign(s.disps.begin() + k * P, s.disps.begin() + (k + 1) * P);
    if (s.disps_sens)
      kf.disp_sens.assign(s.disps_sens->begin() + k * P, s.disps_sens->begin() + (k + 1) * P);
    if (s.timestamps_s) kf.time_s = (*s.timestamps_s)[k];
  }
  for (int e = 0; e < s.numEdges(); ++e) {
    Edge& edge = edges_[{s.tstamp[s.ii[e]], s.tstamp[s.jj[e]]}];
    edge.target.assign(s.targetPlane(e, 0), s.targetPlane(e, 0) + 2 * P);
    edge.weight.assign(s.weightPlane(e, 0), s.weightPlane(e, 0) + 2 * P);
  }
}

Snapshot SequenceProblem::assemble() const {
  if (keyframes_.empty()) throw InputError("sequence: no snapshot was added");
  Snapshot s;
  s.source = "sequence";
  s.H = H_;
  s.W = W_;
  s.intrinsics = intrinsics_;
  const std::size_t P = s.pixelsPerFrame();
  std::map<double, int> index;  // tstamp → row
  if (consistent_indices_) {
    index = index_of_;
  } else {
    for (const auto& [tstamp, kf] : keyframes_)
      index.emplace(tstamp, static_cast<int>(index.size()));
  }
  int N = 0;
  for (const auto& [tstamp, k] : index) N = std::max(N, k + 1);
  s.poses_cw = Eigen::Matrix<double, Eigen::Dynamic, 7, Eigen::RowMajor>::Zero(N, 7);
  s.poses_cw.col(6).setOnes();  // filler rows: identity, no edge
  s.disps.assign(static_cast<std::size_t>(N) * P, 0.0f);
  s.tstamp.resize(N);
  for (int k = 0; k < N; ++k) s.tstamp[k] = -1.0 - k;  // filler rows: a time stamp no one has
  bool times = true;
  std::vector<double> time_s(N, 0.0);
  s.stereo_rig = stereo_rig_;
  for (const auto& [tstamp, kf] : keyframes_)
    if (!kf.disp_sens.empty() && !s.disps_sens)  // 0: no reading (filler rows, mono keyframes)
      s.disps_sens = std::vector<float>(static_cast<std::size_t>(N) * P, 0.0f);
  for (const auto& [tstamp, kf] : keyframes_) {
    const int k = index.at(tstamp);
    s.tstamp[k] = tstamp;
    s.poses_cw.row(k) = kf.pose_cw;
    std::copy(kf.disp.begin(), kf.disp.end(), s.disps.begin() + k * P);
    if (!kf.disp_sens.empty())
      std::copy(kf.disp_sens.begin(), kf.disp_sens.end(), s.disps_sens->begin() + k * P);
    times = times && kf.time_s.has_value();
    time_s[k] = kf.time_s.value_or(0.0);
  }
  if (times) s.timestamps_s = time_s;
  s.target.reserve(edges_.size() * 2 * P);
  s.weight.reserve(edges_.size() * 2 * P);
  for (const auto& [ts, edge] : edges_) {
    s.ii.push_back(index.at(ts.first));
    s.jj.push_back(index.at(ts.second));
    s.target.insert(s.target.end(), edge.target.begin(), edge.target.end());
    s.weight.insert(s.weight.end(), edge.weight.begin(), edge.weight.end());
  }
  return s;
}

GaugedInformation gaugedInformation(const Snapshot& s, const DbaOptions& options) {
  const DbaNormalEquations ne = linearizeDba(s, options);
  const GaugeParameterization gauge = makeGauge(options.gauge, s, ne.keyframes);
  checkGaugeReachesAll(ne.S, gauge, ne.keyframes);
  const int root = gauge.gauge_slots[0], second = gauge.gauge_slots[1];
  if (root != 0 || second != 1)
    throw NumericalError("the gauge keyframes " +
                             joinKeyframes({ne.keyframes[root], ne.keyframes[second]}) +
                             " are not the two lowest graph keyframes",
                         {ne.keyframes[root], ne.keyframes[second]});
  GaugedInformation g;
  g.keyframes = ne.keyframes;
  for (int k : ne.keyframes) g.T_wc.push_back(s.T_wc(k));
  const int n = ne.S.numSlots();
  std::vector<Eigen::Triplet<double>> trip;
  for (int a = 1; a < n; ++a)
    for (const auto& [b, M] : ne.S.row(a)) {
      Matrix6d B = M;
      if (a == second && b == second) {
        // The gauge's prior on the second keyframe, in the full tangent (gauge.h).
        const double stiff = kStiffGauge * std::max(M.diagonal().maxCoeff(), 1e-300);
        if (options.gauge.type == GaugeOptions::Type::TwoPose) {
          for (int c = 0; c < 6; ++c) {
            const double sigma = c < 3 ? options.gauge.sigma_trans : options.gauge.sigma_rot;
            B(c, c) += sigma > 0 ? 1.0 / (sigma * sigma) : stiff;
          }
        } else {
          // Removed direction = the unit vector orthogonal to the kept basis.
          const Eigen::MatrixXd Q = gauge.basis[second];
          const Eigen::MatrixXd P = Matrix6d::Identity() - Q * Q.transpose();
          B += stiff * P;
        }
      }
      if (a == second && b == second) g.gauge_prior = B - M;
      for (int c = 0; c < 6; ++c)
        for (int r = 0; r < 6; ++r)
          if (a != b || r <= c) trip.emplace_back(6 * (a - 1) + r, 6 * (b - 1) + c, B(r, c));
    }
  g.S = ne.S;
  g.Lambda.resize(6 * (n - 1), 6 * (n - 1));
  g.Lambda.setFromTriplets(trip.begin(), trip.end());
  return g;
}

namespace {

using SparseMatrix = Eigen::SparseMatrix<double>;

SparseMatrix fullSymmetric(const SparseMatrix& upper) {
  SparseMatrix full = upper.selfadjointView<Eigen::Upper>();
  return full;
}

double logDetOrThrow(const SparseMatrix& A_full, const std::string& what) {
  Eigen::SimplicialLLT<SparseMatrix> llt(A_full);
  if (llt.info() != Eigen::Success) throw NumericalError(what + " is not positive definite", {});
  const SparseMatrix L = llt.matrixL();
  double ld = 0;
  for (int k = 0; k < L.cols(); ++k) ld += 2 * std::log(L.coeff(k, k));
  return ld;
}

bool positiveDefinite(const SparseMatrix& A_full) {
  Eigen::SimplicialLLT<SparseMatrix> llt(A_full);
  return llt.info() == Eigen::Success;
}

}  // namespace

namespace {

struct EdgeData {
  int a, b;            // slots
  Matrix6d Jf, Jt;     // edge Jacobians at the linearization point
  Matrix6d Sigma_rel;  // relative covariance under Λ
};

/// Full symmetric H = Σ_e J_eᵀ Ω_e J_e over the non-root slots.
SparseMatrix assembleExported(const std::vector<EdgeData>& ed, const std::vector<PoseGraphEdge>& e,
                              int n) {
  std::vector<Eigen::Triplet<double>> trip;
  auto put = [&](int p, int q, const Matrix6d& M) {
    for (int c = 0; c < 6; ++c)
      for (int r = 0; r < 6; ++r) {
        trip.emplace_back(6 * (p - 1) + r, 6 * (q - 1) + c, M(r, c));
        if (p != q) trip.emplace_back(6 * (q - 1) + c, 6 * (p - 1) + r, M(r, c));
      }
  };
  for (std::size_t k = 0; k < ed.size(); ++k) {
    const Matrix6d& O = e[k].information;
    if (ed[k].a > 0) {
      put(ed[k].a, ed[k].a, ed[k].Jf.transpose() * O * ed[k].Jf);
      put(ed[k].a, ed[k].b, ed[k].Jf.transpose() * O * ed[k].Jt);
    }
    put(ed[k].b, ed[k].b, ed[k].Jt.transpose() * O * ed[k].Jt);
  }
  SparseMatrix H(n, n);
  H.setFromTriplets(trip.begin(), trip.end());
  return H;
}

/// J [M_aa M_ab; M_ba M_bb] Jᵀ of an edge, J = [Jf at slot a, Jt at slot b] (no Jf at the
/// root), symmetrized; block(p, q) is M's 6×6 block between slots p and q.
template <class Block>
Matrix6d projectOnEdge(const EdgeData& e, const Block& block) {
  Matrix6d C = e.Jt * block(e.b, e.b) * e.Jt.transpose();
  if (e.a > 0) {
    const Matrix6d Cab = e.Jf * block(e.a, e.b) * e.Jt.transpose();
    C += e.Jf * block(e.a, e.a) * e.Jf.transpose() + Cab + Cab.transpose();
  }
  return 0.5 * (C + C.transpose());
}

/// Relative covariance J [Σ_aa Σ_ab; Σ_ba Σ_bb] Jᵀ of every edge under the inverse of A (full).
std::vector<Matrix6d> edgeCovariances(const SparseMatrix& A, const std::vector<EdgeData>& ed) {
  std::unique_ptr<MarginalSolver> solver = makeCholmodMarginalSolver();
  solver->factorize(SparseMatrix(A.triangularView<Eigen::Upper>()));
  auto idx = [](int slot) {
    std::vector<int> v(6);
    std::iota(v.begin(), v.end(), 6 * (slot - 1));
    return v;
  };
  std::vector<Matrix6d> out;
  auto block = [&](int p, int q) { return Matrix6d(solver->covariance(idx(p), idx(q))); };
  for (const EdgeData& e : ed) out.push_back(projectOnEdge(e, block));
  return out;
}

bool positiveDefinite6(const Matrix6d& M) {
  Eigen::LLT<Matrix6d> llt(M);
  return llt.info() == Eigen::Success;
}

/// Conservative log-det maximization over the edge informations (a barrier method):
///   maximize log det H(Ω) + μ log det(Λ − H(Ω)),  μ → 0,   H(Ω) = Σ_e J_eᵀ Ω_e J_e,
/// by natural-gradient steps Ω_e ← Ω_e + η Ω_e (Σ̂_e − μ Ŝ_e) Ω_e, with Σ̂_e and Ŝ_e the edge's
/// relative covariance under H⁻¹ and (Λ − H)⁻¹ (the gradient of the objective in Ω_e), η halved
/// until every Ω_e and Λ − H stay positive definite and the objective increases. Every iterate is
/// feasible, so the result never exceeds Λ. Returns the number of accepted steps.
int maximizeLogDet(const SparseMatrix& Lf, const std::vector<EdgeData>& ed,
                   std::vector<PoseGraphEdge>& edges) {
  const int n = static_cast<int>(Lf.rows());
  auto objective = [&](const std::vector<PoseGraphEdge>& e, double mu, bool* ok) {
    const SparseMatrix H = assembleExported(ed, e, n);
    Eigen::SimplicialLLT<SparseMatrix> lh(H), lr(SparseMatrix(Lf - H));
    *ok = lh.info() == Eigen::Success && lr.info() == Eigen::Success;
    if (!*ok) return 0.0;
    double f = 0;
    const SparseMatrix Lh = lh.matrixL(), Lr = lr.matrixL();
    for (int k = 0; k < n; ++k)
      f += 2 * std::log(Lh.coeff(k, k)) + mu * 2 * std::log(Lr.coeff(k, k));
    return f;
  };
  // Start strictly inside the feasible set (the certified scale is on its boundary).
  for (PoseGraphEdge& e : edges) e.information *= 0.5;
  int accepted = 0;
  for (double mu : {1.0, 0.3, 0.1, 0.03, 0.01, 0.003, 0.001, 3e-4, 1e-4}) {
    bool ok = false;
    double f = objective(edges, mu, &ok);
    if (!ok) break;
    for (int it = 0; it < 40; ++it) {
      const SparseMatrix H = assembleExported(ed, edges, n);
      const std::vector<Matrix6d> Sh = edgeCovariances(H, ed);
      const std::vector<Matrix6d> Sr = edgeCovariances(SparseMatrix(Lf - H), ed);
      std::vector<Matrix6d> step(edges.size());
      for (std::size_t k = 0; k < edges.size(); ++k)
        step[k] = edges[k].information * (Sh[k] - mu * Sr[k]) * edges[k].information;
      bool moved = false;
      for (double eta = 1.0; eta > 1e-4; eta *= 0.5) {
        std::vector<PoseGraphEdge> trial = edges;
        bool pd = true;
        for (std::size_t k = 0; k < trial.size() && pd; ++k) {
          Matrix6d O = trial[k].information + eta * step[k];
          trial[k].information = 0.5 * (O + O.transpose());
          pd = positiveDefinite6(trial[k].information);
        }
        if (!pd) continue;
        bool feasible = false;
        const double ft = objective(trial, mu, &feasible);
        if (feasible && ft > f) {
          const bool small = ft - f < 1e-6 * std::abs(f) + 1e-9;
          edges = std::move(trial);
          f = ft;
          moved = !small;
          ++accepted;
          break;
        }
      }
      if (!moved) break;
    }
  }
  return accepted;
}

constexpr double kMaxEdgeCondition = 1e-10;  // smallest / largest eigenvalue of an exported Ω

/// The same barrier objective maximized by block-coordinate ascent, one edge's 6×6 information
/// at a time and exactly. With the other edges fixed, H = H₋ₑ + JᵀΩJ and Λ − H = R₋ₑ − JᵀΩJ, and
/// by the determinant lemma the objective is, up to a constant,
///   logdet(P + Ω) + μ logdet(Q − Ω)
/// with P = (J H₋ₑ⁻¹ Jᵀ)⁻¹ = Σ̂⁻¹ − Ω₀ and Q = (J R₋ₑ⁻¹ Jᵀ)⁻¹ = Ŝ⁻¹ + Ω₀ (Σ̂, Ŝ the edge's relative
/// covariance under H⁻¹ and (Λ − H)⁻¹ at the current Ω₀). In the basis V that makes VᵀQV = I and
/// VᵀPV = D diagonal, Ω = V⁻ᵀ X V⁻¹ and the problem separates: each eigen-direction maximizes
/// log(d + x) + μ log(1 − x) on [0, 1), x = (1 − μ d) / (1 + μ).
/// Dense inverses of H and Λ − H are kept up to date by rank-6 Woodbury updates and recomputed
/// after every sweep. Unlike the natural-gradient steps it cannot stall where the objective is
/// flat along one edge and steep along another, and it gains from every edge added to the
/// topology (a superset of edges can only do as well or better). Cost O(n² |E|) per sweep. The
/// barrier weight μ starts high (each edge may then take at most 1/(1 + μ) of its slack): started
/// at μ = 1, the first sweep's greedy halvings left Λ − H with a condition number of 1e9 and the
/// in-place inverses lost feasibility.
int coordinateLogDet(const SparseMatrix& Lf, const std::vector<EdgeData>& ed_in,
                     std::vector<PoseGraphEdge>& edges) {
  const int n = static_cast<int>(Lf.rows());
  // Jacobi scaling: the stiff gauge prior makes Λ's condition number ~1e12, too much for dense
  // inverses updated in place. The subproblems only see J H⁻¹ Jᵀ, which the scaling leaves alone.
  const Eigen::VectorXd sc =
      Eigen::VectorXd(Lf.diagonal()).cwiseMax(1e-300).cwiseSqrt().cwiseInverse();
  const Eigen::MatrixXd L = sc.asDiagonal() * Eigen::MatrixXd(Lf) * sc.asDiagonal();
  std::vector<EdgeData> ed = ed_in;
  for (EdgeData& e : ed) {
    e.Jt = e.Jt * sc.segment<6>(6 * (e.b - 1)).asDiagonal();
    if (e.a > 0) e.Jf = e.Jf * sc.segment<6>(6 * (e.a - 1)).asDiagonal();
  }
  const Eigen::MatrixXd I = Eigen::MatrixXd::Identity(n, n);
  auto dense = [&]() { return Eigen::MatrixXd(assembleExported(ed, edges, n)); };
  Eigen::MatrixXd Hi, Ri;
  auto refresh = [&]() {
    const Eigen::MatrixXd H = dense();
    Eigen::LLT<Eigen::MatrixXd> lh(H), lr(L - H);
    if (lh.info() != Eigen::Success || lr.info() != Eigen::Success) return false;
    Hi = lh.solve(I);
    Ri = lr.solve(I);
    return true;
  };
  // J M Jᵀ (6×6, projectOnEdge) and M Jᵀ (n×6) of an edge.
  auto project = [](const Eigen::MatrixXd& M, const EdgeData& e) {
    return projectOnEdge(
        e, [&](int p, int q) -> Matrix6d { return M.block<6, 6>(6 * (p - 1), 6 * (q - 1)); });
  };
  auto timesJt = [](const Eigen::MatrixXd& M, const EdgeData& e) {
    Eigen::MatrixXd U = M.middleCols<6>(6 * (e.b - 1)) * e.Jt.transpose();
    if (e.a > 0) U += M.middleCols<6>(6 * (e.a - 1)) * e.Jf.transpose();
    return U;
  };
  // Start strictly inside (c is on the boundary); if no sweep is kept, c is what is returned.
  const std::vector<PoseGraphEdge> certified = edges;
  for (PoseGraphEdge& e : edges) e.information *= 0.5;
  if (!refresh()) {
    edges = certified;
    return 0;
  }
  int updates = 0;
  const Matrix6d I6 = Matrix6d::Identity();
  constexpr int kMaxSweeps = 10;  // per barrier weight; the gain per sweep stops it earlier
  // Path following: an intermediate μ only needs to be roughly centred (a sweep gaining less than
  // 1e-4 nats per DoF ends it), the last one more closely (1e-6). Cutting μ by 10 at a time
  // instead of ≈ 3 lost feasibility on a 100-keyframe loop; the loose stops halve the sweeps
  // (27-keyframe line: 110 → 65, KL 29.093 → 29.095 nats; 100 keyframes: 21 s → 12 s, 283 nats).
  const std::vector<double> mus = {10.0, 3.0, 1.0, 0.3, 0.1, 0.03, 0.01, 3e-3, 1e-3, 3e-4, 1e-4};
  for (double mu : mus) {
    for (int sweep = 0; sweep < kMaxSweeps; ++sweep) {
      const std::vector<PoseGraphEdge> feasible = edges;
      const int updates_before = updates;
      double gain = 0;
      for (std::size_t k = 0; k < edges.size(); ++k) {
        const Matrix6d Sh = project(Hi, ed[k]), Sr = project(Ri, ed[k]);
        const Matrix6d O0 = edges[k].information;
        Matrix6d P = Sh.inverse() - O0, Q = Sr.inverse() + O0;
        P = 0.5 * (P + P.transpose());
        Q = 0.5 * (Q + Q.transpose());
        const Eigen::LLT<Matrix6d> lq(Q);
        if (lq.info() != Eigen::Success) continue;
        const Matrix6d Lq = lq.matrixL();
        const Matrix6d Li = Lq.inverse();
        const Eigen::SelfAdjointEigenSolver<Matrix6d> es(Matrix6d(Li * P * Li.transpose()));
        const Vector6d d = es.eigenvalues().cwiseMax(0.0);
        auto value = [&](const Matrix6d& X) {  // logdet(D + X) + μ logdet(I − X), X in the basis
          const Eigen::LLT<Matrix6d> a(Matrix6d(d.asDiagonal()) + X), b(I6 - X);
          if (a.info() != Eigen::Success || b.info() != Eigen::Success)
            return -std::numeric_limits<double>::infinity();
          return 2 * Matrix6d(a.matrixL()).diagonal().array().log().sum() +
                 mu * 2 * Matrix6d(b.matrixL()).diagonal().array().log().sum();
        };
        const Matrix6d B = Lq * es.eigenvectors();  // Ω = B X Bᵀ
        const Matrix6d Bi = es.eigenvectors().transpose() * Li;
        // The exported Ω must stay an information matrix that a reader accepts (informationOf:
        // condition number below 1e12): directions the block would give nothing (x = 0) get a
        // floor t of their slack, raised until Ω is well conditioned; X ≺ I keeps it feasible.
        Vector6d x;
        Matrix6d O1;
        bool conditioned = false;
        for (double t : {1e-9, 1e-7, 1e-5, 1e-3, 1e-1}) {
          for (int i = 0; i < 6; ++i) x[i] = std::clamp((1 - mu * d[i]) / (1 + mu), t, 1 - 1e-9);
          O1 = B * x.asDiagonal() * B.transpose();
          O1 = 0.5 * (O1 + O1.transpose());
          const Vector6d ev = Eigen::SelfAdjointEigenSolver<Matrix6d>(O1).eigenvalues();
          if ((conditioned = ev.minCoeff() > kMaxEdgeCondition * ev.maxCoeff())) break;
        }
        if (!conditioned) continue;
        const double before = value(Matrix6d(Bi * O0 * Bi.transpose()));
        const double after = value(Matrix6d(x.asDiagonal()));
        if (!(after > before)) continue;
        const Matrix6d Delta = O1 - O0;
        // H⁻¹ ← H⁻¹ − H⁻¹Jᵀ Δ (I + Σ̂Δ)⁻¹ J H⁻¹;  (Λ − H)⁻¹ ← (Λ − H)⁻¹ + R⁻¹Jᵀ Δ (I − ŜΔ)⁻¹ J R⁻¹.
        const Eigen::MatrixXd Uh = timesJt(Hi, ed[k]), Ur = timesJt(Ri, ed[k]);
        const Matrix6d Ch = Delta * (I6 + Sh * Delta).inverse();
        const Matrix6d Cr = Delta * (I6 - Sr * Delta).inverse();
        Hi.noalias() -= Uh * Ch * Uh.transpose();
        Ri.noalias() += Ur * Cr * Ur.transpose();
        edges[k].information = O1;
        gain += after - before;
        ++updates;
      }
      // The updated inverses drift by rounding; a sweep that ends outside the feasible set (not
      // seen, but possible when Λ − H is nearly singular) is undone and the ascent stops there.
      if (!refresh()) {
        edges = updates_before > 0 ? feasible : certified;
        return updates_before;
      }
      if (gain < (mu == mus.back() ? 1e-6 : 1e-4) * n) break;
    }
  }
  return updates;
}

}  // namespace

SparsifiedGraph sparsifyInformation(const GaugedInformation& info, const Snapshot& s,
                                    GraphTopology topology, LogDetRefinement refine) {
  const int n_slots = static_cast<int>(info.keyframes.size());
  std::map<int, int> slot_of;
  for (int a = 0; a < n_slots; ++a) slot_of[info.keyframes[a]] = a;
  std::vector<std::pair<int, int>> pairs;  // slots, a < b
  if (topology == GraphTopology::Chain) {
    for (int a = 0; a + 1 < n_slots; ++a) pairs.emplace_back(a, a + 1);
  } else if (topology == GraphTopology::Covisibility) {
    for (const auto& [ka, kb] : s.relativePairs())
      pairs.emplace_back(slot_of.at(ka), slot_of.at(kb));
  } else {
    for (int a = 0; a < n_slots; ++a)
      for (const auto& [b, M] : info.S.row(a))
        if (b > a && !M.isZero(0)) pairs.emplace_back(a, b);
  }

  std::unique_ptr<MarginalSolver> solver = makeCholmodMarginalSolver();
  try {
    solver->factorize(info.Lambda);
  } catch (const FactorizationError& e) {
    // Λ holds the slots after the root (slot 0, the gauge): column c is slot c / 6 + 1.
    const int slot = e.column() >= 0 ? e.column() / 6 + 1 : -1;
    if (slot < 1 || slot >= n_slots)
      throw NumericalError("the sequence information is not positive definite", {});
    const int k = info.keyframes[slot];
    throw NumericalError("the sequence information is not positive definite at keyframe " +
                             std::to_string(k) +
                             " (its pose is not determined by the sequence's pixels beyond "
                             "the keyframes before it in the elimination order)",
                         {k});
  }
  auto idx = [](int slot) {
    std::vector<int> v(6);
    std::iota(v.begin(), v.end(), 6 * (slot - 1));
    return v;
  };

  // Marginal relative informations and H₁ = Σ_e J_eᵀ Ω_e J_e over the non-root slots.
  SparsifiedGraph out;
  std::vector<EdgeData> edata;
  std::vector<Eigen::Triplet<double>> trip;
  for (const auto& [a, b] : pairs) {
    Matrix12d joint = Matrix12d::Zero();
    if (a > 0) joint.topLeftCorner<6, 6>() = solver->covariance(idx(a), idx(a));
    joint.bottomRightCorner<6, 6>() = solver->covariance(idx(b), idx(b));
    if (a > 0) {
      joint.topRightCorner<6, 6>() = solver->covariance(idx(a), idx(b));
      joint.bottomLeftCorner<6, 6>() = joint.topRightCorner<6, 6>().transpose();
    }
    PoseGraphEdge e;
    e.from = info.keyframes[a];
    e.to = info.keyframes[b];
    e.Z = info.T_wc[a].inverse() * info.T_wc[b];
    const Matrix6d Sigma_rel = relativeCovariance(info.T_wc[a], info.T_wc[b], joint);
    if (topology == GraphTopology::Decomposition) {
      const Matrix6d Ad = adjoint(info.T_wc[b].inverse() * info.T_wc[a]);
      Matrix6d O = -Ad.transpose().inverse() * *info.S.find(a, b);
      O = 0.5 * (O + O.transpose());
      if (a == 0 && b == 1) O += info.gauge_prior;
      const Eigen::SelfAdjointEigenSolver<Matrix6d> es(O);
      const double floor = 1e-9 * std::max(es.eigenvalues().maxCoeff(), 1e-300);
      e.information = es.eigenvectors() * es.eigenvalues().cwiseMax(floor).asDiagonal() *
                      es.eigenvectors().transpose();
      e.information = 0.5 * (e.information + e.information.transpose());
    } else if (!informationOf(Sigma_rel, &e.information)) {
      throw NumericalError("the relative covariance of keyframes " + joinKeyframes({e.from, e.to}) +
                               " is not positive definite",
                           {e.from, e.to});
    }
    Vector6d r;
    Matrix6d Jf, Jt;
    poseGraphEdgeResidual(info.T_wc[a], info.T_wc[b], e.Z, &r, &Jf, &Jt);
    edata.push_back({a, b, Jf, Jt, Sigma_rel});
    const Matrix6d& O = e.information;
    auto put = [&](int p, int q, const Matrix6d& M) {  // block (p, q), p <= q, upper only
      for (int c = 0; c < 6; ++c)
        for (int rr = 0; rr < 6; ++rr)
          if (p != q || rr <= c) trip.emplace_back(6 * (p - 1) + rr, 6 * (q - 1) + c, M(rr, c));
    };
    if (a > 0) {
      put(a, a, Jf.transpose() * O * Jf);
      put(a, b, Jf.transpose() * O * Jt);
    }
    put(b, b, Jt.transpose() * O * Jt);
    out.graph.edges.push_back(e);
  }
  const int n = info.dim();
  SparseMatrix H1(n, n);
  H1.setFromTriplets(trip.begin(), trip.end());
  const SparseMatrix H1f = fullSymmetric(H1), Lf = fullSymmetric(info.Lambda);

  // λ_max(Λ⁻¹ H₁) by power iteration with the Rayleigh quotient (a lower bound), then certified.
  Eigen::VectorXd v = Eigen::VectorXd::Ones(n);
  double rho = 0;
  for (int it = 0; it < 300; ++it) {
    Eigen::VectorXd w = solver->solve(H1f * v);
    const double next = v.dot(H1f * v) / v.dot(Lf * v);
    v = w / w.norm();
    if (it > 10 && std::abs(next - rho) <= 1e-10 * next) {
      rho = next;
      break;
    }
    rho = next;
  }
  rho = std::max(rho, v.dot(H1f * v) / v.dot(Lf * v));
  double margin = 1e-6;
  double c = 1.0 / (rho * (1 + margin));
  while (!positiveDefinite(SparseMatrix(Lf - c * H1f))) {
    margin *= 4;
    c = 1.0 / (rho * (1 + margin));
    if (margin > 1) throw NumericalError("the sparsification scale could not be certified", {});
  }
  out.scale = c;
  out.dof = n;
  out.edges = out.graph.edges.size();
  const double logdet_L = logDetOrThrow(Lf, "the sequence information");
  for (PoseGraphEdge& e : out.graph.edges) {
    e.information *= c;
    e.information = 0.5 * (e.information + e.information.transpose());
  }
  if (refine == LogDetRefinement::Auto)
    refine = n <= kDenseBarrierDof ? LogDetRefinement::BlockCoordinate
                                   : LogDetRefinement::NaturalGradient;
  out.refinement = refine;
  if (refine == LogDetRefinement::BlockCoordinate)
    out.barrier_iterations = coordinateLogDet(Lf, edata, out.graph.edges);
  else if (refine == LogDetRefinement::NaturalGradient)
    out.barrier_iterations = maximizeLogDet(Lf, edata, out.graph.edges);
  const SparseMatrix H = assembleExported(edata, out.graph.edges, n);
  double trace = 0;
  for (std::size_t k = 0; k < edata.size(); ++k)
    trace += (out.graph.edges[k].information * edata[k].Sigma_rel).trace();
  out.kl = 0.5 * (trace - n - logDetOrThrow(H, "the exported information") + logdet_L);
  for (int a = 0; a < n_slots; ++a) {
    const int k = info.keyframes[a];
    out.graph.nodes[k] = info.T_wc[a];
    out.graph.node_tstamp[k] = s.tstamp[k];
    if (s.timestamps_s) out.graph.node_time[k] = (*s.timestamps_s)[k];
  }
  return out;
}

SequenceInformation sequenceInformation(const SequenceProblem& problem, const DbaOptions& options,
                                        const DbaSolverOptions& solver) {
  SequenceInformation si;
  si.problem = problem.assemble();
  si.problem.validate();
  if (solver.max_iterations > 0) si.solve = solveDba(si.problem, options, solver);
  si.info = gaugedInformation(si.problem, options);
  return si;
}

SequenceGraph sequenceGraph(const SequenceProblem& problem, const DbaOptions& options,
                            GraphTopology topology, const DbaSolverOptions& solver) {
  const SequenceInformation si = sequenceInformation(problem, options, solver);
  SparsifiedGraph sg = sparsifyInformation(si.info, si.problem, topology);
  SequenceGraph out;
  out.graph = std::move(sg.graph);
  out.solve = si.solve;
  out.edges = sg.edges;
  out.scale = sg.scale;
  out.kl = sg.kl;
  out.dof = sg.dof;
  return out;
}

}  // namespace dbacov
