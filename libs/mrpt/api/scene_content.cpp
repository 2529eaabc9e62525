#include "dbacov/mrpt/scene_content.h"

#include <cmath>
#include <cstdlib>
#include <stdexcept>

namespace dbacov::mrpt_bridge {

void SceneStyle::validate() const {
  if (!(sigma > 0) || !std::isfinite(sigma))
    throw std::invalid_argument("scene: sigma must be > 0");
  if (!(legend_px > 0) || !std::isfinite(legend_px))
    throw std::invalid_argument("scene: legend size must be > 0");
  if (!(exaggeration >= 0) || !std::isfinite(exaggeration))
    throw std::invalid_argument("scene: exaggeration must be > 0 (or 0 = auto)");
  if (!(frustum_depth >= 0) || !std::isfinite(frustum_depth))
    throw std::invalid_argument("scene: frustum depth must be > 0 (or 0 = auto)");
  int unit = 0;
  for (int i = 0; i < 3; ++i) unit += std::abs(up[i]) == 1.0 ? 1 : (up[i] == 0 ? 0 : 10);
  if (unit != 1) throw std::invalid_argument("scene: 'up' must be one of ±x, ±y, ±z");
}

}  // namespace dbacov::mrpt_bridge
