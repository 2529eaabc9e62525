#include "dbacov/core/options.h"

#include <cmath>
#include <stdexcept>

namespace dbacov {

DbaOptions DbaOptions::droid() {
  return DbaOptions{};
}

DbaOptions DbaOptions::paper() {
  DbaOptions o;
  o.weight_scale = 0.1;
  o.min_depth_ratio.reset();
  o.near = 0.25;
  o.far = 2.0;
  o.gauge.type = GaugeOptions::Type::TwoPose;
  o.gauge.sigma_rot = M_PI / 180.0;
  o.gauge.sigma_trans = 0.05;
  return o;
}

DbaOptions DbaOptions::dpvo() {
  DbaOptions o;
  o.weight_scale = 1.0;  // DPVO's BA uses the confidences as they are
  o.min_depth_ratio = 0.2;
  o.max_residual = 128.0;
  o.image_margin = 64.0;
  o.gauge.type = GaugeOptions::Type::Droid;
  return o;
}

DbaOptions DbaOptions::preset(Preset preset) {
  switch (preset) {
    case Preset::Paper:
      return paper();
    case Preset::Dpvo:
      return dpvo();
    case Preset::Droid:
      break;
  }
  return droid();
}

DbaOptions DbaOptions::preset(const std::string& name) {
  return preset(parseEnum<Preset>(name));
}

DbaOptions DbaOptionOverrides::resolve() const {
  // The apps and the Python module read DROID's dense snapshots; DPVO's patch graphs are read by
  // the library (DbaCovariance(PatchGraph)), whose preset this is.
  if (preset == Preset::Dpvo)
    throw std::invalid_argument(
        "preset 'dpvo' is that of DPVO's patch graphs, which the programs and the Python module "
        "do not read yet; a DROID snapshot takes 'droid' or 'paper'");
  DbaOptions o = DbaOptions::preset(preset);
  if (weight_scale) o.weight_scale = *weight_scale;
  if (gauge) o.gauge.type = *gauge;
  if (sensor_depth_weight) o.sensor_depth_weight = *sensor_depth_weight;
  if (o.gauge.type != GaugeOptions::Type::TwoPose) {
    if (gauge_sigma_rot || gauge_sigma_trans)
      throw std::invalid_argument(
          "--gauge-sigma-rot/--gauge-sigma-trans apply to --gauge two-pose only");
    o.gauge.sigma_rot = o.gauge.sigma_trans = 0;
  }
  if (gauge_sigma_rot) o.gauge.sigma_rot = *gauge_sigma_rot;
  if (gauge_sigma_trans) o.gauge.sigma_trans = *gauge_sigma_trans;
  if (near) o.near = *near;
  if (far) o.far = *far;
  if (min_depth_ratio) {
    if (*min_depth_ratio == 0)
      o.min_depth_ratio.reset();
    else
      o.min_depth_ratio = *min_depth_ratio;
  }
  o.validate();
  return o;
}

void DbaOptions::validate() const {
  auto positive = [](double v) { return std::isfinite(v) && v > 0; };
  if (!positive(weight_scale)) throw std::invalid_argument("weight scale must be finite and > 0");
  if (min_depth_ratio && !(std::isfinite(*min_depth_ratio) && *min_depth_ratio >= 0))
    throw std::invalid_argument("minimum depth ratio must be finite and >= 0");
  if (near && !positive(*near)) throw std::invalid_argument("near must be finite and > 0");
  if (far && !positive(*far)) throw std::invalid_argument("far must be finite and > 0");
  if (near && far && !(*near < *far)) throw std::invalid_argument("near must be < far");
  if (max_residual && !positive(*max_residual))
    throw std::invalid_argument("maximum residual must be finite and > 0");
  if (image_margin && !(std::isfinite(*image_margin) && *image_margin >= 0))
    throw std::invalid_argument("image margin must be finite and >= 0");
  if (!(std::isfinite(sensor_depth_weight) && sensor_depth_weight >= 0))
    throw std::invalid_argument("sensor depth weight must be finite and >= 0");
  if (!(std::isfinite(gauge.sigma_rot) && gauge.sigma_rot >= 0))
    throw std::invalid_argument("gauge rotation sigma must be finite and >= 0");
  if (!(std::isfinite(gauge.sigma_trans) && gauge.sigma_trans >= 0))
    throw std::invalid_argument("gauge translation sigma must be finite and >= 0");
  if (!(std::isfinite(depth_info_eps) && depth_info_eps >= 0))
    throw std::invalid_argument("depth information threshold must be finite and >= 0");
}

}  // namespace dbacov
