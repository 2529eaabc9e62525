#include "dbacov/app/visual_outputs.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <set>
#include <stdexcept>

#include "dbacov/app/csv_format.h"
#include "dbacov/io/atomic_file.h"
#include "dbacov/mrpt/bridge.h"
#include "gnuplot.h"
#include "plots_internal.h"

namespace dbacov::app {

Eigen::Vector3d SceneOutputOptions::upAxis() const {
  static const std::map<std::string, Eigen::Vector3d> axes{
      {"+x", Eigen::Vector3d::UnitX()}, {"-x", -Eigen::Vector3d::UnitX()},
      {"+y", Eigen::Vector3d::UnitY()}, {"-y", -Eigen::Vector3d::UnitY()},
      {"+z", Eigen::Vector3d::UnitZ()}, {"-z", -Eigen::Vector3d::UnitZ()}};
  const auto it = axes.find(up);
  if (it == axes.end())
    throw std::invalid_argument("--scene-up '" + up + "': expected +x, -x, +y, -y, +z or -z");
  return it->second;
}

void SceneOutputOptions::validate() const {
  upAxis();
  if (every < 0) throw std::invalid_argument("--snapshot-every must be >= 1");
  if (every > 0 && png_path.empty())
    throw std::invalid_argument("--snapshot-every needs --snapshot");
  if (width < 16 || height < 16 || width > 8192 || height > 8192)
    throw std::invalid_argument("--snapshot-size: each side must be within 16..8192 pixels");
  if (!(exaggeration >= 0) || !std::isfinite(exaggeration))
    throw std::invalid_argument("--scene-exaggeration must be a positive number or 'auto'");
  if (point_stride < 1) throw std::invalid_argument("--point-stride must be >= 1");
  if (point_cloud && !enabled())
    throw std::invalid_argument("--point-cloud needs --scene or --snapshot");
}

std::vector<Eigen::Vector3f> keyframePoints(const Snapshot& s, int k, const Eigen::Isometry3d& T_wc,
                                            int stride) {
  std::vector<float> d;
  for (int y = 0; y < s.H; ++y)
    for (int x = 0; x < s.W; ++x)
      if (const float v = s.disp(k, y, x); std::isfinite(v) && v > 0) d.push_back(v);
  std::vector<Eigen::Vector3f> pts;
  if (d.empty()) return pts;
  std::nth_element(d.begin(), d.begin() + static_cast<std::ptrdiff_t>(d.size() / 2), d.end());
  const double d_min = 0.2 * d[d.size() / 2];  // depth <= 5 × the median depth
  const double fx = s.intrinsics[0], fy = s.intrinsics[1], cx = s.intrinsics[2],
               cy = s.intrinsics[3];
  for (int y = stride / 2; y < s.H; y += stride)
    for (int x = stride / 2; x < s.W; x += stride) {
      const double v = s.disp(k, y, x);
      if (!std::isfinite(v) || !(v > 0) || v < d_min) continue;
      const Eigen::Vector3d p_c((x - cx) / fx / v, (y - cy) / fy / v, 1.0 / v);
      pts.push_back((T_wc * p_c).cast<float>());
    }
  return pts;
}

SceneSink::SceneSink(SceneOutputOptions options) : options_(std::move(options)) {
  options_.validate();
  // Fail before any work when an output directory is not writable (the probes are discarded).
  if (!options_.scene_path.empty()) io::AtomicOutputFile probe(options_.scene_path);
  painter_ = mrpt_bridge::mrptBridge().createScenePainter(options_.width, options_.height,
                                                          !options_.png_path.empty());
  if (!options_.png_path.empty()) {
    io::AtomicOutputFile probe(options_.png_path);
    if (options_.every > 0) {
      const std::string dir = std::filesystem::path(options_.png_path).parent_path().string();
      frames_ = std::make_unique<io::DeferredFiles>(dir.empty() ? "." : dir);
    }
  }
}

SceneSink::~SceneSink() = default;

std::string SceneSink::framePath(const std::string& png_path, std::int64_t label) {
  const std::filesystem::path p(png_path);
  char number[32];
  std::snprintf(number, sizeof number, "_%06lld", static_cast<long long>(label));
  const std::string ext = p.has_extension() ? p.extension().string() : ".png";
  return (p.parent_path() / (p.stem().string() + number + ext)).string();
}

void SceneSink::add(const Snapshot& s, const DbaCovariance& cov) {
  ++processed_;
  last_label_ = s.label();
  intrinsics_ = s.intrinsics;
  H_ = s.H;
  W_ = s.W;
  for (int k : history_.add(s, cov))
    if (options_.point_cloud)
      points_[s.tstamp[k]] = keyframePoints(s, k, cov.T_wc(k), options_.point_stride);
  if (options_.every > 0 && processed_ % static_cast<std::size_t>(options_.every) == 0)
    render("after snapshot " + std::to_string(last_label_) + " (" + std::to_string(processed_) +
               " processed): " + detail::plural(history_.numKeyframes(), "keyframe"),
           framePath(options_.png_path, last_label_), "", true);
}

void SceneSink::commit() {
  render("dba-covariance: " + detail::plural(history_.numKeyframes(), "keyframe") + " from " +
             detail::plural(history_.numSnapshots(), "snapshot") +
             " (last: " + std::to_string(last_label_) + ")",
         options_.png_path, options_.scene_path, false);
  if (frames_) frames_->commit();
}

mrpt_bridge::SceneContent SceneSink::content(const std::string& headline) const {
  mrpt_bridge::SceneContent c;
  c.intrinsics = intrinsics_;
  c.W = W_;
  c.H = H_;
  for (const KeyframeRecord& r : history_.keyframes()) {
    mrpt_bridge::SceneKeyframe kf;
    kf.name = "tstamp " + formatDouble(r.tstamp);
    kf.T_wc = r.T_wc;
    kf.Sigma = r.Sigma;
    kf.gauge = r.gauge;
    c.keyframes.push_back(kf);
    if (const auto p = points_.find(r.tstamp); p != points_.end())
      c.points.insert(c.points.end(), p->second.begin(), p->second.end());
  }
  std::set<std::pair<int, int>> pairs;
  for (const auto& [i, j] : history_.edges()) pairs.emplace(std::min(i, j), std::max(i, j));
  c.covisible.assign(pairs.begin(), pairs.end());
  c.caption = {headline, "keyframes as of their last snapshot outside the gauge"};
  return c;
}

void SceneSink::render(const std::string& headline, const std::string& png,
                       const std::string& scene_path, bool frame) {
  const mrpt_bridge::SceneContent c = content(headline);
  mrpt_bridge::SceneStyle style;
  style.exaggeration = options_.exaggeration;
  style.up = options_.upAxis();
  style.legend_px = std::max(12.0, options_.height / 48.0);
  std::vector<unsigned char> picture = painter_->paint(c, style, scene_path, png);
  if (png.empty()) return;
  if (frame) {
    frames_->add(png, std::move(picture));
    return;
  }
  io::AtomicOutputFile file(png);
  file.write(picture.data(), picture.size());
  file.commit();
}

PlotsSink::PlotsSink(std::string dir) : dir_(std::move(dir)) {
  detail::requireGnuplot();
  checkOutputDirectory(dir_, "plots directory");  // created by commit()
}

void PlotsSink::add(const Snapshot& s, const DbaCovariance& cov) {
  std::vector<int> sources = cov.sourceKeyframes();
  std::sort(sources.begin(), sources.end());
  for (int k : history_.add(s, cov)) {
    // Maps come from the same snapshot as the keyframe's covariance, or not at all.
    if (!std::binary_search(sources.begin(), sources.end(), k)) {
      maps_.erase(s.tstamp[k]);
      continue;
    }
    DepthMaps m;
    m.snapshot = s.label();
    m.keyframe = k;
    m.H = s.H;
    m.W = s.W;
    const auto first = s.disps.begin() + static_cast<std::ptrdiff_t>(k * s.pixelsPerFrame());
    m.disp.assign(first, first + static_cast<std::ptrdiff_t>(s.pixelsPerFrame()));
    m.sigma = cov.inverseDepthSigma(k);
    maps_.insert_or_assign(s.tstamp[k], std::move(m));
  }
}

void PlotsSink::commit() {
  writeSequencePlots(history_, maps_, dir_);
}

}  // namespace dbacov::app
