#include "dba_kernel.h"

#include "dbacov/core/dot_products.h"

#include <algorithm>
#include <atomic>
#include <cmath>
#include <cstddef>
#include <cstdlib>
#include <cstring>
#include <iterator>
#include <stdexcept>
#include <string>

namespace dbacov::kernel {
namespace {

/// C += A Bᵀ for the m rows of A (row r at A + r·lda) and the n rows of B (at B + r·ldb), each K
/// long; with kLower only C's lower triangle (c <= r; A = B, m = n: a symmetric rank update).
/// Every output comes from a block of 2 rows × 4 columns with eight accumulators in registers, so
/// each loaded vector feeds 4/3 FMAs instead of 1/2 for one dot product at a time. Near the
/// diagonal (and at the edges of C) the block computes a few outputs that are dropped: past the
/// last row of A or B it reads that last row again. (The narrower remainder loops this replaces
/// were left scalar by GCC 12: 13 % of the linearization.) Inlined into every variant, compiled
/// for each instruction set.
template <bool kLower>
__attribute__((always_inline)) inline void dotBlocks(int m, int n, int K, const double* A,
                                                     std::ptrdiff_t lda, const double* B,
                                                     std::ptrdiff_t ldb, double* C,
                                                     std::ptrdiff_t ldc) {
  const auto rowA = [&](int k) { return A + std::min(k, m - 1) * lda; };
  const auto rowB = [&](int k) { return B + std::min(k, n - 1) * ldb; };
  for (int r = 0; r < m; r += 2) {
    const double *x0 = rowA(r), *x1 = rowA(r + 1);
    const int cols = kLower ? std::min(r + 2, n) : n;
    for (int c = 0; c < cols; c += 4) {
      const double *y0 = rowB(c), *y1 = rowB(c + 1), *y2 = rowB(c + 2), *y3 = rowB(c + 3);
      double a0 = 0, a1 = 0, a2 = 0, a3 = 0, b0 = 0, b1 = 0, b2 = 0, b3 = 0;
#pragma omp simd reduction(+ : a0, a1, a2, a3, b0, b1, b2, b3)
      for (int p = 0; p < K; ++p) {
        a0 += x0[p] * y0[p];
        a1 += x0[p] * y1[p];
        a2 += x0[p] * y2[p];
        a3 += x0[p] * y3[p];
        b0 += x1[p] * y0[p];
        b1 += x1[p] * y1[p];
        b2 += x1[p] * y2[p];
        b3 += x1[p] * y3[p];
      }
      const double a[4] = {a0, a1, a2, a3}, b[4] = {b0, b1, b2, b3};
      for (int k = 0; k < 4 && c + k < n; ++k) {
        if (!kLower || c + k <= r) C[r * ldc + c + k] += a[k];
        if (r + 1 < m && (!kLower || c + k <= r + 1)) C[(r + 1) * ldc + c + k] += b[k];
      }
    }
  }
}

/// The kernel's Gram sums: C += X Xᵀ on the lower triangle (C row-major, leading dimension ldc)
/// for the m rows of X, row r at X + r·L.
__attribute__((always_inline)) inline void syrkLower(int m, int L, const double* X, double* C,
                                                     int ldc) {
  dotBlocks<true>(m, m, L, X, L, X, L, C, ldc);
}

}  // namespace

void Accumulator::reset(int edges, bool keep_depth_terms) {
  E = edges;
  aug.assign(static_cast<std::size_t>(E) * 7 * 7, 0.0);
  C.assign(static_cast<std::size_t>(36) * E * E, 0.0);
  gC.assign(6 * E, 0.0);
  factors_used = factors_filtered = depths_used = depths_unobservable = 0;
  keep_depths = keep_depth_terms;
  pixel.clear();
  h.clear();
  g.clear();
  B.clear();
  rows.assign(static_cast<std::size_t>(2) * kRow * kChunk, 0.0);
  c.assign(static_cast<std::size_t>(6) * E * kChunk, 0.0);
  hv.assign(kChunk, 0.0);
  gv.assign(kChunk, 0.0);
}

namespace {

// The body of processChunk, inlined into one function per instruction set below.
__attribute__((always_inline)) inline void chunkBody(const Camera& cam, const Filter& flt, int p0,
                                                     int n, const double* xn, const double* yn,
                                                     const double* d, const Edge* edges,
                                                     Accumulator& acc) {
  const int E6 = 6 * acc.E;
  double* cv = acc.c.data();  // cv[(6q + k) * kChunk + p]: entry k of c_q for lane p
  double* hv = acc.hv.data();
  double* gv = acc.gv.data();
  for (int p = 0; p < kChunk; ++p) hv[p] = gv[p] = 0.0;
  const bool has_min = flt.min_depth_ratio > 0, has_near = flt.near > 0, has_far = flt.far > 0;

  // Loop invariants as local values: read through pointers inside the pixel loop, GCC must assume
  // that the stores into the rows may change them, and leaves the loop scalar.
  const double fx = cam.fx, fy = cam.fy, cx = cam.cx, cy = cam.cy;
  const double wscale = flt.weight_scale, min_ratio = flt.min_depth_ratio, near = flt.near,
               far = flt.far;
  for (int q = 0; q < acc.E; ++q) {
    const Edge& e = edges[q];
    double R[9], t[3];
    for (int k = 0; k < 9; ++k) R[k] = e.R[k];
    for (int k = 0; k < 3; ++k) t[k] = e.t[k];
    const float *wx = e.wx + p0, *wy = e.wy + p0, *tx = e.tx + p0, *ty = e.ty + p0;
    // Row k of channel x at A0 + 2k·kChunk, of channel y right after it (A1 = A0 + kChunk), so that
    // both channels of a row form one vector of 2·kChunk lanes for the normal equations.
    double* A0 = acc.rows.data();
    double* A1 = A0 + kChunk;
    // Counted in doubles (exact below 2⁵³): a bool or integer count would make GCC pick a
    // byte-sized vectorization factor for the loop, which then fails.
    double used = 0, filtered = 0;
#pragma omp simd reduction(+ : used, filtered)
    for (int p = 0; p < n; ++p) {
      const double x = xn[p], y = yn[p], dd = d[p];
      const double w0 = wscale * wx[p], w1 = wscale * wy[p];
      // Y = R_ji [x y 1]ᵀ + t_ji d   (conventions §2)
      const double Y0 = R[0] * x + R[1] * y + R[2] + t[0] * dd;
      const double Y1 = R[3] * x + R[4] * y + R[5] + t[1] * dd;
      const double Y2 = R[6] * x + R[7] * y + R[8] + t[2] * dd;
      const bool any = (w0 > 0 || w1 > 0) && dd > 0;
      const bool keep = Y2 > 0 && (!has_min || Y2 >= min_ratio) &&
                        (!has_near || (dd * near < 1.0 && Y2 > near * dd)) &&
                        (!has_far || dd * far > 1.0);
      const bool ok = any && keep;
      used += ok ? 1.0 : 0.0;
      filtered += any && !keep ? 1.0 : 0.0;
      const double s0 = ok ? std::sqrt(w0) : 0.0, s1 = ok ? std::sqrt(w1) : 0.0;
      const double iz = ok ? 1.0 / Y2 : 0.0;
      // −∂π/∂Y rows: m0 = [a 0 c], m1 = [0 e f]
      const double a = -fx * iz, c = fx * Y0 * iz * iz;
      const double ee = -fy * iz, f = fy * Y1 * iz * iz;
      const double res0 = tx[p] - (fx * Y0 * iz + cx);
      const double res1 = ty[p] - (fy * Y1 * iz + cy);
      // J_j = [−d·m, m × Y],  J_d = m·t; J_i = −J_j Ad(T_ji) is applied per edge, outside.
      constexpr int S = 2 * kChunk;  // stride between rows
      double* o0 = A0 + p;
      o0[0 * S] = -s0 * dd * a;
      o0[1 * S] = 0.0;
      o0[2 * S] = -s0 * dd * c;
      o0[3 * S] = s0 * (-c * Y1);
      o0[4 * S] = s0 * (c * Y0 - a * Y2);
      o0[5 * S] = s0 * (a * Y1);
      o0[6 * S] = s0 * res0;
      o0[7 * S] = s0 * (a * t[0] + c * t[2]);
      double* o1 = A1 + p;
      o1[0 * S] = 0.0;
      o1[1 * S] = -s1 * dd * ee;
      o1[2 * S] = -s1 * dd * f;
      o1[3 * S] = s1 * (ee * Y2 - f * Y1);
      o1[4 * S] = s1 * (f * Y0);
      o1[5 * S] = s1 * (-ee * Y0);
      o1[6 * S] = s1 * res1;
      o1[7 * S] = s1 * (ee * t[1] + f * t[2]);
    }
    acc.factors_used += static_cast<std::size_t>(used);
    acc.factors_filtered += static_cast<std::size_t>(filtered);

    // Lanes past the end of a short last chunk hold stale rows: clear them, so that the
    // reductions below can run over whole rows.
    if (n < kChunk)
      for (int k = 0; k < kRow; ++k)
        for (int c = 0; c < 2; ++c)
          for (int p = n; p < kChunk; ++p) A0[(2 * k + c) * kChunk + p] = 0.0;
    // Normal equations of the edge: aug += Σ_lanes a aᵀ over both channels (lower triangle) for
    // a = [J_j r]; J_i = −J_j Ad(T_ji) gives the rest (dba_kernel.h).
    syrkLower(7, 2 * kChunk, A0, &acc.aug[static_cast<std::size_t>(q) * 49], 7);
    // Depth coupling per lane: c_q = J_jᵀ Λ J_d (all lanes: the stale ones are cleared), h_k, g_k.
    constexpr int S = 2 * kChunk;
    const double *d0 = A0 + 7 * S, *d1 = A1 + 7 * S;
    for (int k = 0; k < 6; ++k) {
      double* cq = cv + (6 * q + k) * kChunk;
      const double *j0 = A0 + k * S, *j1 = A1 + k * S;
#pragma omp simd
      for (int p = 0; p < kChunk; ++p) cq[p] = j0[p] * d0[p] + j1[p] * d1[p];
    }
    const double *q0 = A0 + 6 * S, *q1 = A1 + 6 * S;
#pragma omp simd
    for (int p = 0; p < n; ++p) {
      hv[p] += d0[p] * d0[p] + d1[p] * d1[p];
      gv[p] += d0[p] * q0[p] + d1[p] * q1[p];
    }
  }

  // Eliminate the observable depths: scale c_k by 1/√h_k (others to zero) and accumulate
  // gC += c_k g_k / h_k and C += (c_k/√h_k)(c_k/√h_k)ᵀ over the lanes.
  double ratio[kChunk], scale[kChunk];
  for (int p = n; p < kChunk; ++p) ratio[p] = scale[p] = 0.0;  // c is zero there: rows stay zero
  for (int p = 0; p < n; ++p) {
    const bool kept = hv[p] > flt.depth_info_eps;
    scale[p] = kept ? 1.0 / std::sqrt(hv[p]) : 0.0;
    ratio[p] = kept ? gv[p] / hv[p] : 0.0;
    if (kept) {
      ++acc.depths_used;
      if (acc.keep_depths) {
        acc.pixel.push_back(p0 + p);
        acc.h.push_back(hv[p]);
        acc.g.push_back(gv[p]);
        for (int m = 0; m < E6; ++m) acc.B.push_back(cv[m * kChunk + p]);
      }
    } else if (hv[p] > 0) {
      ++acc.depths_unobservable;
    }
  }
  for (int m = 0; m < E6; ++m) {
    double* bm = cv + m * kChunk;
    double sum = 0.0;
#pragma omp simd reduction(+ : sum)
    for (int p = 0; p < kChunk; ++p) {
      sum += bm[p] * ratio[p];
      bm[p] *= scale[p];
    }
    acc.gC[m] += sum;
  }
  syrkLower(E6, kChunk, cv, acc.C.data(), E6);
}

// Compiled for AVX2+FMA and for the x86-64 baseline; processChunk runs the one it is given
// (selectedIsa). (Not GCC's target_clones: clang 14 ignores it on a function declared earlier, and
// where it clones, it defines no symbol that other files can call.) An AVX-512 clone was measured
// and left out: on a Sapphire-Rapids-class Xeon it was 20 % slower with 512-bit vectors and no
// faster with 256-bit ones (docs/development/performance.md).
__attribute__((target("avx2,fma"))) void chunkAvx2Fma(const Camera& cam, const Filter& flt, int p0,
                                                      int n, const double* xn, const double* yn,
                                                      const double* d, const Edge* edges,
                                                      Accumulator& acc) {
  chunkBody(cam, flt, p0, n, xn, yn, d, edges, acc);
}
void chunkBaseline(const Camera& cam, const Filter& flt, int p0, int n, const double* xn,
                   const double* yn, const double* d, const Edge* edges, Accumulator& acc) {
  chunkBody(cam, flt, p0, n, xn, yn, d, edges, acc);
}

constexpr Isa kIsas[] = {Isa::Baseline, Isa::Avx2Fma};
constexpr const char* kEnvIsa = "DBACOV_KERNEL_ISA";

/// The widest supported variant, or the one DBACOV_KERNEL_ISA names (the variable is read once;
/// a wrong value is an error at every call, so that no run silently uses another kernel).
Isa defaultIsa() {
  struct Choice {
    Isa isa = Isa::Baseline;
    std::string error;
  };
  static const Choice choice = [] {
    Choice c;
    const char* v = std::getenv(kEnvIsa);
    if (!v || !*v) {
      c.isa = isaSupported(Isa::Avx2Fma) ? Isa::Avx2Fma : Isa::Baseline;
      return c;
    }
    const auto named = std::find_if(std::begin(kIsas), std::end(kIsas),
                                    [&](Isa isa) { return std::strcmp(v, isaName(isa)) == 0; });
    if (named == std::end(kIsas))
      c.error = std::string(kEnvIsa) + "=" + v + ": unknown pixel kernel (baseline or avx2)";
    else if (!isaSupported(*named))
      c.error = std::string(kEnvIsa) + "=" + v + ": this CPU does not support that pixel kernel";
    else
      c.isa = *named;
    return c;
  }();
  if (!choice.error.empty()) throw std::invalid_argument(choice.error);
  return choice.isa;
}

std::atomic<int> g_forced{-1};  // selectIsa(): the forced variant, or -1

}  // namespace

const char* isaName(Isa isa) {
  switch (isa) {
    case Isa::Avx2Fma:
      return "avx2";
    case Isa::Baseline:
      break;
  }
  return "baseline";
}

bool isaSupported(Isa isa) {
  // __builtin_cpu_supports also checks that the operating system saves the wider registers.
  __builtin_cpu_init();
  switch (isa) {
    case Isa::Avx2Fma:
      return __builtin_cpu_supports("avx2") && __builtin_cpu_supports("fma");
    case Isa::Baseline:
      break;
  }
  return true;
}

Isa selectedIsa() {
  const int forced = g_forced.load(std::memory_order_relaxed);
  return forced >= 0 ? static_cast<Isa>(forced) : defaultIsa();
}

void selectIsa(std::optional<Isa> isa) {
  if (isa && !isaSupported(*isa))
    throw std::invalid_argument(std::string("this CPU does not support the ") + isaName(*isa) +
                                " pixel kernel");
  g_forced.store(isa ? static_cast<int>(*isa) : -1, std::memory_order_relaxed);
}

void processChunk(Isa isa, const Camera& cam, const Filter& flt, int p0, int n, const double* xn,
                  const double* yn, const double* d, const Edge* edges, Accumulator& acc) {
  switch (isa) {
    case Isa::Avx2Fma:
      chunkAvx2Fma(cam, flt, p0, n, xn, yn, d, edges, acc);
      return;
    case Isa::Baseline:
      break;
  }
  chunkBaseline(cam, flt, p0, n, xn, yn, d, edges, acc);
}

namespace {
// The products of dot_products.h: one body, inlined into one function per instruction set like
// the chunk's above.
__attribute__((always_inline)) inline void gemmNTBody(int m, int n, int K, const double* A,
                                                      std::ptrdiff_t lda, const double* B,
                                                      std::ptrdiff_t ldb, double* C,
                                                      std::ptrdiff_t ldc, bool lower) {
  if (lower)
    dotBlocks<true>(m, n, K, A, lda, B, ldb, C, ldc);
  else
    dotBlocks<false>(m, n, K, A, lda, B, ldb, C, ldc);
}
__attribute__((target("avx2,fma"))) void gemmNTAvx2Fma(int m, int n, int K, const double* A,
                                                       std::ptrdiff_t lda, const double* B,
                                                       std::ptrdiff_t ldb, double* C,
                                                       std::ptrdiff_t ldc, bool lower) {
  gemmNTBody(m, n, K, A, lda, B, ldb, C, ldc, lower);
}
void gemmNTBaseline(int m, int n, int K, const double* A, std::ptrdiff_t lda, const double* B,
                    std::ptrdiff_t ldb, double* C, std::ptrdiff_t ldc, bool lower) {
  gemmNTBody(m, n, K, A, lda, B, ldb, C, ldc, lower);
}
}  // namespace

void gemmNT(int m, int n, int K, const double* A, std::ptrdiff_t lda, const double* B,
            std::ptrdiff_t ldb, double* C, std::ptrdiff_t ldc, bool lower) {
  if (m <= 0 || n <= 0 || K <= 0) return;
  switch (selectedIsa()) {
    case Isa::Avx2Fma:
      gemmNTAvx2Fma(m, n, K, A, lda, B, ldb, C, ldc, lower);
      return;
    case Isa::Baseline:
      break;
  }
  gemmNTBaseline(m, n, K, A, lda, B, ldb, C, ldc, lower);
}

}  // namespace dbacov::kernel
