#include "dbacov/core/pose_graph.h"

#include <numeric>

#include <Eigen/Eigenvalues>

#include "dbacov/core/block_matrix.h"
#include "dbacov/core/marginal_solver.h"

namespace dbacov {

bool informationOf(const Matrix6d& Sigma, Matrix6d* information) {
  const Eigen::SelfAdjointEigenSolver<Matrix6d> es(0.5 * (Sigma + Sigma.transpose()));
  const Vector6d lambda = es.eigenvalues();
  if (!(lambda.minCoeff() > 1e-12 * lambda.maxCoeff()) || !(lambda.minCoeff() > 0)) return false;
  const Matrix6d I =
      es.eigenvectors() * lambda.cwiseInverse().asDiagonal() * es.eigenvectors().transpose();
  *information = 0.5 * (I + I.transpose());  // exactly symmetric: serializers keep one triangle
  return true;
}

void PoseGraphBuilder::add(const Snapshot& s, const DbaCovariance& cov) {
  for (int k : cov.keyframes()) {
    partial_.nodes[k] = cov.T_wc(k);
    partial_.node_tstamp[k] = s.tstamp[k];
    if (s.timestamps_s) partial_.node_time[k] = (*s.timestamps_s)[k];
  }
  for (const auto& [a, b] : s.relativePairs()) {
    seen_.emplace(a, b);
    PoseGraphEdge e;
    if (!informationOf(cov.relative(a, b), &e.information)) continue;
    e.from = a;
    e.to = b;
    e.Z = cov.T_wc(a).inverse() * cov.T_wc(b);
    edges_[{a, b}] = e;
  }
}

PoseGraph PoseGraphBuilder::graph() const {
  PoseGraph g = partial_;
  for (const auto& [ids, e] : edges_) g.edges.push_back(e);
  return g;
}

std::size_t PoseGraphBuilder::numUninformativePairs() const {
  return seen_.size() - edges_.size();
}

void poseGraphEdgeResidual(const Eigen::Isometry3d& T_from, const Eigen::Isometry3d& T_to,
                           const Eigen::Isometry3d& Z, Vector6d* r, Matrix6d* J_from,
                           Matrix6d* J_to) {
  // r(δ_from, δ_to) = Log(Z⁻¹ Exp(−δ_from) T_from⁻¹ T_to Exp(δ_to))
  //                 = Log(Exp(r) Exp(δ_to − Ad(T_to⁻¹ T_from) δ_from))  (first order)
  //                 ≈ r + Jr(r)⁻¹ (δ_to − Ad(T_to⁻¹ T_from) δ_from).
  *r = logSE3(Z.inverse() * T_from.inverse() * T_to);
  const Matrix6d Jinv = rightJacobianSE3(*r).inverse();
  if (J_to) *J_to = Jinv;
  if (J_from) *J_from = -Jinv * adjoint(T_to.inverse() * T_from);
}

std::size_t fuseParallelEdges(PoseGraph& g) {
  std::map<std::pair<int, int>, std::vector<PoseGraphEdge>> groups;
  for (PoseGraphEdge e : g.edges) {
    if (e.from > e.to) {
      const Matrix6d Ad = adjoint(e.Z.inverse());
      e.information = Ad.transpose() * e.information * Ad;
      e.information = 0.5 * (e.information + e.information.transpose());
      e.Z = e.Z.inverse();
      std::swap(e.from, e.to);
    }
    groups[{e.from, e.to}].push_back(e);
  }
  const std::size_t before = g.edges.size();
  g.edges.clear();
  for (auto& [ids, edges] : groups) {
    PoseGraphEdge fused = edges.front();
    if (edges.size() > 1) {
      Matrix6d H = Matrix6d::Zero();
      for (int it = 0; it < 50; ++it) {
        H.setZero();
        Vector6d b = Vector6d::Zero();
        for (const PoseGraphEdge& e : edges) {
          const Vector6d r = logSE3(e.Z.inverse() * fused.Z);
          const Matrix6d J = rightJacobianSE3(r).inverse();
          H += J.transpose() * e.information * J;
          b += J.transpose() * e.information * r;
        }
        const Vector6d delta = -H.ldlt().solve(b);
        fused.Z = fused.Z * expSE3(delta);
        if (delta.norm() < 1e-14) break;
      }
      fused.information = 0.5 * (H + H.transpose());
    }
    g.edges.push_back(fused);
  }
  return before - g.edges.size();
}

namespace {

/// Gauss-Newton system over the free nodes: H (block upper), g = Σ Jᵀ Λ r, cost.
struct PoseGraphSystem {
  std::map<int, int> slot;  // free node → slot
  std::vector<int> ids;     // slot → node
  BlockSymmetricMatrix H;
  Eigen::VectorXd g;
  double cost = 0;
};

PoseGraphSystem assemble(const PoseGraph& g, const std::set<int>& fixed) {
  PoseGraphSystem sys;
  for (const auto& [id, T] : g.nodes)
    if (!fixed.count(id)) {
      sys.slot[id] = static_cast<int>(sys.ids.size());
      sys.ids.push_back(id);
    }
  const int n = static_cast<int>(sys.ids.size());
  sys.H = BlockSymmetricMatrix(n);
  for (int a = 0; a < n; ++a) sys.H.at(a, a);
  sys.g = Eigen::VectorXd::Zero(6 * n);
  for (const PoseGraphEdge& e : g.edges) {
    const auto f = g.nodes.find(e.from), t = g.nodes.find(e.to);
    if (f == g.nodes.end() || t == g.nodes.end())
      throw InputError("edge " + std::to_string(e.from) + " -> " + std::to_string(e.to) +
                       " names a node that the graph does not have");
    Vector6d r;
    Matrix6d Jf, Jt;
    poseGraphEdgeResidual(f->second, t->second, e.Z, &r, &Jf, &Jt);
    sys.cost += r.dot(e.information * r);
    const auto sf = sys.slot.find(e.from), st = sys.slot.find(e.to);
    if (sf != sys.slot.end()) {
      sys.H.add(sf->second, sf->second, Jf.transpose() * e.information * Jf);
      sys.g.segment<6>(6 * sf->second) += Jf.transpose() * e.information * r;
    }
    if (st != sys.slot.end()) {
      sys.H.add(st->second, st->second, Jt.transpose() * e.information * Jt);
      sys.g.segment<6>(6 * st->second) += Jt.transpose() * e.information * r;
    }
    if (sf != sys.slot.end() && st != sys.slot.end())
      sys.H.add(sf->second, st->second, Jf.transpose() * e.information * Jt);
  }
  return sys;
}

}  // namespace

std::pair<double, double> poseGraphCostAndGradient(const PoseGraph& g, const std::set<int>& fixed) {
  const PoseGraphSystem sys = assemble(g, fixed);
  return {sys.cost, sys.g.size() ? sys.g.cwiseAbs().maxCoeff() : 0.0};
}

PoseGraphOptimizerSummary optimizePoseGraph(PoseGraph& g, const std::set<int>& fixed,
                                            const PoseGraphOptimizerOptions& o) {
  PoseGraphOptimizerSummary sum;
  PoseGraphSystem sys = assemble(g, fixed);
  sum.initial_cost = sum.final_cost = sys.cost;
  double lambda = 1e-6;
  for (int it = 0; it < o.max_iterations; ++it) {
    if (sys.g.size() == 0 || sys.g.cwiseAbs().maxCoeff() < o.gradient_tolerance) {
      sum.converged = true;
      break;
    }
    // Damped step: (H + λ diag(H)) δ = −g; on a rejected step λ grows and H is kept.
    bool accepted = false;
    while (!accepted && lambda < 1e12) {
      Eigen::SparseMatrix<double> A = sys.H.toSparseUpper();
      for (int k = 0; k < A.rows(); ++k) A.coeffRef(k, k) *= 1.0 + lambda;
      Eigen::VectorXd delta;
      try {
        auto solver = makeCholmodMarginalSolver();
        solver->factorize(A);
        delta = -solver->solve(sys.g);
      } catch (const FactorizationError&) {
        lambda *= 10;
        continue;
      }
      PoseGraph trial = g;
      for (std::size_t a = 0; a < sys.ids.size(); ++a)
        trial.nodes[sys.ids[a]] = trial.nodes[sys.ids[a]] * expSE3(delta.segment<6>(6 * a));
      PoseGraphSystem next = assemble(trial, fixed);
      if (next.cost <= sys.cost) {
        const double decrease = sys.cost - next.cost;
        g = std::move(trial);
        sys = std::move(next);
        lambda = std::max(lambda / 10, 1e-12);
        accepted = true;
        ++sum.iterations;
        if (decrease <= o.cost_tolerance * std::max(sys.cost, 1e-300)) sum.converged = true;
      } else {
        lambda *= 10;
      }
    }
    if (!accepted || sum.converged) break;
  }
  sum.final_cost = sys.cost;
  sum.final_gradient = sys.g.size() ? sys.g.cwiseAbs().maxCoeff() : 0.0;
  if (sum.final_gradient < o.gradient_tolerance) sum.converged = true;
  return sum;
}

std::map<int, Matrix6d> poseGraphCovariances(const PoseGraph& g, const std::set<int>& fixed,
                                             SolverKind solver_kind) {
  // Parts of the graph that no fixed node reaches make H singular: name them first.
  std::map<int, int> parent;
  for (const auto& [id, T] : g.nodes) parent[id] = id;
  auto root = [&](int x) {
    while (parent[x] != x) x = parent[x] = parent[parent[x]];
    return x;
  };
  for (const PoseGraphEdge& e : g.edges)
    if (parent.count(e.from) && parent.count(e.to)) parent[root(e.from)] = root(e.to);
  std::set<int> anchored;
  for (int id : fixed)
    if (parent.count(id)) anchored.insert(root(id));
  std::vector<int> floating;
  for (const auto& [id, T] : g.nodes)
    if (!anchored.count(root(id))) floating.push_back(id);
  if (!floating.empty())
    throw NumericalError("no fixed node reaches nodes " + joinKeyframes(floating) +
                             " (a disconnected part of the pose graph)",
                         floating);

  const PoseGraphSystem sys = assemble(g, fixed);
  std::unique_ptr<MarginalSolver> solver =
      solver_kind == SolverKind::Sparse ? makeCholmodMarginalSolver() : makeDenseMarginalSolver();
  try {
    solver->factorize(sys.H.toSparseUpper());
  } catch (const FactorizationError& e) {
    std::vector<int> bad;
    if (e.column() >= 0) bad.push_back(sys.ids[e.column() / 6]);
    throw NumericalError(
        "the pose-graph information matrix is not positive definite" +
            (bad.empty() ? std::string() : " (at node " + joinKeyframes(bad) + ")"),
        bad);
  }
  std::map<int, Matrix6d> out;
  for (int id : fixed)
    if (g.nodes.count(id)) out[id] = Matrix6d::Zero();
  for (std::size_t a = 0; a < sys.ids.size(); ++a) {
    std::vector<int> idx(6);
    std::iota(idx.begin(), idx.end(), static_cast<int>(6 * a));
    const Matrix6d C = solver->covariance(idx, idx);
    out[sys.ids[a]] = 0.5 * (C + C.transpose());
  }
  return out;
}

}  // namespace dbacov
