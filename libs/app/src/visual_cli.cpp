#include "visual_cli.h"

#include <cmath>
#include <cstdio>
#include <stdexcept>

#include <CLI/CLI.hpp>

#include "engine_cli.h"

namespace dbacov::app::detail {

const char* const kVisualHelp = R"(
Pictures: every keyframe once (pose and covariance from the last snapshot in which it is not a
gauge keyframe); --scene/--snapshot draw each keyframe's frustum and the 3-sigma ellipsoid of its
world-frame position covariance R_wc * Sigma[0:3,0:3] * R_wc^T (offscreen, no X server); --plots
DIR writes the figures (gnuplot) and their values.)";

void addVisualOptions(CLI::App& cli, VisualCli& v) {
  cli.add_option("--scene", v.scene.scene_path,
                 "Write the 3D scene of the sequence (.3Dscene, MRPT COpenGLScene)");
  cli.add_option("--snapshot", v.scene.png_path,
                 "Render the scene offscreen into this PNG (after the last snapshot)");
  cli.add_option("--snapshot-every", v.scene.every,
                 "Also render OUT_<snapshot>.png after every K-th processed snapshot")
      ->check(detail::positiveNumber());
  cli.add_option("--snapshot-size", v.size, "Picture size WxH in pixels (default 1280x720)");
  cli.add_option(
      "--scene-exaggeration", v.exaggeration,
      "Scale of the 3-sigma position ellipsoids: a factor, or auto (default: a 1-2-5 value "
      "that makes them about 0.4 x the keyframe spacing); shown in the legend");
  cli.add_option(
         "--scene-up", v.scene.up,
         "World axis shown up: -y (default: DROID's first camera, y down), +y, -x, +x, -z, +z")
      ->check(CLI::IsMember({"+x", "-x", "+y", "-y", "+z", "-z"}));
  cli.add_flag("--point-cloud", v.scene.point_cloud,
               "Add the points of the keyframes' inverse depths to the scene");
  cli.add_option("--point-stride", v.scene.point_stride,
                 "Point cloud: every N-th pixel in x and y (default 4)")
      ->check(detail::positiveNumber());
  cli.add_option("--plots", v.plots_dir,
                 "Write the figures (PNG, gnuplot) and their values into this directory");
}

void finishVisualOptions(VisualCli& v) {
  int w = 0, h = 0;
  char end = 0;
  if (std::sscanf(v.size.c_str(), "%dx%d%c", &w, &h, &end) != 2)
    throw std::invalid_argument("--snapshot-size '" + v.size + "': expected WxH, e.g. 1280x720");
  v.scene.width = w;
  v.scene.height = h;
  if (v.exaggeration == "auto") {
    v.scene.exaggeration = 0;
  } else {
    std::size_t used = 0;
    double f = 0;
    try {
      f = std::stod(v.exaggeration, &used);
    } catch (const std::exception&) {
      used = 0;
    }
    if (used != v.exaggeration.size() || !(f > 0) || !std::isfinite(f))
      throw std::invalid_argument("--scene-exaggeration '" + v.exaggeration +
                                  "': expected a positive number or auto");
    v.scene.exaggeration = f;
  }
  v.scene.validate();
}

void appendVisualSinks(std::vector<std::unique_ptr<OutputSink>>& sinks, const VisualCli& v) {
  if (v.scene.enabled()) sinks.push_back(std::make_unique<SceneSink>(v.scene));
  if (!v.plots_dir.empty()) sinks.push_back(std::make_unique<PlotsSink>(v.plots_dir));
}

}  // namespace dbacov::app::detail
