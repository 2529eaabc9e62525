#include "dbacov/sim/scenario_json.h"

#include <fstream>
#include <functional>
#include <set>
#include <sstream>

#include <nlohmann/json.hpp>

#include "dbacov/core/errors.h"

namespace dbacov::sim {
namespace {

using nlohmann::json;

/// Reads the keys of one JSON object into fields, refusing unknown keys and wrong types.
class Reader {
 public:
  Reader(const json& obj, std::string path, std::string source)
      : obj_(obj), path_(std::move(path)), source_(std::move(source)) {
    if (!obj_.is_object())
      fail(path_.empty() ? "the file" : "key '" + path_ + "'", "expected an object");
  }
  /// Refuses the keys that no get() asked for.
  void finish() const {
    for (const auto& [k, v] : obj_.items())
      if (!seen_.count(k)) fail("key '" + key(k) + "'", "unknown key");
  }

  template <typename T>
  void get(const std::string& k, T& out) {
    seen_.insert(k);
    if (!obj_.contains(k)) return;
    const json& v = obj_.at(k);
    if constexpr (std::is_same_v<T, bool>) {
      if (!v.is_boolean()) fail("key '" + key(k) + "'", "expected true or false");
      out = v.get<bool>();
    } else if constexpr (std::is_integral_v<T>) {
      if (!v.is_number_integer()) fail("key '" + key(k) + "'", "expected an integer");
      if (std::is_unsigned_v<T> && v.is_number_integer() && !v.is_number_unsigned())
        fail("key '" + key(k) + "'", "expected a non-negative integer");
      out = v.get<T>();
    } else if constexpr (std::is_floating_point_v<T>) {
      if (!v.is_number()) fail("key '" + key(k) + "'", "expected a number");
      out = v.get<T>();
    } else if constexpr (std::is_same_v<T, std::string>) {
      if (!v.is_string()) fail("key '" + key(k) + "'", "expected a string");
      out = v.get<std::string>();
    } else if constexpr (std::is_same_v<T, Eigen::Vector3d>) {
      if (!v.is_array() || v.size() != 3 || !v[0].is_number() || !v[1].is_number() ||
          !v[2].is_number())
        fail("key '" + key(k) + "'", "expected an array of 3 numbers");
      out << v[0].get<double>(), v[1].get<double>(), v[2].get<double>();
    }
  }
  void get(const std::string& k, std::optional<double>& out) {
    double v = 0;
    seen_.insert(k);
    if (!obj_.contains(k)) return;
    get(k, v);
    out = v;
  }
  /// An enumeration given by name: `parse` throws std::invalid_argument for unknown names.
  template <typename E>
  void getEnum(const std::string& k, E& out, const std::function<E(const std::string&)>& parse) {
    std::string name;
    seen_.insert(k);
    if (!obj_.contains(k)) return;
    get(k, name);
    try {
      out = parse(name);
    } catch (const std::invalid_argument& e) {
      fail("key '" + key(k) + "'", e.what());
    }
  }
  /// A nested object, read by `read`.
  void object(const std::string& k, const std::function<void(Reader&)>& read) {
    seen_.insert(k);
    if (!obj_.contains(k)) return;
    Reader sub(obj_.at(k), key(k), source_);
    read(sub);
    sub.finish();
  }
  const json& raw(const std::string& k) {
    seen_.insert(k);
    return obj_.at(k);
  }
  bool has(const std::string& k) const { return obj_.contains(k); }
  std::string key(const std::string& k) const { return path_.empty() ? k : path_ + "." + k; }
  [[noreturn]] void fail(const std::string& where, const std::string& what) const {
    throw InputError(source_ + ": " + where + ": " + what);
  }

 private:
  const json& obj_;
  std::string path_, source_;
  std::set<std::string> seen_;
};

json vec(const Eigen::Vector3d& v) {
  return json::array({v.x(), v.y(), v.z()});
}

}  // namespace

void applyScenarioJson(const std::string& text, const std::string& source, ScenarioConfig& c) {
  json root;
  try {
    root = json::parse(text);
  } catch (const json::parse_error& e) {
    throw InputError(source + ": invalid JSON: " + e.what());
  }
  Reader r(root, "", source);
  r.get("seed", c.seed);
  r.getEnum<SimulationMode>("mode", c.mode, parseSimulationMode);
  r.get("window", c.window);
  r.get("weight_scale", c.weight_scale);
  r.get("solve", c.solve);
  r.object("camera", [&](Reader& o) {
    o.get("height", c.camera.H);
    o.get("width", c.camera.W);
    o.get("fx", c.camera.fx);
    o.get("fy", c.camera.fy);
    o.get("cx", c.camera.cx);
    o.get("cy", c.camera.cy);
  });
  r.object("scene", [&](Reader& o) {
    o.get("min", c.scene.min_corner);
    o.get("max", c.scene.max_corner);
    if (o.has("boxes")) {
      const json& boxes = o.raw("boxes");
      if (!boxes.is_array()) o.fail("key 'scene.boxes'", "expected an array of {min, max} objects");
      c.scene.boxes.clear();
      for (std::size_t i = 0; i < boxes.size(); ++i) {
        Box b;
        Reader br(boxes[i], "scene.boxes[" + std::to_string(i) + "]", source);
        br.get("min", b.min_corner);
        br.get("max", b.max_corner);
        br.finish();
        c.scene.boxes.push_back(b);
      }
    }
  });
  r.object("trajectory", [&](Reader& o) {
    o.getEnum<TrajectoryType>("type", c.trajectory.type, parseTrajectoryType);
    o.get("keyframes", c.trajectory.num_keyframes);
    o.get("step", c.trajectory.step);
    o.get("yaw_amplitude", c.trajectory.yaw_amplitude);
    o.get("loop_center", c.trajectory.loop_center);
    o.get("loop_radius", c.trajectory.loop_radius);
    o.get("keyframes_per_lap", c.trajectory.keyframes_per_lap);
  });
  r.object("edges", [&](Reader& o) {
    o.get("radius", c.edges.edge_radius);
    o.get("overlap_threshold", c.edges.overlap_threshold);
    o.get("max_overlap_edges", c.edges.max_overlap_edges);
    o.get("candidate_distance", c.edges.candidate_distance);
  });
  r.object("weights", [&](Reader& o) {
    o.getEnum<WeightModel::Distribution>("distribution", c.weights.distribution,
                                         parseWeightDistribution);
    o.get("min", c.weights.min);
    o.get("max", c.weights.max);
    o.get("alpha", c.weights.alpha);
    o.get("beta", c.weights.beta);
    o.get("value", c.weights.value);
    o.get("zero_fraction", c.weights.zero_fraction);
  });
  r.object("noise", [&](Reader& o) {
    o.getEnum<NoiseModel::Type>("model", c.noise.type, parseNoiseType);
    o.get("correlation_length_px", c.noise.correlation_length_px);
    o.get("amplitude", c.noise.amplitude);
    o.get("affine_px", c.noise.affine_px);
    o.get("field_px", c.noise.field_px);
    o.get("field_length_px", c.noise.field_length_px);
    o.get("outlier_fraction", c.noise.outlier_fraction);
    o.get("outlier_factor", c.noise.outlier_factor);
  });
  r.object("gauge", [&](Reader& o) {
    o.getEnum<GaugeOptions::Type>("type", c.gauge.type, [](const std::string& n) {
      if (n == "two-pose") return GaugeOptions::Type::TwoPose;
      if (n == "minimal") return GaugeOptions::Type::Minimal;
      throw std::invalid_argument("unknown gauge '" + n + "', expected two-pose or minimal");
    });
    o.get("sigma_rot", c.gauge.sigma_rot);
    o.get("sigma_trans", c.gauge.sigma_trans);
  });
  r.object("initial_perturbation", [&](Reader& o) {
    o.get("translation", c.perturbation.translation);
    o.get("rotation", c.perturbation.rotation);
    o.get("inverse_depth", c.perturbation.inverse_depth);
  });
  r.object("solver", [&](Reader& o) {
    o.get("max_iterations", c.solver.max_iterations);
    o.get("initial_lambda", c.solver.initial_lambda);
    o.get("max_lambda", c.solver.max_lambda);
    o.get("function_tolerance", c.solver.function_tolerance);
    o.get("gradient_tolerance", c.solver.gradient_tolerance);
    o.get("step_tolerance", c.solver.step_tolerance);
    o.get("min_inverse_depth", c.solver.min_inverse_depth);
  });
  r.object("time", [&](Reader& o) {
    o.get("frame_interval", c.time.frame_interval);
    o.get("fps", c.time.fps);
    o.get("start_time", c.time.start_time);
  });
  r.finish();
}

ScenarioConfig loadScenarioConfig(const std::string& path) {
  std::ifstream f(path, std::ios::binary);
  if (!f) throw InputError(path + ": cannot open the scenario configuration");
  std::ostringstream text;
  text << f.rdbuf();
  if (f.bad()) throw InputError(path + ": read error");
  ScenarioConfig c;
  applyScenarioJson(text.str(), path, c);
  return c;
}

std::string scenarioConfigToJson(const ScenarioConfig& c) {
  const PinholeIntrinsics K = c.camera.intrinsics();
  json boxes = json::array();
  for (const Box& b : c.scene.boxes)
    boxes.push_back({{"min", vec(b.min_corner)}, {"max", vec(b.max_corner)}});
  json j = {
      {"seed", c.seed},
      {"mode", toString(c.mode)},
      {"window", c.window},
      {"weight_scale", c.weight_scale},
      {"solve", c.solve},
      {"camera",
       {{"height", c.camera.H},
        {"width", c.camera.W},
        {"fx", K.fx},
        {"fy", K.fy},
        {"cx", K.cx},
        {"cy", K.cy}}},
      {"scene",
       {{"min", vec(c.scene.min_corner)}, {"max", vec(c.scene.max_corner)}, {"boxes", boxes}}},
      {"trajectory",
       {{"type", toString(c.trajectory.type)},
        {"keyframes", c.trajectory.num_keyframes},
        {"step", c.trajectory.step},
        {"yaw_amplitude", c.trajectory.yaw_amplitude},
        {"loop_center", vec(c.trajectory.loop_center)},
        {"loop_radius", c.trajectory.loop_radius},
        {"keyframes_per_lap", c.trajectory.keyframes_per_lap}}},
      {"edges",
       {{"radius", c.edges.edge_radius},
        {"overlap_threshold", c.edges.overlap_threshold},
        {"max_overlap_edges", c.edges.max_overlap_edges},
        {"candidate_distance", c.edges.candidate_distance}}},
      {"weights",
       {{"distribution", toString(c.weights.distribution)},
        {"min", c.weights.min},
        {"max", c.weights.max},
        {"alpha", c.weights.alpha},
        {"beta", c.weights.beta},
        {"value", c.weights.value},
        {"zero_fraction", c.weights.zero_fraction}}},
      {"noise",
       {{"model", toString(c.noise.type)},
        {"correlation_length_px", c.noise.correlation_length_px},
        {"amplitude", c.noise.amplitude},
        {"affine_px", c.noise.affine_px},
        {"field_px", c.noise.field_px},
        {"field_length_px", c.noise.field_length_px},
        {"outlier_fraction", c.noise.outlier_fraction},
        {"outlier_factor", c.noise.outlier_factor}}},
      {"gauge",
       {{"type", c.gauge.type == GaugeOptions::Type::Minimal ? "minimal" : "two-pose"},
        {"sigma_rot", c.gauge.sigma_rot},
        {"sigma_trans", c.gauge.sigma_trans}}},
      {"initial_perturbation",
       {{"translation", c.perturbation.translation},
        {"rotation", c.perturbation.rotation},
        {"inverse_depth", c.perturbation.inverse_depth}}},
      {"solver",
       {{"max_iterations", c.solver.max_iterations},
        {"initial_lambda", c.solver.initial_lambda},
        {"max_lambda", c.solver.max_lambda},
        {"function_tolerance", c.solver.function_tolerance},
        {"gradient_tolerance", c.solver.gradient_tolerance},
        {"step_tolerance", c.solver.step_tolerance},
        {"min_inverse_depth", c.solver.min_inverse_depth}}},
      {"time",
       {{"frame_interval", c.time.frame_interval},
        {"fps", c.time.fps},
        {"start_time", c.time.start_time}}},
  };
  return j.dump(2) + "\n";
}

}  // namespace dbacov::sim
