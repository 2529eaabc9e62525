#include "dbacov/sim/scenario.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <map>
#include <memory>
#include <optional>
#include <random>
#include <set>
#include <stdexcept>

namespace dbacov::sim {
namespace {

std::uint64_t splitmix(std::uint64_t z) {
  z += 0x9e3779b97f4a7c15ULL;
  z = (z ^ (z >> 30)) * 0xbf58476d1ce4e5b9ULL;
  z = (z ^ (z >> 27)) * 0x94d049bb133111ebULL;
  return z ^ (z >> 31);
}

std::string shortNumber(double v) {
  char buf[32];
  std::snprintf(buf, sizeof buf, "%g", v);
  return buf;
}

void require(bool ok, const std::string& what) {
  if (!ok) throw std::invalid_argument("scenario: " + what);
}

bool finiteNonNegative(double v) {
  return std::isfinite(v) && v >= 0;
}
bool finitePositive(double v) {
  return std::isfinite(v) && v > 0;
}

enum Purpose : std::uint64_t {
  kWeights = 1,
  kNoise = 2,
  kInitialState = 3,
  kExtraNoise = 4,
  kDepthReadings = 5,  ///< which pixels have a sensor reading (fixed by the scenario)
  kDepthNoise = 6,     ///< the readings' noise (redrawn per run)
  kTexture = 7,        ///< the room's texture (fixed by the scenario)
  kImageNoise = 8,     ///< the rendered images' sensor noise (redrawn per run)
  // Persistence::Edge: one stream per edge (keyed by its keyframes), not per snapshot.
  kEdgeWeights = 9,
  kEdgeNoise = 10,
  kEdgeExtraNoise = 11,
  kNoiseFamily = 12,  ///< the open family's error model of a run
};

/// Stereo: the rig transform Y = T·X from the left camera to the right one.
Eigen::Isometry3d rigTransform(const SensorConfig& c) {
  return Eigen::Translation3d(-c.stereo_baseline, 0.0, 0.0) * Eigen::Isometry3d::Identity();
}

}  // namespace

std::uint64_t mixSeed(std::uint64_t seed, std::uint64_t purpose, std::uint64_t a, std::uint64_t b) {
  return splitmix(splitmix(splitmix(splitmix(seed) ^ purpose) ^ a) ^ b);
}

PinholeIntrinsics CameraConfig::intrinsics() const {
  return {fx.value_or(0.87 * W), fy.value_or(fx.value_or(0.87 * W)), cx.value_or(0.5 * (W - 1)),
          cy.value_or(0.5 * (H - 1))};
}

SimulationMode parseSimulationMode(const std::string& name) {
  if (name == "sliding-window") return SimulationMode::SlidingWindow;
  if (name == "whole") return SimulationMode::WholeTrajectory;
  throw std::invalid_argument("unknown simulation mode '" + name +
                              "', expected sliding-window or whole");
}

std::string toString(SimulationMode m) {
  return m == SimulationMode::SlidingWindow ? "sliding-window" : "whole";
}

GaugeHold parseGaugeHold(const std::string& name) {
  if (name == "truth") return GaugeHold::Truth;
  if (name == "estimate") return GaugeHold::Estimate;
  throw std::invalid_argument("unknown gauge hold '" + name + "', expected truth or estimate");
}

std::string toString(GaugeHold h) {
  return h == GaugeHold::Truth ? "truth" : "estimate";
}

SensorMode parseSensorMode(const std::string& name) {
  return parseEnum<SensorMode>(name);
}

std::string toString(SensorMode m) {
  return dbacov::toString(m);
}

void ScenarioConfig::validate() const {
  require(camera.H >= 2 && camera.H <= 4096 && camera.W >= 2 && camera.W <= 4096,
          "the grid must be 2..4096 pixels high and wide");
  const PinholeIntrinsics K = camera.intrinsics();
  require(
      finitePositive(K.fx) && finitePositive(K.fy) && std::isfinite(K.cx) && std::isfinite(K.cy),
      "intrinsics must be finite with fx, fy > 0");
  scene.validate();
  require(trajectory.num_keyframes >= 2, "the trajectory needs at least 2 keyframes");
  require(finitePositive(trajectory.step), "trajectory step must be > 0");
  require(finiteNonNegative(trajectory.yaw_amplitude), "trajectory yaw amplitude must be >= 0");
  require(finitePositive(trajectory.loop_radius) && trajectory.keyframes_per_lap >= 3,
          "loop radius must be > 0 and keyframes per lap >= 3");
  require(edges.edge_radius >= 1, "edge radius must be >= 1");
  require(edges.overlap_threshold >= 0 && edges.overlap_threshold <= 1,
          "overlap threshold must be in [0, 1] (0 = no overlap edges)");
  require(edges.max_overlap_edges >= 0 && finitePositive(edges.candidate_distance),
          "max overlap edges must be >= 0 and candidate distance > 0");
  weights.validate();
  noise.validate();
  flow.validate();
  // An unknown flow estimator is a configuration error, found before anything is simulated.
  if (!flow.isModel()) makeFlowEstimator(flow.source);
  // A correlation longer than the grid makes each image's noise one offset, and its kernel (8ℓ/√2
  // wide) would need memory and time beyond the grid's: bound it by the grid.
  require(noise.type != NoiseModel::Type::Correlated ||
              noise.correlation_length_px <= std::max(camera.H, camera.W),
          "noise: correlation length " + shortNumber(noise.correlation_length_px) +
              " px (--correlation-length, noise.correlation_length_px) exceeds the grid (" +
              std::to_string(camera.W) + "x" + std::to_string(camera.H) +
              " px): expected at most " + std::to_string(std::max(camera.H, camera.W)) + " px");
  require(finitePositive(weight_scale), "weight scale must be > 0");
  if (mode == SimulationMode::SlidingWindow)
    require(window >= 2 && window <= trajectory.num_keyframes,
            "the window must hold 2..(number of keyframes) keyframes");
  require(finiteNonNegative(gauge.sigma_rot) && finiteNonNegative(gauge.sigma_trans),
          "gauge sigmas must be >= 0");
  require(finitePositive(sensor.stereo_baseline) && sensor.stereo_baseline <= 10,
          "stereo baseline (--stereo-baseline, sensor.stereo_baseline) must be in (0, 10] m");
  require(finitePositive(sensor.depth_alpha),
          "depth-sensor information (--depth-alpha, sensor.depth_alpha) must be > 0");
  require(sensor.depth_valid_fraction > 0 && sensor.depth_valid_fraction <= 1,
          "depth-sensor valid fraction (sensor.depth_valid_fraction) must be in (0, 1]");
  require(gauge.type != GaugeOptions::Type::Droid || sensor.mode != SensorMode::Mono,
          "gauge droid holds one keyframe, which leaves the scale of monocular DBA free: use "
          "--sensor stereo or rgbd, or gauge two-pose or minimal");
  require(finiteNonNegative(perturbation.translation) && finiteNonNegative(perturbation.rotation) &&
              finiteNonNegative(perturbation.inverse_depth),
          "initial perturbation sigmas must be >= 0");
  solver.validate();
  require(finitePositive(time.fps) && finitePositive(time.frame_interval) &&
              std::isfinite(time.start_time),
          "fps and frame interval must be > 0, start time finite");
}

int ScenarioConfig::numSnapshots() const {
  return mode == SimulationMode::WholeTrajectory ? 1 : trajectory.num_keyframes - window + 1;
}

DbaOptions ScenarioConfig::engineOptions() const {
  DbaOptionOverrides o;
  o.weight_scale = weight_scale;
  o.gauge = gauge.type;
  if (gauge.type == GaugeOptions::Type::TwoPose) {
    o.gauge_sigma_rot = gauge.sigma_rot;
    o.gauge_sigma_trans = gauge.sigma_trans;
  }
  if (sensor.mode == SensorMode::Rgbd) o.sensor_depth_weight = sensor.depth_alpha;
  return o.resolve();
}

Scenario::Scenario(ScenarioConfig config) : config_(std::move(config)) {
  config_.validate();
  K_ = config_.camera.intrinsics();
  const int K = config_.trajectory.num_keyframes, H = config_.camera.H, W = config_.camera.W;
  for (int k = 0; k < K; ++k) {
    const Eigen::Isometry3d T = trajectoryPose(config_.trajectory, k);
    if (!config_.scene.isFree(T.translation())) {
      std::string hint;
      if (config_.trajectory.type != TrajectoryType::Loop && k > 0)
        hint =
            "; a " + toString(config_.trajectory.type) + " trajectory leaves the room after " +
            std::to_string(k) + " keyframes (this run needs " + std::to_string(K) +
            (config_.mode == SimulationMode::WholeTrajectory ? "" : " = snapshots + window - 1") +
            "): ask for fewer, or use --trajectory loop, which stays in the room at any length";
      throw std::invalid_argument("scenario: the camera of keyframe " + std::to_string(k) +
                                  " is outside the room or inside a box" + hint);
    }
    T_wc_true_.push_back(T);
    std::vector<double> d(static_cast<std::size_t>(H) * W);
    for (int p = 0; p < H * W; ++p)
      d[p] = config_.scene.inverseDepth(T, (p % W - K_.cx) / K_.fx, (p / W - K_.cy) / K_.fy);
    disp_true_.push_back(std::move(d));
  }
  for (int s = 0; s < config_.numSnapshots(); ++s) {
    const bool whole = config_.mode == SimulationMode::WholeTrajectory;
    const int last = whole ? K : s + config_.window;
    const std::vector<Eigen::Isometry3d> poses(T_wc_true_.begin(), T_wc_true_.begin() + last);
    std::vector<std::pair<int, int>> e =
        selectEdges(poses, whole ? 0 : s, config_.scene, K_, H, W, config_.edges);
    if (config_.sensor.mode == SensorMode::Stereo) {  // the left–right pair of every source
      const std::set<int> sources = [&] {
        std::set<int> out;
        for (const auto& ij : e) out.insert(ij.first);
        return out;
      }();
      for (int k : sources) e.emplace_back(k, k);
      std::sort(e.begin(), e.end());
    }
    edges_.push_back(std::move(e));
  }
}

double Scenario::keyframeTime(int k) const {
  return config_.time.start_time + config_.time.frame_interval * k / config_.time.fps;
}

SimulatedSnapshot Scenario::simulate(int s, std::uint64_t run, const Snapshot* previous) const {
  if (s < 0 || s >= numSnapshots())
    throw std::invalid_argument("scenario: snapshot " + std::to_string(s) + " out of range");
  const ScenarioConfig& c = config_;
  const int H = c.camera.H, W = c.camera.W, HW = H * W;
  const int N = c.mode == SimulationMode::WholeTrajectory ? numKeyframes() : s + c.window;
  SimulatedSnapshot out;
  Snapshot& snap = out.snapshot;
  snap.source = "simulated(seed=" + std::to_string(c.seed) + ", run=" + std::to_string(run) +
                ", snapshot=" + std::to_string(s) + ")";
  snap.id = s;
  snap.index = s;
  snap.H = H;
  snap.W = W;
  snap.intrinsics << K_.fx, K_.fy, K_.cx, K_.cy;
  snap.poses_cw.resize(N, 7);
  snap.tstamp.resize(N);
  snap.timestamps_s = std::vector<double>(N);
  snap.disps.resize(static_cast<std::size_t>(N) * HW);
  for (int k = 0; k < N; ++k) {
    out.T_wc_true.push_back(T_wc_true_[k]);
    snap.setT_wc(k, T_wc_true_[k]);
    snap.tstamp[k] = c.time.frame_interval * k;
    (*snap.timestamps_s)[k] = keyframeTime(k);
    for (int p = 0; p < HW; ++p)
      snap.disps[static_cast<std::size_t>(k) * HW + p] = static_cast<float>(disp_true_[k][p]);
  }
  for (const auto& [i, j] : edges_[s]) {
    snap.ii.push_back(i);
    snap.jj.push_back(j);
  }
  const Eigen::Isometry3d T_rig = rigTransform(c.sensor);
  if (c.sensor.mode == SensorMode::Stereo) {
    Eigen::Matrix<double, 7, 1> rig;
    rig << T_rig.translation(), 0.0, 0.0, 0.0, 1.0;
    snap.stereo_rig = rig;
  }

  // Confidences (fixed by the scenario) and targets (redrawn per run).
  std::mt19937_64 rng_w(mixSeed(c.seed, kWeights, s)), rng_n(mixSeed(c.seed, kNoise, s, run));
  std::uniform_real_distribution<double> u01(0.0, 1.0);
  // The run's error model: the configured one, or one drawn from the open family per run (every
  // snapshot of a run shares it, as the errors of one sequence share their source).
  const NoiseModel noise = c.noise_family == NoiseFamily::Open
                               ? drawNoiseModel(c.noise, mixSeed(c.seed, kNoiseFamily, run), H, W)
                               : c.noise;
  out.noise = noise;
  const UnitNoiseField field(noise, H, W);
  // Errors beyond the claimed noise (pixel_models.h), from a stream of their own so that the
  // claimed noise of a run does not change when they are switched on.
  std::optional<UnitNoiseField> extra_field;
  std::optional<FourierNoiseField> fourier_field;
  if (noise.field_px > 0 && noise.field_fourier) {
    fourier_field.emplace(noise.field_length_px, H, W);
  } else if (noise.field_px > 0) {
    NoiseModel extra_model;
    extra_model.type = NoiseModel::Type::Correlated;
    extra_model.correlation_length_px = noise.field_length_px;
    extra_field.emplace(extra_model, H, W);
  }
  const auto sampleField = [&](std::mt19937_64& rng) {
    return fourier_field ? fourier_field->sample(rng) : extra_field->sample(rng);
  };
  const double t_dof = noise.student_t_dof;
  std::optional<std::chi_squared_distribution<double>> chi2;
  if (t_dof > 0) chi2.emplace(t_dof);
  std::mt19937_64 rng_x(mixSeed(c.seed, kExtraNoise, s, run));
  std::normal_distribution<double> nx(0.0, 1.0);
  const int E = snap.numEdges();
  snap.target.assign(static_cast<std::size_t>(E) * 2 * HW, 0.0f);
  snap.weight.assign(static_cast<std::size_t>(E) * 2 * HW, 0.0f);
  const bool per_edge = noise.persistence == NoiseModel::Persistence::Edge;
  // Image-based targets (image_flow.h): every camera rendered once per (snapshot, run), keyed by
  // keyframe (left camera) or −1 − keyframe (its right camera, stereo); with edge persistence
  // its sensor noise is the same in every snapshot (one image per keyframe and run).
  std::unique_ptr<FlowEstimator> estimator;
  std::optional<ProceduralTexture> texture;
  std::map<int, GrayImage> images;
  if (!c.flow.isModel()) {
    estimator = makeFlowEstimator(c.flow.source);
    texture.emplace(mixSeed(c.seed, kTexture, 0), c.flow.texture_scale);
  }
  const int rs = c.flow.render_scale;
  const PinholeIntrinsics K_render = renderIntrinsics(K_, rs);
  auto image = [&](int key, const Eigen::Isometry3d& T_wc) -> const GrayImage& {
    auto it = images.find(key);
    if (it == images.end())
      it = images
               .emplace(key,
                        renderImage(
                            c.scene, *texture, T_wc, K_render, rs * H, rs * W, c.flow.image_noise,
                            mixSeed(c.seed, kImageNoise, per_edge ? 0 : s, run * 1000003 + key)))
               .first;
    return it->second;
  };
  for (int e = 0; e < E; ++e) {
    const int i = static_cast<int>(snap.ii[e]), j = static_cast<int>(snap.jj[e]);
    if (per_edge) {  // the same draws for this (i, j) in every snapshot of the run
      const std::uint64_t key =
          (static_cast<std::uint64_t>(i) << 32) ^ static_cast<std::uint32_t>(j);
      rng_w.seed(mixSeed(c.seed, kEdgeWeights, key));
      rng_n.seed(mixSeed(c.seed, kEdgeNoise, key, run));
      rng_x.seed(mixSeed(c.seed, kEdgeExtraNoise, key, run));
    }
    // The camera that sees edge e's targets: keyframe j, or keyframe i's right camera (stereo).
    const Eigen::Isometry3d T_wc_j = i == j ? T_wc_true_[i] * T_rig.inverse() : T_wc_true_[j];
    const Eigen::Isometry3d T_ji = T_wc_j.inverse() * T_wc_true_[i];
    if (estimator) {
      const GrayImage& from = image(i, T_wc_true_[i]);
      const GrayImage& to = image(i == j ? -1 - i : j, T_wc_j);
      // The estimator refines the flow induced by a perturbed pose of the other camera (the
      // initial perturbation's σ), as DROID refines the flow induced by its current estimate.
      auto perturbed = [&](const Eigen::Isometry3d& T) {
        Vector6d xi;
        for (int q = 0; q < 6; ++q)
          xi[q] = nx(rng_x) * (q < 3 ? c.perturbation.translation : c.perturbation.rotation);
        return Eigen::Isometry3d(T * expSE3(xi));
      };
      const FlowField init_fw =
          inducedFlow(c.scene, T_wc_true_[i], perturbed(T_wc_j), K_render, rs * H, rs * W);
      const FlowField init_bw =
          inducedFlow(c.scene, T_wc_j, perturbed(T_wc_true_[i]), K_render, rs * H, rs * W);
      flowTargets(estimator->compute(from, to, init_fw), estimator->compute(to, from, init_bw), H,
                  W, c.flow, &snap.target[static_cast<std::size_t>(e) * 2 * HW],
                  &snap.weight[static_cast<std::size_t>(e) * 2 * HW]);
      continue;
    }
    const std::vector<double> n[2] = {field.sample(rng_n), field.sample(rng_n)};
    double affine[2][3] = {{0, 0, 0}, {0, 0, 0}};
    std::vector<double> gf[2];
    for (int a = 0; a < 2; ++a) {
      for (double& coef : affine[a]) coef = noise.affine_px * nx(rng_x);
      if (noise.field_px > 0) gf[a] = sampleField(rng_x);
    }
    // The edge's own white scale (drawn only when spread, so that the other streams stay put).
    const double edge_scale =
        noise.edge_scale_spread > 0 ? std::exp(noise.edge_scale_spread * nx(rng_x)) : 1.0;
    for (int p = 0; p < HW; ++p) {
      const double d = disp_true_[i][p];
      const Eigen::Vector3d Y =
          transferPoint(T_ji.linear(), T_ji.translation(), K_, p % W, p / W, d);
      bool visible = d > 0 && Y.z() > 0;
      double proj[2] = {0.0, 0.0};
      if (visible) {
        const double xn = Y.x() / Y.z(), yn = Y.y() / Y.z();
        proj[0] = K_.fx * xn + K_.cx;
        proj[1] = K_.fy * yn + K_.cy;
        visible = proj[0] >= -0.5 && proj[0] <= W - 0.5 && proj[1] >= -0.5 && proj[1] <= H - 0.5;
        // Hidden when the surface that camera j sees along this ray is nearer than the point
        // (point inverse depth in j: d / Y.z).
        if (visible) visible = d / Y.z() >= c.scene.inverseDepth(T_wc_j, xn, yn) * (1.0 - 1e-3);
      }
      const bool zero = u01(rng_w) < c.weights.zero_fraction || !visible;
      const bool outlier = noise.outlier_fraction > 0 && u01(rng_x) < noise.outlier_fraction;
      const double u = (p % W - K_.cx) / (0.5 * W), v = (p / W - K_.cy) / (0.5 * H);
      for (int a = 0; a < 2; ++a) {
        const float w = zero ? 0.0f : static_cast<float>(c.weights.sample(rng_w));
        const double sigma =
            w > 0 ? edge_scale * noise.amplitude / std::sqrt(c.weight_scale * w) : 0.0;
        snap.weight[(static_cast<std::size_t>(e) * 2 + a) * HW + p] = w;
        // Student-t of unit variance: z · sqrt((ν − 2) / χ²_ν).
        const double white = chi2 ? n[a][p] * std::sqrt((t_dof - 2) / (*chi2)(rng_x)) : n[a][p];
        double err = sigma * white + affine[a][0] + affine[a][1] * u + affine[a][2] * v;
        if (noise.field_px > 0) err += noise.field_px * gf[a][p];
        if (outlier) err *= noise.outlier_factor;
        snap.target[(static_cast<std::size_t>(e) * 2 + a) * HW + p] =
            static_cast<float>(proj[a] + (w > 0 ? err : 0.0));
      }
    }
  }
  const std::set<std::int64_t> sources(snap.ii.begin(), snap.ii.end());
  if (c.sensor.mode == SensorMode::Rgbd) {
    // Readings on the source keyframes (DROID's disps_sens), d_true + N(0, 1/α); a draw that
    // would not be positive is no reading (0), like a sensor's hole.
    std::mt19937_64 rng_v(mixSeed(c.seed, kDepthReadings, s)),
        rng_d(mixSeed(c.seed, kDepthNoise, s, run));
    std::normal_distribution<double> nd(0.0, 1.0 / std::sqrt(c.sensor.depth_alpha));
    snap.disps_sens = std::vector<float>(snap.disps.size(), 0.0f);
    for (std::int64_t k : sources)
      for (int p = 0; p < HW; ++p) {
        const bool valid = u01(rng_v) < c.sensor.depth_valid_fraction;
        const double v = disp_true_[k][p] + nd(rng_d);
        if (valid && v > 0 && disp_true_[k][p] > 0)
          (*snap.disps_sens)[static_cast<std::size_t>(k) * HW + p] = static_cast<float>(v);
      }
  }
  const bool droid_gauge = c.gauge.type == GaugeOptions::Type::Droid;
  if (droid_gauge) snap.t0 = *sources.begin() + 1;  // DROID's max(1, min(ii) + 1)
  snap.validate();
  if (!c.solve) return out;

  // Initial state: the truth perturbed, gauge held at the truth; then the solve.
  std::mt19937_64 rng_p(mixSeed(c.seed, kInitialState, s, run));
  std::normal_distribution<double> n01(0.0, 1.0);
  const int ga = static_cast<int>(*sources.begin()),
            gb = droid_gauge ? -1 : static_cast<int>(*std::next(sources.begin()));
  const bool minimal = c.gauge.type == GaugeOptions::Type::Minimal;
  const bool chained =
      c.gauge_hold == GaugeHold::Estimate && s > 0 && c.mode == SimulationMode::SlidingWindow;
  std::set<std::int64_t> previous_graph;
  if (chained) {
    if (!previous || previous->numKeyframes() > N)
      throw std::invalid_argument("scenario: snapshot " + std::to_string(s) +
                                  ": --gauge-hold estimate needs the previous snapshot's result (" +
                                  std::to_string(s - 1) + " or earlier)");
    for (std::int64_t k : previous->graphKeyframes()) previous_graph.insert(k);
    for (int g : {ga, gb})
      if (g >= 0 && !previous_graph.count(g))
        throw std::invalid_argument("scenario: snapshot " + std::to_string(s) +
                                    ": gauge keyframe " + std::to_string(g) +
                                    " has no estimate in the previous snapshot (id " +
                                    std::to_string(previous->id.value_or(-1)) + ")");
    // Keyframes outside this graph keep what the previous snapshot last held for them.
    // (The stored rows are copied: a round trip through T_wc would change their last bits.)
    for (int k = 0; k < previous->numKeyframes(); ++k)
      snap.poses_cw.row(k) = previous->poses_cw.row(k);
  }
  for (int k : snap.graphKeyframes()) {
    Vector6d xi;
    for (int q = 0; q < 6; ++q)
      xi[q] = n01(rng_p) * (q < 3 ? c.perturbation.translation : c.perturbation.rotation);
    float* d = &snap.disps[static_cast<std::size_t>(k) * HW];
    for (int p = 0; p < HW; ++p)
      d[p] = static_cast<float>(d[p] * std::exp(c.perturbation.inverse_depth * n01(rng_p)));
    if (chained) {
      // Held (gauge) or started at the previous estimate; a new keyframe from its predecessor's
      // estimate moved by the true motion, perturbed, as DROID starts a keyframe from the last.
      if (previous_graph.count(k)) {
        if (k == ga || k == gb) continue;  // held exactly where the previous snapshot left it
        snap.setT_wc(k, Eigen::Isometry3d(previous->T_wc(k) * expSE3(xi)));
      } else {
        const Eigen::Isometry3d motion = T_wc_true_[k - 1].inverse() * T_wc_true_[k];
        snap.setT_wc(k, Eigen::Isometry3d(snap.T_wc(k - 1) * motion * expSE3(xi)));
      }
      continue;
    }
    if (k == ga || (k == gb && !minimal)) continue;
    Eigen::Isometry3d T = T_wc_true_[k] * expSE3(xi);
    if (k == gb) {  // minimal gauge: the scale keyframe starts at its true distance
      const Eigen::Vector3d c_a = T_wc_true_[ga].translation();
      const double D = (T_wc_true_[gb].translation() - c_a).norm();
      T.translation() = c_a + D * (T.translation() - c_a).normalized();
    }
    snap.setT_wc(k, T);
  }
  out.solver = solveDba(snap, c.engineOptions(), c.solver);
  return out;
}

}  // namespace dbacov::sim
