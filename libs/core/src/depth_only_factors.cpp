#include "depth_only_factors.h"

#include <algorithm>
#include <numeric>

#include "dbacov/core/dba_factor.h"
#include "dbacov/core/linearization.h"

namespace dbacov::detail {

DepthOnlyTerms depthOnlyTerms(const Snapshot& s, const DbaOptions& o, int src,
                              const std::vector<int>& stereo_edges) {
  DepthOnlyTerms t;
  const int HW = static_cast<int>(s.pixelsPerFrame());
  const bool sensor = s.disps_sens && o.sensor_depth_weight > 0;
  if (!sensor && stereo_edges.empty()) return t;
  t.h.assign(HW, 0.0);
  t.g.assign(HW, 0.0);
  const float* disps = &s.disps[static_cast<std::size_t>(src) * HW];
  if (sensor) {  // docs/conventions.md §2, RGB-D: r = d_sens − d, ∂r/∂d = −1, information α
    const float* ds = &(*s.disps_sens)[static_cast<std::size_t>(src) * HW];
    for (int p = 0; p < HW; ++p) {
      if (!(ds[p] > 0) || !(disps[p] > 0)) continue;
      const double r = static_cast<double>(ds[p]) - disps[p];
      t.h[p] += o.sensor_depth_weight;
      t.g[p] += -o.sensor_depth_weight * r;
      t.chi2 += o.sensor_depth_weight * r * r;
      t.sum_r2 += r * r;
      ++t.rows;
      ++t.factors_used;
    }
  }
  if (!stereo_edges.empty()) {  // docs/conventions.md §2 with T_ji = T_rig (fixed)
    const Eigen::Isometry3d rig = s.stereoRig();
    const PinholeIntrinsics K = PinholeIntrinsics::fromVector(s.intrinsics);
    for (int e : stereo_edges) {
      const float *wx = s.weightPlane(e, 0), *wy = s.weightPlane(e, 1);
      const float *tx = s.targetPlane(e, 0), *ty = s.targetPlane(e, 1);
      for (int p = 0; p < HW; ++p) {
        const double d = disps[p];
        if (!(d > 0) || (wx[p] == 0 && wy[p] == 0)) continue;
        const Eigen::Vector3d Y =
            transferPoint(rig.linear(), rig.translation(), K, p % s.W, p / s.W, d);
        if (!keepPixelFactor(o, d, Y.z())) {
          ++t.factors_filtered;
          continue;
        }
        PixelFactorLinearization f;
        linearizePixelFactor(rig.linear(), rig.translation(), K, p % s.W, p / s.W, d, tx[p], ty[p],
                             &f);
        const double w0 = o.weight_scale * wx[p], w1 = o.weight_scale * wy[p];
        t.h[p] += w0 * f.J_d[0] * f.J_d[0] + w1 * f.J_d[1] * f.J_d[1];
        t.g[p] += w0 * f.J_d[0] * f.r[0] + w1 * f.J_d[1] * f.r[1];
        t.chi2 += w0 * f.r[0] * f.r[0] + w1 * f.r[1] * f.r[1];
        for (int c = 0; c < 2; ++c)
          if ((c == 0 ? wx[p] : wy[p]) > 0) {
            t.sum_r2 += f.r[c] * f.r[c];
            ++t.rows;
          }
        ++t.factors_used;
      }
    }
  }
  t.any = std::any_of(t.h.begin(), t.h.end(), [](double v) { return v > 0; });
  return t;
}

std::size_t applyDepthOnlyTerms(const DepthOnlyTerms& t, double eps, int T6,
                                std::vector<int>& pixel, std::vector<double>& h,
                                std::vector<double>& g, std::vector<double>& B,
                                Eigen::MatrixXd& Sloc, Eigen::VectorXd& gS_loc) {
  const std::size_t kept = pixel.size();
  std::vector<char> is_kept(t.h.size(), 0);
  for (std::size_t k = 0; k < kept; ++k) {
    const int p = pixel[k];
    is_kept[p] = 1;
    if (!(t.h[p] > 0)) continue;
    const Eigen::Map<const Eigen::VectorXd> b(&B[k * T6], T6);
    const double h1 = h[k] + t.h[p], g1 = g[k] + t.g[p];
    Sloc.noalias() += (1.0 / h[k] - 1.0 / h1) * (b * b.transpose());
    gS_loc += (g[k] / h[k] - g1 / h1) * b;
    h[k] = h1;
    g[k] = g1;
  }
  // Depths that only the depth-only factors make observable: no pose coupling (b = 0).
  std::vector<int> added;
  for (std::size_t p = 0; p < t.h.size(); ++p)
    if (!is_kept[p] && t.h[p] > eps) added.push_back(static_cast<int>(p));
  if (added.empty()) return 0;
  std::vector<int> pix(pixel);
  std::vector<double> hh(h), gg(g), BB(B);
  for (int p : added) {
    pix.push_back(p);
    hh.push_back(t.h[p]);
    gg.push_back(t.g[p]);
    BB.insert(BB.end(), T6, 0.0);
  }
  // Back into ascending pixel order, as the kernel keeps them.
  std::vector<std::size_t> order(pix.size());
  std::iota(order.begin(), order.end(), 0);
  std::sort(order.begin(), order.end(),
            [&](std::size_t a, std::size_t b) { return pix[a] < pix[b]; });
  pixel.clear();
  h.clear();
  g.clear();
  B.clear();
  for (std::size_t k : order) {
    pixel.push_back(pix[k]);
    h.push_back(hh[k]);
    g.push_back(gg[k]);
    B.insert(B.end(), BB.begin() + k * T6, BB.begin() + (k + 1) * T6);
  }
  return added.size();
}

}  // namespace dbacov::detail
