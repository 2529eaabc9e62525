#include "dbacov/sim/scenario_schema.h"

#include <cerrno>
#include <cstdlib>
#include <stdexcept>
#include <type_traits>

#include <nlohmann/json.hpp>

#include "dbacov/core/errors.h"

namespace dbacov::sim {
namespace {

using nlohmann::json;

[[noreturn]] void typeError(const std::string& where, const std::string& expected) {
  throw InputError(where + ": " + expected);
}

/// A value of type T from JSON, with the messages of the reader ("expected an integer", ...).
template <typename T>
T fromJson(const json& v, const std::string& where) {
  if constexpr (std::is_same_v<T, bool>) {
    if (!v.is_boolean()) typeError(where, "expected true or false");
    return v.get<bool>();
  } else if constexpr (std::is_integral_v<T>) {
    if (!v.is_number_integer()) typeError(where, "expected an integer");
    if (std::is_unsigned_v<T> && !v.is_number_unsigned())
      typeError(where, "expected a non-negative integer");
    return v.get<T>();
  } else if constexpr (std::is_floating_point_v<T>) {
    if (!v.is_number()) typeError(where, "expected a number");
    return v.get<T>();
  } else if constexpr (std::is_same_v<T, std::string>) {
    if (!v.is_string()) typeError(where, "expected a string");
    return v.get<std::string>();
  } else if constexpr (std::is_same_v<T, Eigen::Vector3d>) {
    if (!v.is_array() || v.size() != 3 || !v[0].is_number() || !v[1].is_number() ||
        !v[2].is_number())
      typeError(where, "expected an array of 3 numbers");
    return Eigen::Vector3d(v[0].get<double>(), v[1].get<double>(), v[2].get<double>());
  }
}

json toJson(const Eigen::Vector3d& v) {
  return json::array({v.x(), v.y(), v.z()});
}

/// A flag's number, all of its text.
template <typename T>
T fromText(const std::string& text, const std::string& flag) {
  const char* s = text.c_str();
  char* end = nullptr;
  errno = 0;
  T value{};
  if constexpr (std::is_floating_point_v<T>) {
    value = static_cast<T>(std::strtod(s, &end));
  } else if constexpr (std::is_unsigned_v<T>) {
    value = static_cast<T>(std::strtoull(s, &end, 10));
    if (!text.empty() && text[0] == '-') end = const_cast<char*>(s);
  } else {
    const long long v = std::strtoll(s, &end, 10);
    value = static_cast<T>(v);
    if (static_cast<long long>(value) != v) errno = ERANGE;
  }
  if (end == s || *end != '\0' || errno == ERANGE)
    throw std::invalid_argument(flag + " '" + text + "': expected " +
                                (std::is_floating_point_v<T> ? "a number" : "an integer"));
  return value;
}

/// A row for a number, bool or vector at `access(config)`.
template <typename T, typename Access>
ScenarioField field(std::string key, std::string flag, std::string help, Access access) {
  ScenarioField f;
  f.key = std::move(key);
  f.flag = std::move(flag);
  f.help = std::move(help);
  f.type_name = std::is_floating_point_v<T>      ? "FLOAT"
                : std::is_integral_v<T>          ? "INT"
                : std::is_same_v<T, std::string> ? "TEXT"
                                                 : "";
  f.read = [access](const json& v, ScenarioConfig& c, const std::string& where) {
    access(c) = fromJson<T>(v, where);
  };
  f.write = [access](const ScenarioConfig& c) {
    const T& v = access(const_cast<ScenarioConfig&>(c));
    if constexpr (std::is_same_v<T, Eigen::Vector3d>)
      return toJson(v);
    else
      return json(v);
  };
  if constexpr (std::is_same_v<T, std::string>) {
    f.parse = [access](const std::string& text, ScenarioConfig& c) { access(c) = text; };
  } else if constexpr (!std::is_same_v<T, Eigen::Vector3d> && !std::is_same_v<T, bool>) {
    const std::string fl = f.flag;
    f.parse = [access, fl](const std::string& text, ScenarioConfig& c) {
      access(c) = fromText<T>(text, fl);
    };
  }
  return f;
}

/// A row for an enum with its parse (throws std::invalid_argument for unknown names) and name.
template <typename E, typename Access>
ScenarioField enumField(std::string key, std::string flag, std::string help,
                        std::vector<std::string> choices, E (*parse)(const std::string&),
                        std::string (*name)(E), Access access) {
  ScenarioField f;
  f.key = std::move(key);
  f.flag = std::move(flag);
  f.help = std::move(help);
  f.choices = std::move(choices);
  f.type_name = "TEXT";
  f.read = [access, parse](const json& v, ScenarioConfig& c, const std::string& where) {
    if (!v.is_string()) typeError(where, "expected a string");
    try {
      access(c) = parse(v.get<std::string>());
    } catch (const std::invalid_argument& e) {
      typeError(where, e.what());
    }
  };
  f.write = [access, name](const ScenarioConfig& c) {
    return json(name(access(const_cast<ScenarioConfig&>(c))));
  };
  f.parse = [access, parse](const std::string& text, ScenarioConfig& c) {
    access(c) = parse(text);
  };
  return f;
}

GaugeOptions::Type parseGauge(const std::string& name) {
  return parseEnum<GaugeOptions::Type>(name);
}
std::string gaugeName(GaugeOptions::Type t) {
  return toString(t);
}

/// camera.fx/fy/cx/cy: unset means derived from the grid; the writer writes the value in use.
ScenarioField intrinsic(const std::string& name, std::optional<double> CameraConfig::*member,
                        double PinholeIntrinsics::*used) {
  ScenarioField f;
  f.key = "camera." + name;
  f.read = [member](const json& v, ScenarioConfig& c, const std::string& where) {
    c.camera.*member = fromJson<double>(v, where);
  };
  f.write = [used](const ScenarioConfig& c) { return json(c.camera.intrinsics().*used); };
  return f;
}

ScenarioField boxes() {
  ScenarioField f;
  f.key = "scene.boxes";
  f.read = [](const json& v, ScenarioConfig& c, const std::string& where) {
    if (!v.is_array()) typeError(where, "expected an array of {min, max} objects");
    c.scene.boxes.clear();
    const std::string source = where.substr(0, where.rfind(": key '"));
    for (std::size_t i = 0; i < v.size(); ++i) {
      const std::string at = source + ": key 'scene.boxes[" + std::to_string(i) + "]";
      if (!v[i].is_object()) typeError(at + "'", "expected an object");
      Box b;
      for (const auto& [k, x] : v[i].items()) {
        if (k == "min")
          b.min_corner = fromJson<Eigen::Vector3d>(x, at + ".min'");
        else if (k == "max")
          b.max_corner = fromJson<Eigen::Vector3d>(x, at + ".max'");
        else
          typeError(at + "." + k + "'", "unknown key");
      }
      c.scene.boxes.push_back(b);
    }
  };
  f.write = [](const ScenarioConfig& c) {
    json a = json::array();
    for (const Box& b : c.scene.boxes)
      a.push_back({{"min", toJson(b.min_corner)}, {"max", toJson(b.max_corner)}});
    return a;
  };
  return f;
}

std::vector<ScenarioField> makeSchema() {
  using C = ScenarioConfig;
  std::vector<ScenarioField> s;
  s.push_back(field<std::uint64_t>(
      "seed", "--seed", "Random seed of the scenario", [](C & c) -> auto& { return c.seed; }));
  s.push_back(enumField<SimulationMode>(
      "mode", "--mode",
      "sliding-window (one snapshot per new keyframe, DROID's frontend) or whole (one snapshot of "
      "the whole trajectory)",
      {"sliding-window", "whole"}, parseSimulationMode, toString,
      [](C & c) -> auto& { return c.mode; }));
  s.push_back(field<int>(
      "window", "--window", "Sliding window: keyframes per snapshot graph (W)",
      [](C & c) -> auto& { return c.window; }));
  s.push_back(field<double>(
      "weight_scale", "--weight-scale", "Information per unit confidence, px^-2 (default 4)",
      [](C & c) -> auto& { return c.weight_scale; }));
  s.push_back(field<bool>(
      "solve", "", "", [](C & c) -> auto& { return c.solve; }));
  s.push_back(field<int>(
      "camera.height", "--height", "Grid height, pixels (default 48)",
      [](C & c) -> auto& { return c.camera.H; }));
  s.push_back(field<int>(
      "camera.width", "--width",
      "Grid width, pixels (default 64); fx = fy = 0.87 width unless the config sets them",
      [](C & c) -> auto& { return c.camera.W; }));
  s.push_back(intrinsic("fx", &CameraConfig::fx, &PinholeIntrinsics::fx));
  s.push_back(intrinsic("fy", &CameraConfig::fy, &PinholeIntrinsics::fy));
  s.push_back(intrinsic("cx", &CameraConfig::cx, &PinholeIntrinsics::cx));
  s.push_back(intrinsic("cy", &CameraConfig::cy, &PinholeIntrinsics::cy));
  s.push_back(enumField<SensorMode>(
      "sensor.mode", "--sensor",
      "DROID mode: mono, stereo (an edge to the right camera of a rig per keyframe) or rgbd (a "
      "depth-sensor reading per pixel); stereo and rgbd make the scale metric",
      enumNames<SensorMode>(), parseSensorMode, toString,
      [](C & c) -> auto& { return c.sensor.mode; }));
  s.push_back(field<double>(
      "sensor.stereo_baseline", "--stereo-baseline",
      "Stereo: baseline of the rig, metres (default 0.1, DROID's)",
      [](C & c) -> auto& { return c.sensor.stereo_baseline; }));
  s.push_back(field<double>(
      "sensor.depth_alpha", "--depth-alpha",
      "RGB-D: information of a depth reading, (inverse depth)^-2 (default 400); also the engine's "
      "--sensor-depth-weight",
      [](C & c) -> auto& { return c.sensor.depth_alpha; }));
  s.push_back(field<double>(
      "sensor.depth_valid_fraction", "", "",
      [](C & c) -> auto& { return c.sensor.depth_valid_fraction; }));
  s.push_back(field<Eigen::Vector3d>(
      "scene.min", "", "", [](C & c) -> auto& { return c.scene.min_corner; }));
  s.push_back(field<Eigen::Vector3d>(
      "scene.max", "", "", [](C & c) -> auto& { return c.scene.max_corner; }));
  s.push_back(boxes());
  s.push_back(enumField<TrajectoryType>(
      "trajectory.type", "--trajectory", "line, loop or explore-return",
      {"line", "loop", "explore-return"}, parseTrajectoryType, toString,
      [](C & c) -> auto& { return c.trajectory.type; }));
  s.push_back(field<int>(
      "trajectory.keyframes", "--keyframes", "Keyframes of the whole sequence",
      [](C & c) -> auto& { return c.trajectory.num_keyframes; }));
  s.push_back(field<double>(
      "trajectory.step", "", "", [](C & c) -> auto& { return c.trajectory.step; }));
  s.push_back(field<double>(
      "trajectory.yaw_amplitude", "", "",
      [](C & c) -> auto& { return c.trajectory.yaw_amplitude; }));
  s.push_back(field<Eigen::Vector3d>(
      "trajectory.loop_center", "", "", [](C & c) -> auto& { return c.trajectory.loop_center; }));
  s.push_back(field<double>(
      "trajectory.loop_radius", "", "", [](C & c) -> auto& { return c.trajectory.loop_radius; }));
  s.push_back(field<int>(
      "trajectory.keyframes_per_lap", "", "",
      [](C & c) -> auto& { return c.trajectory.keyframes_per_lap; }));
  s.push_back(field<int>(
      "edges.radius", "--edge-radius", "Link keyframes at most this far apart (temporal edges)",
      [](C & c) -> auto& { return c.edges.edge_radius; }));
  s.push_back(field<double>(
      "edges.overlap_threshold", "--overlap-threshold",
      "Also link farther keyframes whose views overlap this much (0 = off)",
      [](C & c) -> auto& { return c.edges.overlap_threshold; }));
  s.push_back(field<int>(
      "edges.max_overlap_edges", "", "", [](C & c) -> auto& { return c.edges.max_overlap_edges; }));
  s.push_back(field<double>(
      "edges.candidate_distance", "", "",
      [](C & c) -> auto& { return c.edges.candidate_distance; }));
  s.push_back(enumField<WeightModel::Distribution>(
      "weights.distribution", "--weights",
      "Confidence distribution: uniform, beta (shape from the config) or constant",
      {"uniform", "beta", "constant"}, parseWeightDistribution, toString,
      [](C & c) -> auto& { return c.weights.distribution; }));
  s.push_back(field<double>(
      "weights.min", "--weight-min", "Smallest confidence (uniform, beta)",
      [](C & c) -> auto& { return c.weights.min; }));
  s.push_back(field<double>(
      "weights.max", "--weight-max", "Largest confidence (uniform, beta)",
      [](C & c) -> auto& { return c.weights.max; }));
  s.push_back(field<double>(
      "weights.alpha", "", "", [](C & c) -> auto& { return c.weights.alpha; }));
  s.push_back(field<double>(
      "weights.beta", "", "", [](C & c) -> auto& { return c.weights.beta; }));
  s.push_back(field<double>(
      "weights.value", "", "", [](C & c) -> auto& { return c.weights.value; }));
  s.push_back(field<double>(
      "weights.zero_fraction", "--zero-fraction", "Fraction of pixels with zero confidence",
      [](C & c) -> auto& { return c.weights.zero_fraction; }));
  s.push_back(enumField<NoiseModel::Type>(
      "noise.model", "--noise",
      "Target noise: white (independent pixels, consistent) or correlated (Gaussian random field "
      "per edge and axis)",
      {"white", "correlated"}, parseNoiseType, toString,
      [](C & c) -> auto& { return c.noise.type; }));
  s.push_back(enumField<NoiseModel::Persistence>(
      "noise.persistence", "--noise-persistence",
      "snapshot (every snapshot redraws its edges' confidences and errors) or edge (an edge's are "
      "drawn once and shared by every snapshot that holds it, as DROID's windows share flows)",
      {"snapshot", "edge"}, parseNoisePersistence, toString,
      [](C & c) -> auto& { return c.noise.persistence; }));
  s.push_back(field<double>(
      "noise.correlation_length_px", "--correlation-length",
      "Correlated noise: correlation length, pixels",
      [](C & c) -> auto& { return c.noise.correlation_length_px; }));
  s.push_back(field<double>(
      "noise.amplitude", "--noise-amplitude",
      "Multiplies the target noise (1 = the variance 1/(weight_scale w) "
      "that the confidences claim)",
      [](C & c) -> auto& { return c.noise.amplitude; }));
  // Errors the confidences do not describe (self-calibration studies; pixel_models.h).
  s.push_back(field<double>(
      "noise.affine_px", "", "", [](C & c) -> auto& { return c.noise.affine_px; }));
  s.push_back(field<double>(
      "noise.field_px", "", "", [](C & c) -> auto& { return c.noise.field_px; }));
  s.push_back(field<double>(
      "noise.field_length_px", "", "", [](C & c) -> auto& { return c.noise.field_length_px; }));
  s.push_back(field<double>(
      "noise.outlier_fraction", "", "", [](C & c) -> auto& { return c.noise.outlier_fraction; }));
  s.push_back(field<double>(
      "noise.outlier_factor", "", "", [](C & c) -> auto& { return c.noise.outlier_factor; }));
  s.push_back(field<double>(
      "noise.edge_scale_spread", "", "", [](C & c) -> auto& { return c.noise.edge_scale_spread; }));
  s.push_back(field<double>(
      "noise.student_t_dof", "", "", [](C & c) -> auto& { return c.noise.student_t_dof; }));
  s.push_back(field<bool>(
      "noise.field_fourier", "", "", [](C & c) -> auto& { return c.noise.field_fourier; }));
  s.push_back(enumField<NoiseFamily>(
      "noise.family", "--noise-family",
      "fixed (every run follows the noise settings) or open (every run draws its own error model: "
      "white scale 1/4-4x, per-edge spread, random fields of 1 px to beyond the image, affine, "
      "outliers, Student-t tails, and their mixtures; docs/apps/simul-dba.md)",
      {"fixed", "open"}, parseNoiseFamily, toString,
      [](C & c) -> auto& { return c.noise_family; }));
  s.push_back(field<std::string>(
      "flow.source", "--flow",
      "Targets: model (true projection + the noise model) or dis / farneback (OpenCV's dense "
      "optical flow between rendered textured images, confidence from forward-backward "
      "consistency)",
      [](C & c) -> auto& { return c.flow.source; }));
  s.push_back(field<int>(
      "flow.render_scale", "", "", [](C & c) -> auto& { return c.flow.render_scale; }));
  s.push_back(field<double>(
      "flow.image_noise", "--image-noise",
      "Image flow: sensor noise of the rendered images, grey levels (default 2)",
      [](C & c) -> auto& { return c.flow.image_noise; }));
  s.push_back(field<double>(
      "flow.fb_scale_px", "", "", [](C & c) -> auto& { return c.flow.fb_scale_px; }));
  s.push_back(field<double>(
      "flow.texture_scale", "", "", [](C & c) -> auto& { return c.flow.texture_scale; }));
  {
    // --gauge names the type only, as everywhere (DbaOptionOverrides): a two-pose gauge keeps the
    // sigmas of the file, a minimal one has none.
    ScenarioField g = enumField<GaugeOptions::Type>(
        "gauge.type", "--gauge",
        "Gauge of the solve, held at the truth: two-pose (hard unless the config gives sigmas), "
        "minimal, or droid (the first keyframe only: --sensor stereo or rgbd)",
        enumNames<GaugeOptions::Type>(), parseGauge, gaugeName,
        [](C & c) -> auto& { return c.gauge.type; });
    g.parse = [](const std::string& text, ScenarioConfig& c) {
      c.gauge.type = parseGauge(text);
      if (c.gauge.type == GaugeOptions::Type::Minimal) c.gauge.sigma_rot = c.gauge.sigma_trans = 0;
    };
    s.push_back(g);
  }
  s.push_back(enumField<GaugeHold>(
      "gauge.hold", "--gauge-hold",
      "Sliding window: hold each snapshot's gauge keyframes at the truth (default: absolute NEES "
      "per snapshot) or at the previous snapshot's estimates (DROID's frontend: frame and scale "
      "drift between windows; compare whole-sequence results with the ground truth)",
      {"truth", "estimate"}, parseGaugeHold, toString,
      [](C & c) -> auto& { return c.gauge_hold; }));
  s.push_back(field<double>(
      "gauge.sigma_rot", "", "", [](C & c) -> auto& { return c.gauge.sigma_rot; }));
  s.push_back(field<double>(
      "gauge.sigma_trans", "", "", [](C & c) -> auto& { return c.gauge.sigma_trans; }));
  s.push_back(field<double>(
      "initial_perturbation.translation", "", "",
      [](C & c) -> auto& { return c.perturbation.translation; }));
  s.push_back(field<double>(
      "initial_perturbation.rotation", "", "",
      [](C & c) -> auto& { return c.perturbation.rotation; }));
  s.push_back(field<double>(
      "initial_perturbation.inverse_depth", "", "",
      [](C & c) -> auto& { return c.perturbation.inverse_depth; }));
  s.push_back(field<int>(
      "solver.max_iterations", "", "", [](C & c) -> auto& { return c.solver.max_iterations; }));
  s.push_back(field<double>(
      "solver.initial_lambda", "", "", [](C & c) -> auto& { return c.solver.initial_lambda; }));
  s.push_back(field<double>(
      "solver.max_lambda", "", "", [](C & c) -> auto& { return c.solver.max_lambda; }));
  s.push_back(field<double>(
      "solver.function_tolerance", "", "",
      [](C & c) -> auto& { return c.solver.function_tolerance; }));
  s.push_back(field<double>(
      "solver.gradient_tolerance", "", "",
      [](C & c) -> auto& { return c.solver.gradient_tolerance; }));
  s.push_back(field<double>(
      "solver.step_tolerance", "", "", [](C & c) -> auto& { return c.solver.step_tolerance; }));
  s.push_back(field<double>(
      "solver.min_inverse_depth", "", "",
      [](C & c) -> auto& { return c.solver.min_inverse_depth; }));
  s.push_back(field<double>(
      "time.frame_interval", "", "", [](C & c) -> auto& { return c.time.frame_interval; }));
  s.push_back(field<double>(
      "time.fps", "--fps", "Camera rate: keyframe time = start + tstamp / fps (tstamp = 3 k)",
      [](C & c) -> auto& { return c.time.fps; }));
  s.push_back(field<double>(
      "time.start_time", "--start-time",
      "Time of image 0, seconds since 1970 (MRPT treats 0 as 'no time')",
      [](C & c) -> auto& { return c.time.start_time; }));
  return s;
}

}  // namespace

const std::vector<ScenarioField>& scenarioSchema() {
  static const std::vector<ScenarioField> schema = makeSchema();
  return schema;
}

const ScenarioField* findScenarioFlag(const std::string& flag) {
  for (const ScenarioField& f : scenarioSchema())
    if (f.flag == flag) return &f;
  return nullptr;
}

}  // namespace dbacov::sim
