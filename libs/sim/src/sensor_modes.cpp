#include "dbacov/sim/sensor_modes.h"

#include <cmath>
#include <random>
#include <set>

#include "dbacov/core/dba_factor.h"

namespace dbacov::sim {

void addStereoEdges(Snapshot& s, const StereoConfig& c) {
  const PinholeIntrinsics K = PinholeIntrinsics::fromVector(s.intrinsics);
  const int HW = static_cast<int>(s.pixelsPerFrame());
  const std::set<std::int64_t> sources(s.ii.begin(), s.ii.end());
  std::mt19937_64 rng(c.seed), rng_noise(c.seed ^ 0x5851f42d4c957f2dULL);
  std::uniform_real_distribution<double> uw(c.weight_min, c.weight_max);
  std::normal_distribution<double> n01(0.0, 1.0);
  const Eigen::Quaterniond q(c.T_rig.linear());
  Eigen::Matrix<double, 7, 1> rig;
  rig << c.T_rig.translation(), q.x(), q.y(), q.z(), q.w();
  s.stereo_rig = rig;
  for (std::int64_t k : sources) {
    s.ii.push_back(k);
    s.jj.push_back(k);
    std::vector<float> tx(HW), ty(HW), wx(HW), wy(HW);
    for (int p = 0; p < HW; ++p) {
      const double d = s.disps[static_cast<std::size_t>(k) * HW + p];
      const Eigen::Vector3d Y =
          transferPoint(c.T_rig.linear(), c.T_rig.translation(), K, p % s.W, p / s.W, d);
      const bool ok = Y.z() > 0 && d > 0;
      const double w[2] = {ok ? uw(rng) : 0.0, ok ? uw(rng) : 0.0};
      const double proj[2] = {ok ? K.fx * Y.x() / Y.z() + K.cx : 0.0,
                              ok ? K.fy * Y.y() / Y.z() + K.cy : 0.0};
      for (int a = 0; a < 2; ++a) {
        const double sigma = w[a] > 0 ? 1.0 / std::sqrt(c.weight_scale * w[a]) : 0.0;
        (a == 0 ? tx : ty)[p] =
            static_cast<float>(proj[a] + (c.noise ? sigma * n01(rng_noise) : 0));
        (a == 0 ? wx : wy)[p] = static_cast<float>(w[a]);
      }
    }
    s.target.insert(s.target.end(), tx.begin(), tx.end());
    s.target.insert(s.target.end(), ty.begin(), ty.end());
    s.weight.insert(s.weight.end(), wx.begin(), wx.end());
    s.weight.insert(s.weight.end(), wy.begin(), wy.end());
  }
}

void addSensorDepth(Snapshot& s, const RgbdConfig& c) {
  const std::size_t HW = s.pixelsPerFrame();
  const std::set<std::int64_t> sources(s.ii.begin(), s.ii.end());
  std::mt19937_64 rng(c.seed), rng_noise(c.seed ^ 0x2545f4914f6cdd1dULL);
  std::uniform_real_distribution<double> u01(0.0, 1.0);
  std::normal_distribution<double> n01(0.0, 1.0);
  s.disps_sens = std::vector<float>(s.disps.size(), 0.0f);
  const double sigma = 1.0 / std::sqrt(c.alpha);
  for (std::int64_t k : sources)
    for (std::size_t p = 0; p < HW; ++p) {
      const std::size_t at = static_cast<std::size_t>(k) * HW + p;
      const bool valid = u01(rng) < c.valid_fraction;
      const double v = s.disps[at] + (c.noise ? sigma * n01(rng_noise) : 0.0);
      (*s.disps_sens)[at] = valid && v > 0 && s.disps[at] > 0 ? static_cast<float>(v) : 0.0f;
    }
}

}  // namespace dbacov::sim
