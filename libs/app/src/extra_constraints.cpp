#include "dbacov/app/extra_constraints.h"

#include <climits>
#include <cmath>
#include <fstream>
#include <sstream>

namespace dbacov::app {
namespace {

struct LineParser {
  std::string where;  // "file:line"
  [[noreturn]] void fail(const std::string& what) const { throw InputError(where + ": " + what); }

  int node(const std::string& tok, const std::map<int, Eigen::Isometry3d>& nodes) const {
    std::size_t used = 0;
    long v = -1;
    try {
      v = std::stol(tok, &used);
    } catch (const std::exception&) {
    }
    if (used != tok.size() || v < 0) fail("'" + tok + "' is not a node id");
    if (v > INT_MAX)
      fail("node id " + tok +
           " is beyond the ids dbacov handles (0 to 2147483647): it would alias another node");
    if (!nodes.count(static_cast<int>(v))) fail("node " + tok + " is not in the graph");
    return static_cast<int>(v);
  }

  std::vector<double> numbers(const std::vector<std::string>& toks, std::size_t from) const {
    std::vector<double> v;
    for (std::size_t i = from; i < toks.size(); ++i) {
      std::size_t used = 0;
      double x = NAN;
      try {
        x = std::stod(toks[i], &used);
      } catch (const std::exception&) {
      }
      if (used != toks[i].size()) fail("'" + toks[i] + "' is not a number");
      if (!std::isfinite(x)) fail("value '" + toks[i] + "' is not finite");
      v.push_back(x);
    }
    return v;
  }

  /// Pose from 7 numbers and the information of the covariance in the remaining 2 or 21.
  void poseAndInformation(const std::vector<double>& v, Eigen::Isometry3d* T,
                          Matrix6d* info) const {
    if (v.size() != 7 + 2 && v.size() != 7 + 21)
      fail("expected a pose (7 numbers) and a covariance (2 sigmas or 21 entries), found " +
           std::to_string(v.size()) + " numbers");
    if (Eigen::Vector4d(v[3], v[4], v[5], v[6]).norm() < 1e-9) fail("the quaternion is zero");
    *T = poseFromTQ(v.data());
    Matrix6d C = Matrix6d::Zero();
    if (v.size() == 9) {
      if (!(v[7] > 0 && v[8] > 0)) fail("sigmas must be > 0");
      C.diagonal() << Eigen::Vector3d::Constant(v[7] * v[7]),
          Eigen::Vector3d::Constant(v[8] * v[8]);
    } else {
      int k = 7;
      for (int r = 0; r < 6; ++r)
        for (int c = r; c < 6; ++c) C(r, c) = C(c, r) = v[k++];
    }
    if (!informationOf(C, info)) fail("the covariance is not positive definite");
  }
};

}  // namespace

ExtraConstraints readExtraConstraints(const std::string& path,
                                      const std::map<int, Eigen::Isometry3d>& nodes) {
  std::ifstream in(path);
  if (!in) throw InputError(path + ": cannot open the constraints file");
  ExtraConstraints out;
  std::map<int, int> absolute_line;  // node → line of its absolute prior
  int line_no = 0;
  for (std::string line; std::getline(in, line);) {
    ++line_no;
    if (const auto nul = line.find('\0'); nul != std::string::npos)
      throw InputError(path + ":" + std::to_string(line_no) + ": a NUL byte at column " +
                       std::to_string(nul + 1) +
                       ": a constraints file is text; the rest of the line would be lost");
    if (const auto hash = line.find('#'); hash != std::string::npos) line.resize(hash);
    std::istringstream ls(line);
    std::vector<std::string> tok;
    for (std::string t; ls >> t;) tok.push_back(t);
    if (tok.empty()) continue;
    const LineParser p{path + ":" + std::to_string(line_no)};
    if (tok[0] == "relative") {
      if (tok.size() < 3) p.fail("'relative' needs FROM TO, a pose and a covariance");
      PoseGraphEdge e;
      e.from = p.node(tok[1], nodes);
      e.to = p.node(tok[2], nodes);
      if (e.from == e.to) p.fail("a relative constraint needs two different nodes");
      p.poseAndInformation(p.numbers(tok, 3), &e.Z, &e.information);
      out.relative.push_back(e);
    } else if (tok[0] == "absolute") {
      if (tok.size() < 2) p.fail("'absolute' needs ID, a pose and a covariance");
      AbsolutePrior a;
      a.node = p.node(tok[1], nodes);
      if (const auto [it, fresh] = absolute_line.emplace(a.node, line_no); !fresh)
        p.fail("node " + tok[1] + " already has an absolute prior (line " +
               std::to_string(it->second) +
               "): give one prior per node (two would be merged silently into their "
               "information-weighted mean)");
      p.poseAndInformation(p.numbers(tok, 2), &a.T_wc, &a.information);
      out.absolute.push_back(a);
    } else {
      p.fail("unknown constraint '" + tok[0] + "', expected 'relative' or 'absolute'");
    }
  }
  if (in.bad()) throw InputError(path + ": read error");
  return out;
}

}  // namespace dbacov::app
