// Floating-point operations that linearizeDba's kernel performs on a snapshot (issue 8), counted
// from the kernel's arithmetic (libs/core/src/dba_kernel.cpp), per lane = pixel of a source
// keyframe processed against one edge:
//   whitened rows of both channels (transfer, projection, Jacobians, residual)   124
//   normal equations of the edge (91 products per channel, multiply + add)         364
//   depth coupling b_k, h_k, g_k                                                    56
// and per lane and source: depth elimination 3 + 3·6T, Schur update (6T)(6T+1) for the T slots
// that the source touches (itself and its edge targets). Masked lanes (invalid pixels) are
// counted too: the kernel computes them.
#pragma once

#include <algorithm>
#include <set>

#include "dbacov/core/linearization.h"
#include "dbacov/core/snapshot.h"

namespace dbacov::bench {

inline double linearizationFlops(const Snapshot& s) {
  const double HW = static_cast<double>(s.pixelsPerFrame());
  double flops = 0;
  for (int src : s.graphKeyframes()) {
    int edges = 0;
    std::set<std::int64_t> targets;
    for (int e = 0; e < s.numEdges(); ++e)
      if (s.ii[e] == src) {
        ++edges;
        targets.insert(s.jj[e]);
      }
    if (edges == 0) continue;
    const double T6 = 6.0 * (1 + targets.size());
    flops += HW * (edges * (124.0 + 364.0 + 56.0) + 3.0 + 3.0 * T6 + T6 * (T6 + 1.0));
  }
  return flops;
}

/// One core's double-precision peak of the benchmark machine: 2 FMA pipes × 4 lanes × 2 flops
/// per cycle (AVX2; Zen 4 executes AVX-512 at the same rate) at 2.6 GHz.
constexpr double kPeakFlopsPerSecond = 2.6e9 * 16;

}  // namespace dbacov::bench
