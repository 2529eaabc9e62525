// The MRPT bridge as the rest of dbacov sees it: an interface without a single MRPT type, so that
// the apps and the Python module include no MRPT header and load no MRPT library until a rawlog,
// a pose graph or a scene is asked for. mrptBridge() loads libdbacov_mrpt.so (the implementation,
// bridge_impl.cpp, which also registers CObservationDbaSnapshot with MRPT) on first use with
// dlopen, from the directory of the library that holds mrptBridge() itself, and fails with
// InputError naming the file and the loader's reason when it cannot.
//
// Conventions (conventions §3, §6): poses are T_wc with the tangent [ρ; φ] covariance of the right
// perturbation; the conversion to and from MRPT's [x y z yaw pitch roll] covariance is
// mrpt/pose_conversion.h's. Times are seconds since 1970 (MRPT's Clock; 0 = "no time").
#pragma once

#include <cstddef>
#include <cstdint>
#include <memory>
#include <set>
#include <string>
#include <vector>

#include <Eigen/Geometry>

#include "dbacov/core/pose_graph.h"
#include "dbacov/core/se3.h"
#include "dbacov/core/snapshot.h"
#include "dbacov/mrpt/scene_content.h"

namespace dbacov::mrpt_bridge {

/// A pose with its tangent covariance: one CObservationRobotPose (CPose3DPDFGaussian) of a pose
/// rawlog.
struct PoseRecord {
  double time = 0;  ///< seconds since 1970
  Eigen::Isometry3d T_wc = Eigen::Isometry3d::Identity();
  Matrix6d Sigma = Matrix6d::Zero();  ///< tangent covariance (conventions §3)
  std::string label;                  ///< sensorLabel
  std::size_t entry = 0;              ///< reading: the rawlog entry it came from
};

/// Writes PoseRecords into a gz-compressed rawlog that appears at its path only on commit().
class PoseRawlogWriter {
 public:
  virtual ~PoseRawlogWriter() = default;
  /// Throws std::domain_error when the pose is at gimbal lock (MRPT's yaw/pitch/roll cannot hold
  /// its covariance), InputError when the record cannot be written (then the writer is failed).
  virtual void write(const PoseRecord& record) = 0;
  /// Closes the stream and replaces the file. Throws InputError on failure.
  virtual void commit() = 0;
  virtual std::size_t count() const = 0;
};

/// Writes DBA snapshots (CObservationDbaSnapshot) into a gz-compressed rawlog, likewise.
class SnapshotRawlogWriter {
 public:
  virtual ~SnapshotRawlogWriter() = default;
  /// Appends the snapshot (moved in: it may be large) with observation time `time` and sensorLabel
  /// `label`. Throws InputError.
  virtual void write(Snapshot snapshot, double time, const std::string& label) = 0;
  virtual void commit() = 0;
  virtual std::size_t count() const = 0;
};

/// The DBA snapshots of a rawlog, one at a time (rawlog_io.h's RawlogSnapshotReader).
class SnapshotRawlogReader {
 public:
  virtual ~SnapshotRawlogReader() = default;
  /// The next snapshot (`source` = "<path>#<entry>", `index` = first_index + count, values not
  /// validated); false at the end. Throws InputError naming the file and entry.
  virtual bool next(Snapshot* out) = 0;
  virtual std::size_t objectsRead() const = 0;
};

/// Draws scenes (scene.h) and renders them offscreen (scene_render.h).
class ScenePainter {
 public:
  virtual ~ScenePainter() = default;
  /// Builds the scene with the camera fitted to the content and writes it (.3Dscene) atomically
  /// when `scene_path` is not empty; renders it into a PNG (in memory; `png_name` names it in
  /// errors) when `png_name` is not empty and the painter renders. Returns the PNG (or nothing).
  virtual std::vector<unsigned char> paint(const SceneContent& content, const SceneStyle& style,
                                           const std::string& scene_path,
                                           const std::string& png_name) = 0;
};

/// What MRPT's Levenberg-Marquardt did (optimize_graph_spa_levmarq).
struct LevmarqResult {
  std::size_t iterations = 0;
};

class Bridge {
 public:
  virtual ~Bridge() = default;

  virtual std::unique_ptr<PoseRawlogWriter> createPoseRawlog(const std::string& path) const = 0;
  /// Every CObservationRobotPose of a rawlog (alone or in CSensoryFrames) with sensorLabel `label`
  /// (empty: all), its covariance converted back to the tangent. InputError naming file and entry.
  virtual std::vector<PoseRecord> readPoseRawlog(const std::string& path,
                                                 const std::string& label) const = 0;
  /// Throws std::domain_error when a pose rawlog cannot hold this pose's covariance.
  virtual void checkPoseRecord(const Eigen::Isometry3d& T_wc) const = 0;

  virtual std::unique_ptr<SnapshotRawlogWriter> createSnapshotRawlog(
      const std::string& path) const = 0;
  virtual std::unique_ptr<SnapshotRawlogReader> openSnapshotRawlog(
      const std::string& path, std::int64_t first_index) const = 0;

  /// PREFIX.graphbin (exact), PREFIX.graph (MRPT 2.5.8's text layout), PREFIX.g2o — atomically.
  virtual void writeGraphFiles(const std::string& prefix, const PoseGraph& graph) const = 0;
  /// A .graphbin (exact) or a .graph through MRPT's own text loader (which drops the rotation
  /// off-diagonal information). InputError naming the file.
  virtual PoseGraph readGraph(const std::string& path, bool mrpt_text) const = 0;
  /// MRPT's optimize_graph_spa_levmarq on the graph, root node `root` held; the node poses are
  /// replaced by MRPT's result. NumericalError with MRPT's message when it fails.
  virtual LevmarqResult optimizeLevmarq(PoseGraph& graph, int root,
                                        std::size_t max_iterations) const = 0;

  /// A painter for width×height pictures; `render` false: it only writes scenes (no EGL).
  /// Throws InputError when offscreen rendering is unavailable.
  virtual std::unique_ptr<ScenePainter> createScenePainter(int width, int height,
                                                           bool render) const = 0;
};

/// The bridge, loaded on the first call (thread-safe). Throws InputError when libdbacov_mrpt.so
/// cannot be loaded.
const Bridge& mrptBridge();

/// Whether the bridge has been loaded in this process (tests of the start-up).
bool mrptBridgeLoaded();

}  // namespace dbacov::mrpt_bridge
