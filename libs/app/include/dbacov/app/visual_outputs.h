// The picture outputs of `dba-covariance`: the 3D scene (--scene, --snapshot) and the figures
// (--plots). Both show the whole processed sequence: each keyframe once, from the snapshot that
// SequenceHistory chooses (the last one where it is not a gauge keyframe; sequence_history.h).
#pragma once

#include <cstdint>
#include <map>
#include <memory>
#include <string>
#include <vector>

#include <Eigen/Core>

#include "dbacov/app/outputs.h"
#include "dbacov/app/plots.h"
#include "dbacov/app/sequence_history.h"

namespace dbacov::mrpt_bridge {
class ScenePainter;
struct SceneContent;
}  // namespace dbacov::mrpt_bridge

namespace dbacov::app {

struct SceneOutputOptions {
  std::string scene_path;  ///< --scene OUT.3Dscene (COpenGLScene::saveToFile)
  std::string png_path;    ///< --snapshot OUT.png: the final picture
  int every = 0;  ///< --snapshot-every K: also OUT_<label>.png after every K-th processed snapshot
  int width = 1280, height = 720;  ///< --snapshot-size WxH
  double exaggeration = 0;         ///< --scene-exaggeration F (ellipsoid size factor; 0 = auto)
  std::string up = "-y";           ///< --scene-up: world axis shown up (±x, ±y, ±z)
  bool point_cloud = false;        ///< --point-cloud: points from the inverse depths
  int point_stride = 4;            ///< --point-stride N: every N-th pixel in x and y

  bool enabled() const { return !scene_path.empty() || !png_path.empty(); }
  /// World axis of `up` as a vector; std::invalid_argument for anything but ±x, ±y, ±z.
  Eigen::Vector3d upAxis() const;
  /// Throws std::invalid_argument for contradicting or out-of-range values.
  void validate() const;
};

/// `--scene` / `--snapshot`: the scene of SceneContent (dbacov/mrpt/scene.h) over the processed
/// sequence: ground grid, trajectory, frustums, 3-sigma world position ellipsoids (exaggerated,
/// stated in the legend), co-visible pairs, optionally the point cloud. The PNG is rendered
/// offscreen with the camera fitted to the content; the `.3Dscene` stores the same camera. Every
/// file appears at commit(): the --snapshot-every pictures are rendered as the snapshots come and
/// queued until then (io::DeferredFiles).
class SceneSink final : public OutputSink {
 public:
  /// Creates the offscreen renderer when a picture is wanted (InputError when EGL is unavailable)
  /// and checks that the output directories are writable.
  explicit SceneSink(SceneOutputOptions options);
  ~SceneSink() override;
  void add(const Snapshot& snapshot, const DbaCovariance& cov) override;
  void commit() override;

  /// OUT_<label>.png for OUT.png (label zero-padded to six digits; the extension is kept).
  static std::string framePath(const std::string& png_path, std::int64_t label);

 private:
  mrpt_bridge::SceneContent content(const std::string& headline) const;
  /// Renders the scene; writes `png` and `scene` (when not empty) or, for a frame of
  /// --snapshot-every, queues the PNG in frames_ (written by commit()).
  void render(const std::string& headline, const std::string& png, const std::string& scene,
              bool frame);

  SceneOutputOptions options_;
  SequenceHistory history_;
  Eigen::Vector4d intrinsics_ = Eigen::Vector4d::Ones();
  int H_ = 1, W_ = 1;
  std::map<double, std::vector<Eigen::Vector3f>> points_;  ///< tstamp → world points
  std::unique_ptr<mrpt_bridge::ScenePainter> painter_;     ///< through the MRPT bridge
  std::unique_ptr<io::DeferredFiles> frames_;  ///< --snapshot-every pictures, until commit()
  std::int64_t last_label_ = 0;
  std::size_t processed_ = 0;
};

/// `--plots DIR`: the figures of plots.h. Needs depth variances (for the depth maps).
class PlotsSink final : public OutputSink {
 public:
  /// Checks that gnuplot with pngcairo runs and that DIR can be created (InputError otherwise);
  /// DIR is created by commit().
  explicit PlotsSink(std::string dir);
  void add(const Snapshot& snapshot, const DbaCovariance& cov) override;
  void commit() override;
  bool needsDepthVariances() const override { return true; }

 private:
  std::string dir_;
  SequenceHistory history_;
  std::map<double, DepthMaps> maps_;  ///< tstamp → maps from the keyframe's chosen snapshot
};

/// Points of keyframe k of `s` from its inverse depths, in world coordinates (T_wc of the
/// snapshot): pixels (x, y) with x, y ≡ stride/2 (mod stride), with a finite d > 0 and a depth at
/// most 5× the keyframe's median depth (DROID clamps far pixels at d = 0.001: depth 1000).
std::vector<Eigen::Vector3f> keyframePoints(const Snapshot& s, int k, const Eigen::Isometry3d& T_wc,
                                            int stride);

}  // namespace dbacov::app
