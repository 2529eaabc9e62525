#include "dbacov/sim/synthetic_snapshot.h"

#include <cmath>
#include <random>

#include "dbacov/core/dba_factor.h"

namespace dbacov::sim {

SyntheticSnapshot generateSyntheticSnapshot(const SyntheticSnapshotConfig& c) {
  SyntheticSnapshot out;
  Snapshot& s = out.snapshot;
  const int N = c.num_keyframes, H = c.H, W = c.W, HW = H * W;
  s.source = "synthetic(seed=" + std::to_string(c.seed) + ")";
  s.id = c.id;
  s.H = H;
  s.W = W;
  s.intrinsics << c.fx, c.fy, c.cx, c.cy;
  s.poses_cw.resize(N, 7);
  s.tstamp.resize(N);
  s.disps.assign(static_cast<std::size_t>(N) * HW, 0.0f);
  const PinholeIntrinsics K{c.fx, c.fy, c.cx, c.cy};
  const RoomScene room;
  for (int k = 0; k < N; ++k) {
    out.T_wc_true.push_back(trajectoryPose(c.trajectory, k));
    s.setT_wc(k, out.T_wc_true.back());
    s.tstamp[k] = c.frame_interval * k;
    for (int p = 0; p < HW; ++p)
      s.disps[static_cast<std::size_t>(k) * HW + p] = static_cast<float>(
          room.inverseDepth(out.T_wc_true[k], (p % W - c.cx) / c.fx, (p / W - c.cy) / c.fy));
  }
  for (const auto& [i, j] :
       selectEdges(out.T_wc_true, c.first_keyframe, room, K, H, W, c.covisibility)) {
    s.ii.push_back(i);
    s.jj.push_back(j);
  }

  // Separate streams, so that switching the noise off leaves the weights unchanged.
  std::mt19937_64 rng(c.seed), rng_noise(c.seed ^ 0x9e3779b97f4a7c15ULL);
  std::uniform_real_distribution<double> uw(c.weight_min, c.weight_max), u01(0.0, 1.0);
  std::normal_distribution<double> n01(0.0, 1.0);
  const int E = s.numEdges();
  s.target.assign(static_cast<std::size_t>(E) * 2 * HW, 0.0f);
  s.weight.assign(static_cast<std::size_t>(E) * 2 * HW, 0.0f);
  for (int e = 0; e < E; ++e) {
    const int i = static_cast<int>(s.ii[e]), j = static_cast<int>(s.jj[e]);
    const Eigen::Isometry3d T_ji = out.T_wc_true[j].inverse() * out.T_wc_true[i];
    float* tx = &s.target[(static_cast<std::size_t>(e) * 2) * HW];
    float* ty = tx + HW;
    float* wx = &s.weight[(static_cast<std::size_t>(e) * 2) * HW];
    float* wy = wx + HW;
    for (int p = 0; p < HW; ++p) {
      const double d = s.disps[static_cast<std::size_t>(i) * HW + p];
      const Eigen::Vector3d Y =
          transferPoint(T_ji.linear(), T_ji.translation(), K, p % W, p / W, d);
      const bool zero = u01(rng) < c.zero_weight_fraction || !(Y.z() > 0);
      const double w[2] = {zero ? 0.0 : uw(rng), zero ? 0.0 : uw(rng)};
      const double proj[2] = {Y.z() > 0 ? K.fx * Y.x() / Y.z() + K.cx : 0.0,
                              Y.z() > 0 ? K.fy * Y.y() / Y.z() + K.cy : 0.0};
      for (int a = 0; a < 2; ++a) {
        const double sigma = w[a] > 0 ? 1.0 / std::sqrt(c.weight_scale * w[a]) : 0.0;
        const double noise = c.noise ? sigma * n01(rng_noise) : 0.0;
        (a == 0 ? tx : ty)[p] = static_cast<float>(proj[a] + noise);
        (a == 0 ? wx : wy)[p] = static_cast<float>(w[a]);
      }
    }
  }
  s.validate();
  return out;
}

}  // namespace dbacov::sim
