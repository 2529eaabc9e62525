#include "dbacov/mrpt/pose_graph_io.h"

#include <array>
#include <cstdio>

#include <mrpt/io/CFileInputStream.h>
#include <mrpt/io/CFileOutputStream.h>
#include <mrpt/serialization/CArchive.h>

#include "dbacov/io/atomic_file.h"
#include "dbacov/mrpt/mrpt_errors.h"
#include "dbacov/mrpt/pose_conversion.h"

namespace dbacov::mrpt_bridge {
namespace {

/// The matrix slots that MRPT 2.5.8's EDGE_SE3:QUAT loader fills, in file order.
constexpr std::array<std::pair<int, int>, 21> kMrptSlots{
    {{0, 0}, {0, 1}, {0, 2}, {0, 5}, {0, 4}, {0, 3}, {1, 1}, {1, 2}, {1, 5}, {1, 4}, {1, 3},
     {2, 2}, {2, 5}, {2, 4}, {2, 3}, {5, 5}, {5, 4}, {5, 3}, {4, 4}, {4, 3}, {3, 3}}};

std::string num(double v) {
  if (v == 0) v = 0.0;  // no "-0"
  char buf[32];
  std::snprintf(buf, sizeof buf, "%.17g", v);
  return buf;
}

std::string poseText(const Eigen::Isometry3d& T) {
  const Eigen::Matrix<double, 7, 1> tq = poseToTQ(T);
  std::string s;
  for (int i = 0; i < 7; ++i) s += (i ? " " : "") + num(tq[i]);
  return s;
}

Matrix6d toEigen(const mrpt::math::CMatrixDouble66& m) {
  Matrix6d M;
  for (int r = 0; r < 6; ++r)
    for (int c = 0; c < 6; ++c) M(r, c) = m(r, c);
  return M;
}

}  // namespace

std::vector<double> informationToText(const Matrix6d& I, GraphTextLayout layout) {
  std::vector<double> v;
  if (layout == GraphTextLayout::Mrpt258) {
    for (const auto& [r, c] : kMrptSlots) v.push_back(I(r, c));
  } else {
    Vector6d d;
    d << 1, 1, 1, 2, 2, 2;
    const Matrix6d G = d.asDiagonal() * I * d.asDiagonal();
    for (int r = 0; r < 6; ++r)
      for (int c = r; c < 6; ++c) v.push_back(G(r, c));
  }
  return v;
}

mrpt::graphs::CNetworkOfPoses3DInf toNetwork(const PoseGraph& g) {
  mrpt::graphs::CNetworkOfPoses3DInf net;
  for (const auto& [id, T] : g.nodes) net.nodes[id] = toCPose3D(T);
  if (!g.nodes.empty()) net.root = g.nodes.begin()->first;
  for (const PoseGraphEdge& e : g.edges) {
    mrpt::poses::CPose3DPDFGaussianInf edge;
    edge.mean = toCPose3D(e.Z);
    for (int r = 0; r < 6; ++r)
      for (int c = 0; c < 6; ++c) edge.cov_inv(r, c) = e.information(r, c);
    net.insertEdge(e.from, e.to, edge);
  }
  return net;
}

PoseGraph fromNetwork(const mrpt::graphs::CNetworkOfPoses3DInf& net, const std::string& source) {
  PoseGraph g;
  for (const auto& [id, p] : net.nodes) {
    checkNodeId(id, source);
    g.nodes[static_cast<int>(id)] = fromCPose3D(p);
  }
  for (const auto& [ids, edge] : net.edges) {
    for (const auto id : {ids.first, ids.second})
      checkNodeId(
          id, source + ": edge " + std::to_string(ids.first) + " -> " + std::to_string(ids.second));
    PoseGraphEdge e;
    e.from = static_cast<int>(ids.first);
    e.to = static_cast<int>(ids.second);
    e.Z = fromCPose3D(edge.mean);
    e.information = toEigen(edge.cov_inv);
    g.edges.push_back(e);
  }
  return g;
}

void writeGraphBinary(const std::string& path, const PoseGraph& graph) {
  io::AtomicOutputFile file(path);
  {
    mrpt::io::CFileOutputStream out;
    if (!out.open(file.writePath())) throw InputError(path + ": cannot open the temporary output");
    try {
      auto arch = mrpt::serialization::archiveFrom(out);
      arch << toNetwork(graph);
    } catch (const std::exception& e) {  // e.g. disk full
      throw InputError(path + ": cannot write the graph: " + conciseMrptMessage(e.what()));
    }
  }
  file.commit();
}

mrpt::graphs::CNetworkOfPoses3DInf readGraphBinary(const std::string& path) {
  mrpt::io::CFileInputStream in;
  if (!in.open(path)) throw InputError(path + ": cannot open for reading");
  mrpt::graphs::CNetworkOfPoses3DInf net;
  try {
    auto arch = mrpt::serialization::archiveFrom(in);
    arch >> net;
  } catch (const std::exception& e) {
    throw InputError(path + ": not a binary CNetworkOfPoses3DInf (" + conciseMrptMessage(e.what()) +
                     ")");
  }
  return net;
}

void writeGraphText(const std::string& path, const PoseGraph& g, GraphTextLayout layout) {
  io::writeFileAtomically(path, [&](std::ostream& os) {
    for (const auto& [id, T] : g.nodes)
      os << "VERTEX_SE3:QUAT " << id << ' ' << poseText(T) << '\n';
    if (!g.nodes.empty()) os << "FIX " << g.nodes.begin()->first << '\n';
    for (const PoseGraphEdge& e : g.edges) {
      os << "EDGE_SE3:QUAT " << e.from << ' ' << e.to << ' ' << poseText(e.Z);
      for (double v : informationToText(e.information, layout)) os << ' ' << num(v);
      os << '\n';
    }
  });
}

mrpt::graphs::CNetworkOfPoses3DInf readGraphMrptText(const std::string& path) {
  checkGraphText(path);  // what MRPT's loader would misread silently
  mrpt::graphs::CNetworkOfPoses3DInf net;
  try {
    net.loadFromTextFile(path);
  } catch (const std::exception& e) {
    throw InputError(path + ": cannot load the text graph (" + conciseMrptMessage(e.what()) + ")");
  }
  return net;
}

}  // namespace dbacov::mrpt_bridge
