// The image-based flow test bed: targets that no noise formula wrote. The room is given
// a procedural texture, each keyframe is rendered at `render_scale` times the grid resolution with
// sensor noise, and a dense optical flow estimator (OpenCV's DIS or Farneback, registered by the
// programs that link libs/flow) computes the flow between the two images of every edge; the
// confidence of a pixel comes from the forward–backward consistency of the flow. Their errors are
// the estimator's own: correlated, heavy-tailed, occlusion dependent.
//
// Like DROID, whose update operator refines the flow around the reprojection of its current
// estimate, the estimator starts from the flow induced by the geometry with the other camera's
// pose perturbed by the scenario's initial perturbation (inducedFlow; a few pixels off), so that
// its errors are those of its local refinement (texture, noise, occlusion, foreshortening), not
// the gross failures of a coarse-to-fine search over tens of pixels.
//
// Geometry (conventions §1, DROID's 1/8 grid): grid pixel u covers the rendered pixels
// s·u .. s·u + s − 1, its centre at x = s·u + (s − 1)/2, so the rendered camera has fx' = s·fx,
// cx' = s·cx + (s − 1)/2. A grid pixel's target is (x + f(x) − (s − 1)/2) / s with f the forward
// flow sampled bilinearly at x; its confidence on both axes is w = 1 / (1 + (e / τ)²), with
// e = |f(x) + b(x + f(x))| the forward–backward error in rendered pixels and τ = fb_scale_px, and
// 0 where x + f(x) leaves the image or e > 4τ (the estimator's own occlusion test).
//
// This library stays free of OpenCV: the estimator is reached through FlowEstimator and a registry
// (registerFlowEstimator), so that dba-covariance never loads OpenCV.
#pragma once

#include <cstdint>
#include <functional>
#include <memory>
#include <string>
#include <vector>

#include <Eigen/Geometry>

#include "dbacov/core/dba_factor.h"
#include "dbacov/sim/scene.h"

namespace dbacov::sim {

/// A grey image, row-major, values in [0, 255].
struct GrayImage {
  int H = 0, W = 0;
  std::vector<float> data;
  float at(int x, int y) const { return data[static_cast<std::size_t>(y) * W + x]; }
};

/// A dense flow field: the displacement (u, v) of every pixel of the first image, in pixels.
struct FlowField {
  int H = 0, W = 0;
  std::vector<float> u, v;
};

/// The flow at (x, y), bilinear between pixels, clamped to the field's border.
Eigen::Vector2d sampleFlow(const FlowField& f, double x, double y);

/// A dense optical flow estimator between two grey images of equal size.
class FlowEstimator {
 public:
  virtual ~FlowEstimator() = default;
  /// The flow from `from` to `to`, refined from `initial` (same size as the images).
  virtual FlowField compute(const GrayImage& from, const GrayImage& to,
                            const FlowField& initial) const = 0;
};

/// Makes an estimator; registered under a name (e.g. "dis") by a program that links one.
using FlowEstimatorFactory = std::function<std::unique_ptr<FlowEstimator>()>;
void registerFlowEstimator(const std::string& name, FlowEstimatorFactory factory);
/// The registered names, sorted.
std::vector<std::string> registeredFlowEstimators();
/// Throws std::invalid_argument naming the registered estimators (or saying that this program has
/// none: simul-dba and dba-evaluate have OpenCV's) when `name` is not registered.
std::unique_ptr<FlowEstimator> makeFlowEstimator(const std::string& name);

struct ImageFlowConfig {
  /// "model": targets = true projection + the noise model (pixel_models.h); any other name is a
  /// registered FlowEstimator ("dis", "farneback").
  std::string source = "model";
  int render_scale = 8;        ///< rendered pixels per grid pixel and axis (DROID's 8)
  double image_noise = 2.0;    ///< σ of the rendered images' sensor noise, grey levels (per run)
  double fb_scale_px = 0.5;    ///< τ of the confidence, rendered pixels
  double texture_scale = 1.0;  ///< multiplies the texture's spatial frequencies (cycles per metre)

  bool isModel() const { return source == "model"; }
  /// Throws std::invalid_argument naming the setting.
  void validate() const;
};

/// A solid procedural texture: a sum of random plane waves in world coordinates (frequencies
/// 0.5–8 cycles/m times texture_scale), through a soft threshold. Deterministic for a seed.
class ProceduralTexture {
 public:
  explicit ProceduralTexture(std::uint64_t seed, double frequency_scale = 1.0);
  /// Grey value in [0, 255] of a world point.
  double operator()(const Eigen::Vector3d& p) const;

 private:
  std::vector<Eigen::Vector3d> k_;
  std::vector<double> phase_;
};

/// Renders the textured room from T_wc through the pinhole K (H×W pixels, 2×2 supersampled), adds
/// N(0, noise²) per pixel from `noise_seed` (no noise when noise = 0), clamps to [0, 255].
GrayImage renderImage(const RoomScene& scene, const ProceduralTexture& texture,
                      const Eigen::Isometry3d& T_wc, const PinholeIntrinsics& K, int H, int W,
                      double noise, std::uint64_t noise_seed);

/// The flow that the room's geometry induces from camera T_a to camera T_b (H×W rendered pixels,
/// pinhole K): each pixel's ray hits the room at depth 1/d, projected into b; 0 where the ray or
/// its point has no valid depth.
FlowField inducedFlow(const RoomScene& scene, const Eigen::Isometry3d& T_a,
                      const Eigen::Isometry3d& T_b, const PinholeIntrinsics& K, int H, int W);

/// The rendered camera of a grid camera (header: fx' = s·fx, cx' = s·cx + (s − 1)/2).
PinholeIntrinsics renderIntrinsics(const PinholeIntrinsics& grid, int scale);

/// Targets and confidences of one edge on the grid (H×W grid pixels, 2·H·W each: x then y) from
/// the forward flow (source → target image) and the backward flow, as the header describes.
void flowTargets(const FlowField& forward, const FlowField& backward, int H, int W,
                 const ImageFlowConfig& config, float* target, float* weight);

}  // namespace dbacov::sim
