// The implementation of the MRPT bridge (bridge.h) on top of the MRPT-facing files of this
// library; mrptBridge() (api/bridge_loader.cpp) finds it through the C entry point at the end.
#include "levmarq_node_index.h"  // before MRPT's levmarq: its free-node look-up

#include <mrpt/graphslam/levmarq.h>
#include <mrpt/obs/CObservationRobotPose.h>
#include <mrpt/obs/CSensoryFrame.h>

#include "dbacov/core/errors.h"
#include "dbacov/mrpt/bridge.h"
#include "dbacov/mrpt/mrpt_errors.h"
#include "dbacov/mrpt/observation_dba_snapshot.h"
#include "dbacov/mrpt/pose_conversion.h"
#include "dbacov/mrpt/pose_graph_io.h"
#include "dbacov/mrpt/rawlog_io.h"
#include "dbacov/mrpt/scene.h"
#include "dbacov/mrpt/scene_render.h"

namespace dbacov::mrpt_bridge {
namespace {

class PoseRawlogWriterImpl final : public PoseRawlogWriter {
 public:
  explicit PoseRawlogWriterImpl(const std::string& path) : writer_(path) {}
  void write(const PoseRecord& r) override {
    mrpt::obs::CObservationRobotPose obs;
    obs.pose = toPoseGaussian(r.T_wc, r.Sigma);  // std::domain_error at gimbal lock
    obs.timestamp = mrpt::Clock::fromDouble(r.time);
    obs.sensorLabel = r.label;
    writer_.write(obs);
  }
  void commit() override { writer_.commit(); }
  std::size_t count() const override { return writer_.count(); }

 private:
  RawlogWriter writer_;
};

class SnapshotRawlogWriterImpl final : public SnapshotRawlogWriter {
 public:
  explicit SnapshotRawlogWriterImpl(const std::string& path) : writer_(path) {}
  void write(Snapshot s, double time, const std::string& label) override {
    CObservationDbaSnapshot obs;
    obs.timestamp = mrpt::Clock::fromDouble(time);
    obs.sensorLabel = label;
    obs.snapshot = std::move(s);
    writer_.write(obs);
  }
  void commit() override { writer_.commit(); }
  std::size_t count() const override { return writer_.count(); }

 private:
  RawlogWriter writer_;
};

class SnapshotRawlogReaderImpl final : public SnapshotRawlogReader {
 public:
  SnapshotRawlogReaderImpl(const std::string& path, std::int64_t first_index)
      : reader_(path, first_index) {}
  bool next(Snapshot* out) override { return reader_.next(out); }
  std::size_t objectsRead() const override { return reader_.objectsRead(); }

 private:
  RawlogSnapshotReader reader_;
};

class ScenePainterImpl final : public ScenePainter {
 public:
  ScenePainterImpl(int width, int height, bool render) : width_(width), height_(height) {
    if (render) renderer_ = std::make_unique<SceneRenderer>(width, height);
  }
  std::vector<unsigned char> paint(const SceneContent& content, const SceneStyle& style,
                                   const std::string& scene_path,
                                   const std::string& png_name) override {
    auto scene = buildScene(content, style);
    const SceneView view = fitView(content, style, width_, height_);
    applyView(*scene, view);
    if (!scene_path.empty()) saveSceneFile(*scene, scene_path);
    if (png_name.empty() || !renderer_) return {};
    return encodePng(renderer_->render(*scene, view), png_name);
  }

 private:
  int width_, height_;
  std::unique_ptr<SceneRenderer> renderer_;
};

class BridgeImpl final : public Bridge {
 public:
  std::unique_ptr<PoseRawlogWriter> createPoseRawlog(const std::string& path) const override {
    return std::make_unique<PoseRawlogWriterImpl>(path);
  }

  std::vector<PoseRecord> readPoseRawlog(const std::string& path,
                                         const std::string& label) const override {
    RawlogReader reader(path);
    std::vector<PoseRecord> rows;
    auto handle = [&](const mrpt::serialization::CSerializable::Ptr& obj, std::size_t entry) {
      const auto obs = std::dynamic_pointer_cast<mrpt::obs::CObservationRobotPose>(obj);
      if (!obs || (!label.empty() && obs->sensorLabel != label)) return;
      PoseRecord r;
      r.entry = entry;
      r.label = obs->sensorLabel;
      r.time = mrpt::Clock::toDouble(obs->timestamp);
      r.T_wc = fromCPose3D(obs->pose.mean);
      Matrix6d C;
      for (int a = 0; a < 6; ++a)
        for (int b = 0; b < 6; ++b) C(a, b) = obs->pose.cov(a, b);
      try {
        r.Sigma = yprToTangentCovariance(r.T_wc, C);
      } catch (const std::domain_error& e) {
        throw InputError(path + ": entry " + std::to_string(entry) + ": " + e.what());
      }
      if (!r.Sigma.allFinite() || !r.T_wc.matrix().allFinite())
        throw InputError(path + ": entry " + std::to_string(entry) +
                         ": non-finite pose or covariance");
      rows.push_back(r);
    };
    for (auto obj = reader.next(); obj; obj = reader.next()) {
      const std::size_t entry = reader.count() - 1;
      if (auto sf = std::dynamic_pointer_cast<mrpt::obs::CSensoryFrame>(obj)) {
        for (const auto& o : *sf) handle(o, entry);
      } else {
        handle(obj, entry);
      }
    }
    return rows;
  }

  void checkPoseRecord(const Eigen::Isometry3d& T_wc) const override { tangentToYprJacobian(T_wc); }

  std::unique_ptr<SnapshotRawlogWriter> createSnapshotRawlog(
      const std::string& path) const override {
    return std::make_unique<SnapshotRawlogWriterImpl>(path);
  }

  std::unique_ptr<SnapshotRawlogReader> openSnapshotRawlog(
      const std::string& path, std::int64_t first_index) const override {
    return std::make_unique<SnapshotRawlogReaderImpl>(path, first_index);
  }

  void writeGraphFiles(const std::string& prefix, const PoseGraph& g) const override {
    writeGraphBinary(prefix + ".graphbin", g);
    writeGraphText(prefix + ".graph", g, GraphTextLayout::Mrpt258);
    writeGraphText(prefix + ".g2o", g, GraphTextLayout::G2o);
  }

  PoseGraph readGraph(const std::string& path, bool mrpt_text) const override {
    return fromNetwork(mrpt_text ? readGraphMrptText(path) : readGraphBinary(path), path);
  }

  LevmarqResult optimizeLevmarq(PoseGraph& g, int root, std::size_t max_iterations) const override {
    mrpt::graphs::CNetworkOfPoses3DInf net = toNetwork(g);
    net.root = root;
    mrpt::graphslam::TResultInfoSpaLevMarq info;
    mrpt::containers::yaml params;
    params["max_iterations"] = max_iterations;
    std::set<mrpt::graphs::TNodeID> free;  // what MRPT builds itself without this argument
    for (const auto& [id, pose] : net.nodes)
      if (id != net.root) free.insert(free.end(), id);
    try {
      const FreeNodeIndex index(free);
      mrpt::graphslam::optimize_graph_spa_levmarq(net, info, &free, params);
    } catch (const std::exception& e) {
      throw NumericalError("MRPT's optimizer failed: " + conciseMrptMessage(e.what()), {});
    }
    for (auto& [id, T] : g.nodes) T = fromCPose3D(net.nodes.at(id));
    return LevmarqResult{info.num_iters};
  }

  std::unique_ptr<ScenePainter> createScenePainter(int width, int height,
                                                   bool render) const override {
    return std::make_unique<ScenePainterImpl>(width, height, render);
  }
};

}  // namespace
}  // namespace dbacov::mrpt_bridge

/// The entry point that api/bridge_loader.cpp looks up with dlsym.
extern "C" __attribute__((visibility("default"))) const dbacov::mrpt_bridge::Bridge*
dbacov_mrpt_bridge_v1() {
  static const dbacov::mrpt_bridge::BridgeImpl bridge;
  return &bridge;
}
