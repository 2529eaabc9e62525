#include "dbacov/core/patch_graph.h"

#include <algorithm>
#include <cmath>
#include <map>
#include <sstream>

#include "dbacov/core/se3.h"

namespace dbacov {
namespace {

[[noreturn]] void fail(const PatchGraph& g, const std::string& what) {
  throw InputError(g.source + ": " + what);
}

std::string num(double v) {
  std::ostringstream os;
  os << v;
  return os.str();
}

/// InputError at the first non-finite value of `v` (E×2 or per patch), naming the item.
void requireFinite(const PatchGraph& g, const std::string& what, const std::vector<double>& v,
                   const char* item, int per_item) {
  for (std::size_t i = 0; i < v.size(); ++i)
    if (!std::isfinite(v[i]))
      fail(g, what + " is non-finite (" + num(v[i]) + ") at " + item + ' ' +
                  std::to_string(i / per_item) +
                  (per_item == 2 ? std::string(" channel ") + std::to_string(i % 2) : ""));
}

void checkSizes(const PatchGraph& g) {
  const std::size_t N = g.poses_cw.rows(), E = g.ii.size();
  if (N == 0) fail(g, "key 'poses' is empty: expected at least 2 frames");
  if (g.M <= 0) fail(g, "key 'patches' has no patches per frame (M = 0)");
  const std::size_t P = N * static_cast<std::size_t>(g.M);
  for (const auto& [key, v] : {std::pair<const char*, const std::vector<double>*>{"x", &g.patch_x},
                               {"y", &g.patch_y},
                               {"inverse depth", &g.patch_d}})
    if (v->size() != P)
      fail(g, std::string("key 'patches' has ") + std::to_string(v->size()) + " patch " + key +
                  " values, expected N·M = " + std::to_string(P));
  for (const auto& [key, v] :
       {std::pair<const char*, std::size_t>{"jj", g.jj.size()}, {"kk", g.kk.size()}})
    if (v != E)
      fail(g, std::string("key '") + key + "' has " + std::to_string(v) + " values, expected " +
                  std::to_string(E) + " (E from 'ii')");
  if (E == 0) fail(g, "keys 'ii'/'jj'/'kk' are empty: the snapshot has no edges");
  for (const auto& [key, v] : {std::pair<const char*, std::size_t>{"target", g.target.size()},
                               {"weight", g.weight.size()}})
    if (v != 2 * E)
      fail(g, std::string("key '") + key + "' has " + std::to_string(v) + " values, expected (" +
                  std::to_string(E) + ",2) (E from 'ii')");
  if (g.tstamp.size() != N)
    fail(g, "key 'tstamp' has " + std::to_string(g.tstamp.size()) + " values, expected " +
                std::to_string(N) + " (N from 'poses')");
  if (g.timestamps_s && g.timestamps_s->size() != N)
    fail(g, "key 'timestamps_s' has " + std::to_string(g.timestamps_s->size()) +
                " values, expected " + std::to_string(N) + " (N from 'poses')");
}

void checkEdges(const PatchGraph& g) {
  const std::int64_t N = g.numFrames(), P = g.numPatches();
  bool any_pair = false, any_weight = false;
  for (std::size_t e = 0; e < g.ii.size(); ++e) {
    const std::string edge = "edge " + std::to_string(e);
    for (const auto& [key, v, hi] :
         {std::tuple<const char*, std::int64_t, std::int64_t>{"ii", g.ii[e], N},
          {"jj", g.jj[e], N},
          {"kk", g.kk[e], P}})
      if (v < 0 || v >= hi)
        fail(g, std::string("key '") + key + "' " + edge + " names " + std::to_string(v) +
                    ", expected 0.." + std::to_string(hi - 1));
    if (g.ii[e] != g.kk[e] / g.M)
      fail(g, "key 'ii' " + edge + " names frame " + std::to_string(g.ii[e]) +
                  " but its patch kk = " + std::to_string(g.kk[e]) + " belongs to frame kk / M = " +
                  std::to_string(g.kk[e] / g.M) + " (M = " + std::to_string(g.M) + ")");
    for (int c = 0; c < 2; ++c)
      if (g.weight[2 * e + c] < 0)
        fail(g, "key 'weight' is negative (" + num(g.weight[2 * e + c]) + ") at " + edge +
                    " channel " + std::to_string(c) + ", expected confidences >= 0");
    if (g.ii[e] == g.jj[e]) continue;
    any_pair = true;
    any_weight |= g.weight[2 * e] > 0 || g.weight[2 * e + 1] > 0;
    const double d = g.patch_d[g.kk[e]];
    if (!(d > 0))
      fail(g, "key 'patches': patch " + std::to_string(g.kk[e]) + " (frame " +
                  std::to_string(g.ii[e]) + ", patch " + std::to_string(g.kk[e] % g.M) +
                  ") named by " + edge + " has the inverse depth " + num(d) + ", expected > 0");
  }
  if (!any_pair)
    fail(g, "every edge links a frame to itself (ii == jj): such edges carry no information");
  if (!any_weight)
    fail(g,
         "key 'weight' is zero on every edge between two frames: the snapshot carries no "
         "information, expected some confidences > 0");
}

}  // namespace

Eigen::Isometry3d PatchGraph::T_cw(int k) const {
  return poseFromTQ(poses_cw.row(k).data());
}

Eigen::Isometry3d PatchGraph::T_wc(int k) const {
  return T_cw(k).inverse();
}

std::vector<int> PatchGraph::graphFrames() const {
  std::vector<char> used(numFrames(), 0);
  for (std::size_t e = 0; e < ii.size(); ++e)
    if (ii[e] != jj[e]) used[ii[e]] = used[jj[e]] = 1;
  std::vector<int> frames;
  for (int k = 0; k < numFrames(); ++k)
    if (used[k]) frames.push_back(k);
  return frames;
}

std::vector<std::pair<int, int>> PatchGraph::relativePairs() const {
  std::vector<std::pair<int, int>> pairs;
  for (std::size_t e = 0; e < ii.size(); ++e)
    if (ii[e] != jj[e])
      pairs.emplace_back(static_cast<int>(std::min(ii[e], jj[e])),
                         static_cast<int>(std::max(ii[e], jj[e])));
  const std::vector<int> f = graphFrames();
  for (std::size_t a = 0; a + 1 < f.size(); ++a) pairs.emplace_back(f[a], f[a + 1]);
  std::sort(pairs.begin(), pairs.end());
  pairs.erase(std::unique(pairs.begin(), pairs.end()), pairs.end());
  return pairs;
}

void PatchGraph::validate() const {
  checkSizes(*this);
  static const char* const kPoseColumns[7] = {"tx", "ty", "tz", "qx", "qy", "qz", "qw"};
  for (int k = 0; k < numFrames(); ++k) {
    for (int c = 0; c < 7; ++c)
      if (!std::isfinite(poses_cw(k, c)))
        fail(*this, "key 'poses' frame " + std::to_string(k) + " has the non-finite value " +
                        num(poses_cw(k, c)) + " in column " + std::to_string(c) + " (" +
                        kPoseColumns[c] + "), expected a finite pose [tx ty tz qx qy qz qw]");
    if (poses_cw.row(k).tail<4>().norm() < 1e-6)
      fail(*this, "key 'poses' frame " + std::to_string(k) +
                      " has a zero quaternion, expected a unit quaternion [qx qy qz qw]");
  }
  if (!intrinsics.allFinite() || !(intrinsics[0] > 0) || !(intrinsics[1] > 0)) {
    std::ostringstream os;
    os << "key 'intrinsics' is [fx fy cx cy] = [" << intrinsics.transpose()
       << "], expected finite values with fx, fy > 0";
    fail(*this, os.str());
  }
  requireFinite(*this, "key 'patches' channel 0 (x)", patch_x, "patch", 1);
  requireFinite(*this, "key 'patches' channel 1 (y)", patch_y, "patch", 1);
  requireFinite(*this, "key 'patches' channel 2 (inverse depth)", patch_d, "patch", 1);
  requireFinite(*this, "key 'target'", target, "edge", 2);
  requireFinite(*this, "key 'weight'", weight, "edge", 2);
  if (t0 < 0 || t0 > numFrames())
    fail(*this, "key 't0' is " + std::to_string(t0) +
                    ", expected 0 <= t0 <= N = " + std::to_string(numFrames()));
  std::map<double, int> first;
  for (int k = 0; k < numFrames(); ++k) {
    if (!std::isfinite(tstamp[k]))
      fail(*this, "key 'tstamp' frame " + std::to_string(k) + " has the non-finite value " +
                      num(tstamp[k]) + ", expected a finite stamp");
    if (timestamps_s && !std::isfinite((*timestamps_s)[k]))
      fail(*this, "key 'timestamps_s' frame " + std::to_string(k) + " has the non-finite value " +
                      num((*timestamps_s)[k]) + ", expected a finite time");
    const auto [it, inserted] = first.emplace(tstamp[k], k);
    if (!inserted)
      fail(*this, "key 'tstamp' gives frames " + std::to_string(it->second) + " and " +
                      std::to_string(k) + " the same value " + num(tstamp[k]) +
                      ": a frame is identified by its tstamp, expected distinct values");
  }
  checkEdges(*this);
}

}  // namespace dbacov
