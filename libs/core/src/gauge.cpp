#include "dbacov/core/gauge.h"

#include <algorithm>
#include <numeric>
#include <set>

#include "dbacov/core/errors.h"

namespace dbacov {
namespace {

/// The two lowest-indexed keyframes that appear in `ii` (conventions §4), as slots.
std::vector<int> gaugeSlots(const GaugeGraph& s, const std::vector<int>& keyframes) {
  const std::set<std::int64_t> sources(s.sources.begin(), s.sources.end());
  std::vector<int> slots;
  for (auto it = sources.begin(); it != sources.end() && slots.size() < 2; ++it)
    slots.push_back(static_cast<int>(
        std::lower_bound(keyframes.begin(), keyframes.end(), static_cast<int>(*it)) -
        keyframes.begin()));
  if (slots.size() < 2)
    throw NumericalError("the gauge needs two keyframes in 'ii', found only keyframe " +
                             joinKeyframes({keyframes[slots[0]]}),
                         {keyframes[slots[0]]});
  return slots;
}

}  // namespace

GaugeGraph gaugeGraph(const Snapshot& s) {
  return {s.source, s.t0, s.ii, [&s](int k) { return s.T_wc(k); }};
}

GaugeGraph gaugeGraph(const PatchGraph& g) {
  GaugeGraph gg{g.source, g.t0, {}, [&g](int k) { return g.T_wc(k); }};
  for (int e = 0; e < g.numEdges(); ++e)
    if (g.ii[e] != g.jj[e]) gg.sources.push_back(g.ii[e]);  // self-edges carry nothing
  return gg;
}

GaugeParameterization makeGauge(const GaugeOptions& options, const Snapshot& s,
                                const std::vector<int>& keyframes) {
  return makeGauge(options, gaugeGraph(s), keyframes);
}

GaugeParameterization makeGauge(const GaugeOptions& options, const GaugeGraph& s,
                                const std::vector<int>& keyframes) {
  const int n = static_cast<int>(keyframes.size());
  GaugeParameterization g;
  g.basis.assign(n, Eigen::MatrixXd::Identity(6, 6));
  g.prior.assign(n, Eigen::MatrixXd());
  if (options.type == GaugeOptions::Type::Droid) {
    // DROID's BA holds every pose below t0 (docs/conventions.md §4): those slots are removed.
    if (!s.t0)
      throw InputError(s.source +
                       ": gauge droid needs DROID's t0 (key 't0', written by dbacov_dump.py)");
    for (int k = 0; k < n; ++k)
      if (keyframes[k] < *s.t0) {
        g.basis[k] = Eigen::MatrixXd(6, 0);
        g.gauge_slots.push_back(k);
      }
    g.any_slot_reaches = true;
    if (g.gauge_slots.empty())
      throw NumericalError("gauge droid: no graph keyframe lies below t0 = " +
                               std::to_string(*s.t0) + ", so DROID held no pose of this graph",
                           {keyframes.front()});
    // t0 past every graph keyframe: DROID optimized none of them, so every covariance would be
    // exactly 0 (a dump from another place than the BA call, or a wrong t0): refused, as t0 = 0.
    if (static_cast<int>(g.gauge_slots.size()) == n)
      throw NumericalError("gauge droid: t0 = " + std::to_string(*s.t0) +
                               " is past every graph keyframe (the last is " +
                               std::to_string(keyframes.back()) +
                               "), so DROID optimized no pose of this graph",
                           {keyframes.back()});
    g.offset.assign(n + 1, 0);
    for (int k = 0; k < n; ++k) g.offset[k + 1] = g.offset[k] + static_cast<int>(g.basis[k].cols());
    return g;
  }
  g.gauge_slots = gaugeSlots(s, keyframes);
  const int a = g.gauge_slots[0], b = g.gauge_slots[1];

  if (options.type == GaugeOptions::Type::TwoPose) {
    for (int slot : g.gauge_slots) {
      std::vector<int> keep;
      std::vector<double> info;
      for (int c = 0; c < 6; ++c) {
        const double sigma = c < 3 ? options.sigma_trans : options.sigma_rot;
        if (sigma > 0) {
          keep.push_back(c);
          info.push_back(1.0 / (sigma * sigma));
        }
      }
      Eigen::MatrixXd basis = Eigen::MatrixXd::Zero(6, keep.size());
      for (std::size_t c = 0; c < keep.size(); ++c) basis(keep[c], c) = 1.0;
      g.basis[slot] = basis;
      g.prior[slot] = Eigen::Map<Eigen::VectorXd>(info.data(), info.size()).asDiagonal();
    }
  } else {
    g.basis[a] = Eigen::MatrixXd(6, 0);
    const Eigen::Isometry3d T_a = s.T_wc(keyframes[a]), T_b = s.T_wc(keyframes[b]);
    const Eigen::Vector3d baseline = T_b.translation() - T_a.translation();
    if (!(baseline.norm() > 1e-9))
      throw NumericalError("minimal gauge: keyframes " +
                               joinKeyframes({keyframes[a], keyframes[b]}) +
                               " share one centre, so their distance cannot fix the scale",
                           {keyframes[a], keyframes[b]});
    Vector6d c = Vector6d::Zero();
    c.head<3>() = T_b.linear().transpose() * baseline.normalized();
    // Orthonormal complement of c: the last 5 columns of the full Q of c's QR decomposition.
    const Eigen::MatrixXd Q = Eigen::HouseholderQR<Eigen::MatrixXd>(c).householderQ();
    g.basis[b] = Q.rightCols(5);
  }

  g.offset.assign(n + 1, 0);
  for (int k = 0; k < n; ++k) g.offset[k + 1] = g.offset[k] + static_cast<int>(g.basis[k].cols());
  return g;
}

Eigen::SparseMatrix<double> reduceSystem(const BlockSymmetricMatrix& S,
                                         const GaugeParameterization& g) {
  std::vector<Eigen::Triplet<double>> trip;
  for (int a = 0; a < S.numSlots(); ++a) {
    if (g.dimOf(a) == 0) continue;
    for (const auto& [b, M] : S.row(a)) {
      if (g.dimOf(b) == 0) continue;
      Eigen::MatrixXd R = g.basis[a].transpose() * M * g.basis[b];
      if (a == b && g.prior[a].size()) R += g.prior[a];
      for (int c = 0; c < R.cols(); ++c)
        for (int r = 0; r < R.rows(); ++r)
          if (a != b || r <= c) trip.emplace_back(g.offset[a] + r, g.offset[b] + c, R(r, c));
    }
  }
  Eigen::SparseMatrix<double> Sr(g.dim(), g.dim());
  Sr.setFromTriplets(trip.begin(), trip.end());
  return Sr;
}

void checkGaugeReachesAll(const BlockSymmetricMatrix& S, const GaugeParameterization& g,
                          const std::vector<int>& keyframes) {
  const int n = S.numSlots();
  std::vector<int> parent(n);
  std::iota(parent.begin(), parent.end(), 0);
  auto root = [&](int x) {
    while (parent[x] != x) x = parent[x] = parent[parent[x]];
    return x;
  };
  for (int a = 0; a < n; ++a)
    for (const auto& [b, M] : S.row(a))
      if (a != b && !M.isZero(0)) parent[root(a)] = root(b);

  // two-pose / minimal: a part must hold both gauge keyframes; droid: some held keyframe.
  const bool any = g.any_slot_reaches;
  std::vector<char> held_root(n, 0);
  for (int slot : g.gauge_slots) held_root[root(slot)] = 1;
  const int ra = root(g.gauge_slots[0]), rb = root(g.gauge_slots.back());
  std::vector<int> unreached;
  for (int a = 0; a < n; ++a)
    if (any ? !held_root[root(a)] : (root(a) != ra || root(a) != rb)) unreached.push_back(a);
  if (unreached.empty()) return;
  // Name the first part that does not contain both gauge keyframes.
  const int r0 = root(unreached.front());
  std::vector<int> part;
  for (int a : unreached)
    if (root(a) == r0) part.push_back(keyframes[a]);
  std::vector<int> gauge_kf;
  for (int slot : g.gauge_slots) gauge_kf.push_back(keyframes[slot]);
  throw NumericalError("no gauge reaches keyframes " + joinKeyframes(part) +
                           ": they share no information with gauge keyframes " +
                           joinKeyframes(gauge_kf) + " (disconnected part of the graph)",
                       part);
}

}  // namespace dbacov
