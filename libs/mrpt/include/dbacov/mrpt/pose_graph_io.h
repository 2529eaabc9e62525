// Pose graphs as MRPT objects and files (conventions §6): CNetworkOfPoses3DInf, its binary
// serialization, and the VERTEX_SE3:QUAT / EDGE_SE3:QUAT text formats.
//
// Information layouts of an EDGE_SE3:QUAT line (21 upper-triangular values after the pose):
//   Mrpt258 — what MRPT 2.5.8's loader reads correctly. It stores the values at the matrix slots
//             (0,0) (0,1) (0,2) (0,5) (0,4) (0,3) (1,1) (1,2) (1,5) (1,4) (1,3) (2,2) (2,5) (2,4)
//             (2,3) (5,5) (5,4) (5,3) (4,4) (4,3) (3,3) of the [t; ω] information, so the writer
//             puts each entry where the loader expects it. Caveats of that loader: the three
//             rotation–rotation off-diagonal entries land below the diagonal and are then
//             overwritten by its symmetrization (lost), and only the first edge per node pair is
//             kept. The binary format keeps everything.
//   G2o     — g2o's own EdgeSE3 convention: row-major upper triangle over its error
//             [t; q_xyz], where the quaternion's vector part is φ/2, so the information is
//             D Λ D with D = diag(1, 1, 1, 2, 2, 2).
// Both write `FIX <root>` for the lowest node.
#pragma once

#include <string>

#include <mrpt/graphs/CNetworkOfPoses.h>

#include "dbacov/core/pose_graph.h"

namespace dbacov::mrpt_bridge {

/// CNetworkOfPoses3DInf with the graph's nodes and edges; root = the lowest node id.
mrpt::graphs::CNetworkOfPoses3DInf toNetwork(const PoseGraph& graph);
/// Nodes and edges of an MRPT network (no times). Edges keep MRPT's (from, to) direction.
/// Throws InputError naming `source` for node ids beyond 2^31 - 1 (they would alias other nodes).
PoseGraph fromNetwork(const mrpt::graphs::CNetworkOfPoses3DInf& net,
                      const std::string& source = "graph");

/// MRPT's binary serialization of toNetwork(graph), written atomically.
void writeGraphBinary(const std::string& path, const PoseGraph& graph);
/// Reads a binary CNetworkOfPoses3DInf. Throws InputError naming the file.
mrpt::graphs::CNetworkOfPoses3DInf readGraphBinary(const std::string& path);

enum class GraphTextLayout { Mrpt258, G2o };
/// VERTEX_SE3:QUAT / EDGE_SE3:QUAT / FIX lines at full precision, written atomically.
void writeGraphText(const std::string& path, const PoseGraph& graph, GraphTextLayout layout);
/// MRPT's own text loader (loadFromTextFile). Throws InputError naming the file.
mrpt::graphs::CNetworkOfPoses3DInf readGraphMrptText(const std::string& path);

/// Refuses the lines of a text graph that MRPT's loader would misread silently: an edge whose
/// information is missing, too short, NaN/inf or not a number (MRPT uses the identity), a vertex
/// or edge with too few values, node ids that are not integers in [0, 2^31) (they would alias
/// other nodes). InputError "<path>:<line>: edge <from> -> <to>: ...". readGraphMrptText calls it.
void checkGraphText(const std::string& path);
/// InputError "<where>: node id <id> is beyond the ids dbacov handles ..." when id > 2^31 - 1.
void checkNodeId(unsigned long long id, const std::string& where);

/// The 21 values of an EDGE_SE3:QUAT line for information Λ (tangent [t; ω]) in a layout.
std::vector<double> informationToText(const Matrix6d& information, GraphTextLayout layout);

}  // namespace dbacov::mrpt_bridge
