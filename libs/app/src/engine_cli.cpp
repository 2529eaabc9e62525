#include "engine_cli.h"

#include <cmath>
#include <optional>
#include <sstream>

#include <CLI/CLI.hpp>

#include "dbacov/app/outputs.h"
#include "dbacov/core/self_calibration.h"

namespace dbacov::app::detail {

namespace {
/// The whole text read by `read` (std::stoll, std::stod: leading blanks allowed, nothing after),
/// or nothing when it is no such number or beyond the type's range.
template <class T, class Read>
std::optional<T> readWhole(const std::string& text, Read read) {
  try {
    std::size_t used = 0;
    const T v = read(text, &used);
    if (used == text.size()) return v;
  } catch (const std::logic_error&) {
  }
  return std::nullopt;
}
}  // namespace

std::optional<long long> parseInteger(const std::string& text) {
  return readWhole<long long>(
      text, [](const std::string& t, std::size_t* used) { return std::stoll(t, used); });
}

CLI::Validator integerIn(long long lo, long long hi) {
  const std::string range = std::to_string(lo) + ".." + std::to_string(hi);
  return CLI::Validator(
      [lo, hi, range](std::string& text) -> std::string {
        const std::optional<long long> v = parseInteger(text);
        if (!v) return "'" + text + "' is not an integer in " + range;
        return *v < lo || *v > hi ? text + " is not in " + range : std::string();
      },
      "");  // no annotation in --help, as the ranges CLI::Range gave (cli_common.cpp)
}

CLI::Validator positiveNumber(bool zero_too) {
  const std::string bound = zero_too ? ">= 0" : "> 0";
  return CLI::Validator(
      [zero_too, bound](std::string& text) -> std::string {
        const std::optional<double> v = readWhole<double>(
            text, [](const std::string& t, std::size_t* used) { return std::stod(t, used); });
        const bool ok = v && std::isfinite(*v) && (zero_too ? *v >= 0 : *v > 0);
        return ok ? std::string() : "'" + text + "' is not a finite number " + bound;
      },
      "");
}

CLI::Validator numberIn(double lo, double hi) {
  std::ostringstream os;
  os << "[" << lo << ", " << hi << "]";
  const std::string range = os.str();
  return CLI::Validator(
      [lo, hi, range](std::string& text) -> std::string {
        const std::optional<double> v = readWhole<double>(
            text, [](const std::string& t, std::size_t* used) { return std::stod(t, used); });
        if (!v) return "'" + text + "' is not a number in " + range;
        return *v >= lo && *v <= hi ? std::string() : text + " is not in " + range;  // NaN too
      },
      "");
}

template <class E>
CLI::Validator enumValidator() {
  // The message of parseEnum (the enum table's "unknown <what> 'x', expected a, b or c"), as the
  // library and the Python module report it; the help shows the names as CLI::IsMember did.
  std::string names;
  for (const std::string& n : enumNames<E>()) names += (names.empty() ? "" : ",") + n;
  return CLI::Validator(
      [](std::string& name) -> std::string {
        try {
          parseEnum<E>(name);
          return {};
        } catch (const std::invalid_argument& e) {
          return e.what();
        }
      },
      "{" + names + "}");
}

template <class E>
CLI::Option* addEnumOption(CLI::App& cli, const std::string& flags, E& value,
                           const std::string& description) {
  return cli
      .add_option_function<std::string>(
          flags, [&value](const std::string& name) { value = parseEnum<E>(name); }, description)
      ->check(enumValidator<E>());
}

template <class E>
CLI::Option* addEnumOption(CLI::App& cli, const std::string& flags, std::optional<E>& value,
                           const std::string& description) {
  return cli
      .add_option_function<std::string>(
          flags, [&value](const std::string& name) { value = parseEnum<E>(name); }, description)
      ->check(enumValidator<E>());
}

template CLI::Option* addEnumOption(CLI::App&, const std::string&, Preset&, const std::string&);
template CLI::Option* addEnumOption(CLI::App&, const std::string&, SolverKind&, const std::string&);
template CLI::Option* addEnumOption(CLI::App&, const std::string&, Ordering&, const std::string&);
template CLI::Option* addEnumOption(CLI::App&, const std::string&, EmitMode&, const std::string&);
template CLI::Option* addEnumOption(CLI::App&, const std::string&, GraphEdges&, const std::string&);
template CLI::Option* addEnumOption(CLI::App&, const std::string&,
                                    std::optional<GaugeOptions::Type>&, const std::string&);

CLI::Option* addWeightScaleOption(CLI::App& cli, std::optional<double>& value,
                                  const std::string& default_text) {
  return cli
      .add_option("--weight-scale", value,
                  "Information per unit confidence, px^-2 (" + default_text + ")")
      ->check(detail::positiveNumber());
}

void addEngineOptions(CLI::App& cli, DbaOptionOverrides& o) {
  addEnumOption(cli, "--preset", o.preset, "Engine preset: droid (default) or paper");
  addWeightScaleOption(cli, o.weight_scale, "the preset's: droid 0.001, paper 0.1");
  addEnumOption(
      cli, "--gauge", o.gauge,
      "two-pose (priors on the first two keyframes of ii), minimal (first fixed + scale) or "
      "droid (the poses below the snapshot's t0 fixed, as DROID's BA held them)");
  cli.add_option("--sensor-depth-weight", o.sensor_depth_weight,
                 "RGB-D (key disps_sens): information of the depth-sensor factor (droid 0.05)");
  cli.add_option("--gauge-sigma-rot", o.gauge_sigma_rot,
                 "two-pose prior sigma of rotation, rad (0 = hard fix)");
  cli.add_option("--gauge-sigma-trans", o.gauge_sigma_trans,
                 "two-pose prior sigma of translation (0 = hard fix)");
  cli.add_option("--near", o.near,
                 "Keep a pixel only if d < 1/near and its depth in frame j > near");
  cli.add_option("--far", o.far, "Keep a pixel only if d > 1/far");
  cli.add_option("--min-depth-ratio", o.min_depth_ratio,
                 "Drop a pixel when z_j*d is below this (droid 0.25; 0 = off)");
}

void addCovarianceOptions(CLI::App& cli, CovarianceOptions& o) {
  addEnumOption(cli, "--solver", o.kind,
                "sparse (CHOLMOD, default) or dense (reference, small graphs)");
  addEnumOption(cli, "--ordering", o.ordering,
                "Fill-reducing ordering of the sparse solver: auto, amd, metis, nesdis, natural");
}

}  // namespace dbacov::app::detail
