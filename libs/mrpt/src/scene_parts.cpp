// Parts of the scene that are not geometry of the estimate: legend, point-cloud colours, numbers.
#include <algorithm>
#include <cmath>
#include <cstdio>

#include "scene_internal.h"

namespace dbacov::mrpt_bridge::detail {

double median(std::vector<double> v) {
  return quantile(std::move(v), 0.5);
}

double quantile(std::vector<double> v, double q) {
  const auto i = static_cast<std::size_t>(std::lround(q * static_cast<double>(v.size() - 1)));
  std::nth_element(v.begin(), v.begin() + static_cast<std::ptrdiff_t>(i), v.end());
  return v[i];
}

double niceStep(double x) {
  const double decade = std::pow(10.0, std::floor(std::log10(x)));
  for (double m : {1.0, 2.0, 5.0, 10.0})
    if (m * decade >= x * (1 - 1e-12)) return m * decade;
  return 10 * decade;
}

mrpt::opengl::CPointCloudColoured::Ptr makePointCloud(const std::vector<Eigen::Vector3f>& points,
                                                      const Eigen::Matrix3d& R_dw) {
  std::vector<double> height;
  height.reserve(points.size());
  for (const auto& p : points) height.push_back(R_dw.row(2).dot(p.cast<double>()));
  const double lo = quantile(height, 0.05), hi = quantile(height, 0.95);
  auto cloud = mrpt::opengl::CPointCloudColoured::Create();
  cloud->setName("points");
  cloud->setPointSize(2.5f);
  cloud->reserve(points.size());
  for (std::size_t i = 0; i < points.size(); ++i) {
    // Low = slate blue, high = sand: a muted ramp that keeps frustums and ellipsoids readable.
    const double t = hi > lo ? std::clamp((height[i] - lo) / (hi - lo), 0.0, 1.0) : 0.5;
    const auto mix = [t](double a, double b) {
      return static_cast<float>((a + t * (b - a)) / 255);
    };
    cloud->push_back(points[i].x(), points[i].y(), points[i].z(), mix(90, 215), mix(110, 190),
                     mix(160, 130));
  }
  return cloud;
}

void addLegend(mrpt::opengl::COpenGLScene& scene, const std::vector<std::string>& caption,
               const SceneStyle& s, int ellipsoids, const std::string& grid_line) {
  struct Line {
    std::string text;
    mrpt::img::TColorf colour;
  };
  const mrpt::img::TColorf ink(0.1f, 0.1f, 0.1f);
  std::vector<Line> lines;
  for (const auto& c : caption) lines.push_back({c, ink});
  lines.push_back({"frustums: keyframes (blue), newest (red), gauge (grey)",
                   mrpt::img::TColorf(0.12f, 0.31f, 0.78f)});
  if (ellipsoids > 0)
    lines.push_back(
        {ellipsoidLegend(s.sigma, s.exaggeration), mrpt::img::TColorf(0.85f, 0.4f, 0.0f)});
  else
    lines.push_back({"no position covariance to draw (every keyframe fixed)", ink});
  lines.push_back({"lines: trajectory (black), co-visible pairs (green)",
                   mrpt::img::TColorf(0.2f, 0.5f, 0.2f)});
  if (!grid_line.empty()) lines.push_back({grid_line, mrpt::img::TColorf(0.45f, 0.45f, 0.45f)});

  auto vp = scene.getViewport();
  vp->setCustomBackgroundColor(mrpt::img::TColorf(1, 1, 1));
  // Softer shading than MRPT's default (ambient 0.2): translucent ellipsoids stay orange.
  vp->lightParameters().ambient = mrpt::img::TColorf(0.55f, 0.55f, 0.55f, 1.0f);
  vp->lightParameters().diffuse = mrpt::img::TColorf(0.6f, 0.6f, 0.6f, 1.0f);
  mrpt::opengl::TFontParams font;
  font.vfont_name = "sans";
  font.vfont_scale = static_cast<float>(s.legend_px);
  font.draw_shadow = true;  // a white halo keeps the legend readable over points and lines
  font.shadow_color = mrpt::img::TColorf(1, 1, 1, 1);
  for (std::size_t i = 0; i < lines.size(); ++i) {
    font.color = lines[i].colour;
    vp->addTextMessage(0.6 * s.legend_px, -(1.0 + 1.5 * static_cast<double>(i)) * s.legend_px - 4,
                       lines[i].text, i, font);
  }
}

}  // namespace dbacov::mrpt_bridge::detail
