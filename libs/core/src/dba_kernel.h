// Private to dbacov_core: the inner kernel of linearizeDba, in structure-of-arrays form.
//
// One call processes a chunk of consecutive pixels of one source keyframe against every edge
// leaving it. Pixels are the SIMD lanes: every per-pixel quantity lives in a short array, invalid
// lanes (d <= 0, zero weight, filtered, behind the camera) carry zero whitening weight, and the
// reductions over pixels (normal equations, Schur update) run as dot products over those arrays.
// The function is compiled twice (AVX2+FMA, Haswell class, 4 double lanes per register; the
// x86-64 baseline, 2 lanes) and runs AVX2+FMA where the CPU has it, or the variant named by
// DBACOV_KERNEL_ISA or selectIsa() (portable to GCC and clang). The variants compute the same sums
// in different orders: their results agree to rounding (tests/core). It uses no Eigen and no heap
// memory: Eigen's allocation code must not be instantiated with two different alignments in one
// process.
#pragma once

#include <cstddef>
#include <vector>

#include "dbacov/core/kernel_isa.h"

namespace dbacov::kernel {

constexpr int kChunk = 64;  ///< pixels per chunk (lanes)
constexpr int kRow = 8;     ///< whitened row: J_j (6), r (1), J_d (1)

struct Camera {
  double fx, fy, cx, cy;
};

/// The pixel filters of conventions §2 (DbaOptions), as plain numbers: a non-positive value means
/// "off".
struct Filter {
  double weight_scale;
  double min_depth_ratio;  ///< keep Y2 >= this (≤ 0: only Y2 > 0)
  double near;             ///< keep d·near < 1 and Y2 > near·d
  double far;              ///< keep d·far > 1
  double depth_info_eps;   ///< eliminate a depth only if h > this
};

struct Edge {
  double R[9];                     ///< R_ji, row-major
  double t[3];                     ///< t_ji
  const float *wx, *wy, *tx, *ty;  ///< weight and target planes of the edge (H×W)
};

/// Everything one source keyframe accumulates; sized by reset(). The kernel works in the edges'
/// coordinates only: the source's Jacobian of each pixel factor is J_i = −J_j Ad(T_ji), Ad(T) =
/// [R [t]×R; 0 R], so per edge q it forms J_j, r and J_d, and linearization.cpp maps the sums to
/// the touched slots with Γ (6T × 6E: block (0, q) = −Adᵀ_q, block (target_q, q) = I). A depth's
/// coupling b_k = Γ c_k with c_k = [J_jᵀ Λ J_d per edge] (6E); the Schur update Σ b bᵀ/h =
/// Γ (Σ c cᵀ/h) Γᵀ. This saves the source's rows, 63 of the 91 dot products of each edge's normal
/// equations, and the Schur update's rows and columns of the source.
struct Accumulator {
  int E = 0;                ///< edges
  std::vector<double> aug;  ///< E × 7 × 7 per edge: Σ aᵀa of a = √w·[J_j r] (lower, row-major)
  std::vector<double> C;   ///< 6E × 6E, Σ_k c_k c_kᵀ / h_k (lower triangle, row-major)
  std::vector<double> gC;  ///< 6E, Σ_k c_k g_k / h_k
  std::size_t factors_used = 0, factors_filtered = 0, depths_used = 0, depths_unobservable = 0;
  // Depth terms of the kept depths, when requested (keep_depth_terms).
  bool keep_depths = false;
  std::vector<int> pixel;
  std::vector<double> h, g, B;  ///< B: c_k (6E values) per kept depth, appended
  // Scratch reused by every chunk.
  std::vector<double> rows, c, hv, gv;

  void reset(int edges, bool keep_depth_terms);
};

/// Accumulates pixels [p0, p0 + n) (n <= kChunk). xn, yn: normalized coordinates of those
/// pixels; d: their inverse depths. isa: the variant to run (selectedIsa(), resolved once per
/// linearization; it must be supported).
void processChunk(Isa isa, const Camera& cam, const Filter& filter, int p0, int n, const double* xn,
                  const double* yn, const double* d, const Edge* edges, Accumulator& acc);

}  // namespace dbacov::kernel
