#include "dbacov/sim/image_flow.h"

#include <algorithm>
#include <cmath>
#include <map>
#include <mutex>
#include <random>
#include <stdexcept>

namespace dbacov::sim {
namespace {

struct Registry {
  std::mutex mutex;
  std::map<std::string, FlowEstimatorFactory> factories;
};

Registry& registry() {
  static Registry r;
  return r;
}

}  // namespace

Eigen::Vector2d sampleFlow(const FlowField& f, double x, double y) {
  x = std::clamp(x, 0.0, f.W - 1.0);
  y = std::clamp(y, 0.0, f.H - 1.0);
  const int x0 = std::min(static_cast<int>(x), std::max(f.W - 2, 0));
  const int y0 = std::min(static_cast<int>(y), std::max(f.H - 2, 0));
  const int x1 = std::min(x0 + 1, f.W - 1), y1 = std::min(y0 + 1, f.H - 1);
  const double ax = x - x0, ay = y - y0;
  auto at = [&](int xx, int yy) {
    const std::size_t p = static_cast<std::size_t>(yy) * f.W + xx;
    return Eigen::Vector2d(f.u[p], f.v[p]);
  };
  return (1 - ay) * ((1 - ax) * at(x0, y0) + ax * at(x1, y0)) +
         ay * ((1 - ax) * at(x0, y1) + ax * at(x1, y1));
}

void registerFlowEstimator(const std::string& name, FlowEstimatorFactory factory) {
  Registry& r = registry();
  const std::lock_guard<std::mutex> lock(r.mutex);
  r.factories[name] = std::move(factory);
}

std::vector<std::string> registeredFlowEstimators() {
  Registry& r = registry();
  const std::lock_guard<std::mutex> lock(r.mutex);
  std::vector<std::string> names;
  for (const auto& [name, f] : r.factories) names.push_back(name);
  return names;
}

std::unique_ptr<FlowEstimator> makeFlowEstimator(const std::string& name) {
  Registry& r = registry();
  FlowEstimatorFactory factory;
  {
    const std::lock_guard<std::mutex> lock(r.mutex);
    const auto it = r.factories.find(name);
    if (it != r.factories.end()) factory = it->second;
  }
  if (!factory) {
    std::string known;
    for (const std::string& n : registeredFlowEstimators())
      known += (known.empty() ? "" : ", ") + n;
    throw std::invalid_argument(
        "flow source '" + name + "' (--flow, flow.source) is not available here: " +
        (known.empty() ? std::string("this program has no optical flow estimator (simul-dba and "
                                     "dba-evaluate have OpenCV's dis and farneback)")
                       : "expected model or one of " + known));
  }
  return factory();
}

void ImageFlowConfig::validate() const {
  if (render_scale < 1 || render_scale > 16)
    throw std::invalid_argument("flow.render_scale must be 1..16 rendered pixels per grid pixel");
  if (!(std::isfinite(image_noise) && image_noise >= 0 && image_noise <= 255))
    throw std::invalid_argument("flow.image_noise must be in [0, 255] grey levels");
  if (!(std::isfinite(fb_scale_px) && fb_scale_px > 0))
    throw std::invalid_argument("flow.fb_scale_px must be > 0");
  if (!(std::isfinite(texture_scale) && texture_scale > 0 && texture_scale <= 100))
    throw std::invalid_argument("flow.texture_scale must be in (0, 100]");
}

ProceduralTexture::ProceduralTexture(std::uint64_t seed, double frequency_scale) {
  std::mt19937_64 rng(seed);
  std::normal_distribution<double> n01(0.0, 1.0);
  std::uniform_real_distribution<double> u01(0.0, 1.0);
  constexpr int kWaves = 32;
  const double two_pi = 2.0 * M_PI;
  for (int i = 0; i < kWaves; ++i) {
    Eigen::Vector3d dir(n01(rng), n01(rng), n01(rng));
    dir.normalize();
    // Log-uniform frequencies in [0.5, 8] cycles per metre: blobs of 6 cm to 1 m, 7–110 rendered
    // pixels at 2 m with DROID's 8× grid (aliasing-free for the 2×2 supersampled renderer).
    const double cycles = 0.5 * std::pow(16.0, u01(rng)) * frequency_scale;
    k_.push_back(two_pi * cycles * dir);
    phase_.push_back(two_pi * u01(rng));
  }
}

double ProceduralTexture::operator()(const Eigen::Vector3d& p) const {
  double s = 0;
  for (std::size_t i = 0; i < k_.size(); ++i) s += std::sin(k_[i].dot(p) + phase_[i]);
  s /= std::sqrt(0.5 * static_cast<double>(k_.size()));  // unit variance
  return 127.5 + 110.0 * std::tanh(0.8 * s);
}

FlowField inducedFlow(const RoomScene& scene, const Eigen::Isometry3d& T_a,
                      const Eigen::Isometry3d& T_b, const PinholeIntrinsics& K, int H, int W) {
  FlowField f;
  f.H = H;
  f.W = W;
  f.u.assign(static_cast<std::size_t>(H) * W, 0.0f);
  f.v.assign(f.u.size(), 0.0f);
  const Eigen::Isometry3d T_ba = T_b.inverse() * T_a;
  for (int y = 0; y < H; ++y)
    for (int x = 0; x < W; ++x) {
      const double xn = (x - K.cx) / K.fx, yn = (y - K.cy) / K.fy;
      const double d = scene.inverseDepth(T_a, xn, yn);
      if (!(d > 0)) continue;
      const Eigen::Vector3d Y = T_ba * Eigen::Vector3d(xn / d, yn / d, 1.0 / d);
      if (!(Y.z() > 1e-6)) continue;
      const std::size_t p = static_cast<std::size_t>(y) * W + x;
      f.u[p] = static_cast<float>(K.fx * Y.x() / Y.z() + K.cx - x);
      f.v[p] = static_cast<float>(K.fy * Y.y() / Y.z() + K.cy - y);
    }
  return f;
}

PinholeIntrinsics renderIntrinsics(const PinholeIntrinsics& g, int s) {
  const double half = 0.5 * (s - 1);
  return {s * g.fx, s * g.fy, s * g.cx + half, s * g.cy + half};
}

GrayImage renderImage(const RoomScene& scene, const ProceduralTexture& texture,
                      const Eigen::Isometry3d& T_wc, const PinholeIntrinsics& K, int H, int W,
                      double noise, std::uint64_t noise_seed) {
  GrayImage img;
  img.H = H;
  img.W = W;
  img.data.assign(static_cast<std::size_t>(H) * W, 0.0f);
  std::mt19937_64 rng(noise_seed);
  std::normal_distribution<double> n01(0.0, 1.0);
  constexpr double kOffsets[2] = {-0.25, 0.25};
  for (int y = 0; y < H; ++y)
    for (int x = 0; x < W; ++x) {
      double sum = 0;
      for (double oy : kOffsets)
        for (double ox : kOffsets) {
          const double xn = (x + ox - K.cx) / K.fx, yn = (y + oy - K.cy) / K.fy;
          const double d = scene.inverseDepth(T_wc, xn, yn);
          if (d > 0) sum += texture(T_wc * Eigen::Vector3d(xn / d, yn / d, 1.0 / d));
        }
      double v = 0.25 * sum;
      if (noise > 0) v += noise * n01(rng);
      img.data[static_cast<std::size_t>(y) * W + x] = static_cast<float>(std::clamp(v, 0.0, 255.0));
    }
  return img;
}

void flowTargets(const FlowField& fw, const FlowField& bw, int H, int W, const ImageFlowConfig& c,
                 float* target, float* weight) {
  const int s = c.render_scale;
  const double half = 0.5 * (s - 1), tau = c.fb_scale_px;
  const std::size_t HW = static_cast<std::size_t>(H) * W;
  for (int v = 0; v < H; ++v)
    for (int u = 0; u < W; ++u) {
      const std::size_t p = static_cast<std::size_t>(v) * W + u;
      const double x = s * u + half, y = s * v + half;
      const Eigen::Vector2d f = sampleFlow(fw, x, y);
      const double fu = f.x(), fv = f.y(), x2 = x + fu, y2 = y + fv;
      float w = 0.0f;
      if (std::isfinite(fu) && std::isfinite(fv) && x2 >= 0 && x2 <= bw.W - 1.0 && y2 >= 0 &&
          y2 <= bw.H - 1.0) {
        const double e = (f + sampleFlow(bw, x2, y2)).norm();  // forward–backward error
        if (e <= 4 * tau) w = static_cast<float>(1.0 / (1.0 + (e / tau) * (e / tau)));
      }
      weight[p] = weight[HW + p] = w;
      target[p] = static_cast<float>(w > 0 ? (x2 - half) / s : 0.0);
      target[HW + p] = static_cast<float>(w > 0 ? (y2 - half) / s : 0.0);
    }
}

}  // namespace dbacov::sim
