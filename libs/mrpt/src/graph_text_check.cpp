// checkGraphText: the lines of an MRPT text graph that MRPT's loader would misread silently
// (refused instead). MRPT 2.5 turns an edge whose information is missing, too short, NaN/inf or not
// a number into an identity information matrix with a warning, drops self-edges and whatever
// follows a NUL byte, and node ids beyond 32 bits alias other nodes in dbacov's int ids: refuse
// them, naming file, line and edge.
#include <cerrno>
#include <climits>
#include <cmath>
#include <cstdlib>
#include <fstream>
#include <sstream>
#include <string>
#include <vector>

#include "dbacov/core/errors.h"
#include "dbacov/mrpt/pose_graph_io.h"

namespace dbacov::mrpt_bridge {
namespace {

/// Node id token: a decimal integer in [0, INT_MAX].
bool parseId(const std::string& t, long long* id) {
  if (t.empty() || t.find_first_not_of("0123456789") != std::string::npos) return false;
  errno = 0;
  *id = std::strtoll(t.c_str(), nullptr, 10);
  return errno == 0;
}

bool parseFinite(const std::string& t) {
  char* end = nullptr;
  errno = 0;
  const double v = std::strtod(t.c_str(), &end);
  return end && *end == '\0' && !t.empty() && errno != ERANGE && std::isfinite(v);
}

}  // namespace

void checkNodeId(unsigned long long id, const std::string& where) {
  if (id > static_cast<unsigned long long>(INT_MAX))
    throw InputError(where + ": node id " + std::to_string(id) +
                     " is beyond the ids dbacov handles (0 to 2147483647): it would alias "
                     "another node; renumber the graph's nodes");
}

void checkGraphText(const std::string& path) {
  std::ifstream in(path);
  if (!in) return;  // MRPT's loader reports it
  std::string line;
  for (long long n = 1; std::getline(in, line); ++n) {
    if (const auto nul = line.find('\0'); nul != std::string::npos)
      throw InputError(
          path + ":" + std::to_string(n) + ": a NUL byte at column " + std::to_string(nul + 1) +
          ": a text graph holds no NUL; MRPT's loader would drop the rest of the line");
    std::istringstream ls(line);
    std::vector<std::string> t;
    for (std::string x; ls >> x;) t.push_back(x);
    if (t.empty() || t[0][0] == '#') continue;
    const std::string where = path + ":" + std::to_string(n);
    std::size_t ids = 0, pose = 0;
    if (t[0] == "VERTEX_SE3:QUAT")
      ids = 1, pose = 7;
    else if (t[0] == "VERTEX3")
      ids = 1, pose = 6;
    else if (t[0] == "EDGE_SE3:QUAT")
      ids = 2, pose = 7;
    else if (t[0] == "EDGE3")
      ids = 2, pose = 6;
    else if (t[0] == "FIX")
      ids = 1;
    else
      continue;  // other tags: MRPT's loader decides
    const bool edge = ids == 2;
    const std::size_t expected = 1 + ids + pose + (edge ? 21 : 0);
    const std::string what =
        edge && t.size() >= 3 ? where + ": edge " + t[1] + " -> " + t[2] : where + ": " + t[0];
    if (t.size() != expected)
      throw InputError(what + ": expected " + std::to_string(expected - 1) + " values after " +
                       t[0] + " (" + (ids == 2 ? "from, to" : "node id") +
                       (pose ? ", " + std::to_string(pose) + " pose values" : std::string()) +
                       (edge ? ", 21 information entries" : "") + "), found " +
                       std::to_string(t.size() - 1));
    long long id[2] = {0, 0};
    for (std::size_t i = 1; i <= ids; ++i) {
      if (!parseId(t[i], &id[i - 1]))
        throw InputError(what + ": node id '" + t[i] + "' is not a non-negative integer");
      checkNodeId(static_cast<unsigned long long>(id[i - 1]), what);
    }
    if (edge && id[0] == id[1])
      throw InputError(what + ": joins node " + std::to_string(id[0]) +
                       " to itself; an edge needs two nodes (MRPT's loader drops it silently)");
    for (std::size_t i = 1 + ids; i < t.size(); ++i)
      if (!parseFinite(t[i])) {
        const bool info = i >= 1 + ids + pose;
        throw InputError(what + ": " +
                         (info ? "information entry " + std::to_string(i - ids - pose)
                               : "pose value " + std::to_string(i - ids)) +
                         " is '" + t[i] + "', expected a finite number");
      }
  }
}

}  // namespace dbacov::mrpt_bridge
