// Floating-point operations that linearizeDba's kernel performs on a snapshot, counted
// from the kernel's arithmetic (libs/core/src/dba_kernel.cpp). The kernel works in the edges'
// coordinates: the source's Jacobian is J_i = −J_j Ad(T_ji), applied once per edge and source
// outside the kernel (negligible here). Per lane = pixel of a source keyframe against one edge:
//   transfer, projection, residual and whitened rows [J_j r J_d] of both channels     73
//   normal equations of the edge, [J_j r] (28 products per channel, multiply + add)   112
//   depth coupling c_q = J_jᵀ Λ J_d, h_k, g_k                                           26
// and per lane and source with E edges: depth elimination 3 + 3·6E and the Schur update
// (6E)(6E+1) in the edges' coordinates. Masked lanes (invalid pixels) are counted too: the
// kernel computes them. (Until 2026-12-04: 124 + 364 + 56 per edge and the Schur update over the
// 6T coordinates of the touched slots.)
#pragma once

#include "dbacov/core/linearization.h"
#include "dbacov/core/snapshot.h"

namespace dbacov::bench {

inline double linearizationFlops(const Snapshot& s) {
  const double HW = static_cast<double>(s.pixelsPerFrame());
  double flops = 0;
  for (int src : s.graphKeyframes()) {
    int edges = 0;
    for (int e = 0; e < s.numEdges(); ++e)
      if (s.ii[e] == src) ++edges;
    if (edges == 0) continue;
    const double E6 = 6.0 * edges;
    flops += HW * (edges * (73.0 + 112.0 + 26.0) + 3.0 + 3.0 * E6 + E6 * (E6 + 1.0));
  }
  return flops;
}

/// One core's double-precision peak of the benchmark machine: 2 FMA pipes × 4 lanes × 2 flops
/// per cycle (AVX2; Zen 4 executes AVX-512 at the same rate) at 2.6 GHz.
constexpr double kPeakFlopsPerSecond = 2.6e9 * 16;

}  // namespace dbacov::bench
