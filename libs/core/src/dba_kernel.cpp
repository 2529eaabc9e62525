#include "dba_kernel.h"

#include <cmath>

namespace dbacov::kernel {
namespace {

/// C += X Xᵀ on the lower triangle (C row-major with leading dimension ldc) for the m rows of X,
/// row r at X + r·L. Blocks of 2 × 4 outputs keep eight accumulators in registers, so each loaded
/// vector feeds 4/3 FMAs instead of 1/2 for one dot product at a time. Inlined into both clones of
/// processChunk so that it is compiled for each instruction set.
__attribute__((always_inline)) inline void syrkLower(int m, int L, const double* X, double* C,
                                                     int ldc) {
  int r = 0;
  for (; r + 2 <= m; r += 2) {
    const double *x0 = X + r * L, *x1 = x0 + L;
    int c = 0;
    for (; c + 4 <= r + 2; c += 4) {
      const double *y0 = X + c * L, *y1 = y0 + L, *y2 = y1 + L, *y3 = y2 + L;
      double a0 = 0, a1 = 0, a2 = 0, a3 = 0, b0 = 0, b1 = 0, b2 = 0, b3 = 0;
#pragma omp simd reduction(+ : a0, a1, a2, a3, b0, b1, b2, b3)
      for (int p = 0; p < L; ++p) {
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
      for (int k = 0; k < 4; ++k) {
        if (c + k <= r) C[r * ldc + c + k] += a[k];
        if (c + k <= r + 1) C[(r + 1) * ldc + c + k] += b[k];
      }
    }
    for (; c <= r + 1; ++c) {
      const double* y = X + c * L;
      double a = 0, b = 0;
#pragma omp simd reduction(+ : a, b)
      for (int p = 0; p < L; ++p) {
        a += x0[p] * y[p];
        b += x1[p] * y[p];
      }
      if (c <= r) C[r * ldc + c] += a;
      C[(r + 1) * ldc + c] += b;
    }
  }
  for (; r < m; ++r)
    for (int c = 0; c <= r; ++c) {
      const double *x = X + r * L, *y = X + c * L;
      double a = 0;
#pragma omp simd reduction(+ : a)
      for (int p = 0; p < L; ++p) a += x[p] * y[p];
      C[r * ldc + c] += a;
    }
}

}  // namespace

void Accumulator::reset(int touched, int edges, bool keep_depth_terms) {
  T = touched;
  E = edges;
  aug.assign(static_cast<std::size_t>(E) * 13 * 13, 0.0);
  W.assign(static_cast<std::size_t>(36) * T * T, 0.0);
  gS.assign(6 * T, 0.0);
  factors_used = factors_filtered = depths_used = depths_unobservable = 0;
  keep_depths = keep_depth_terms;
  pixel.clear();
  h.clear();
  g.clear();
  B.clear();
  rows.assign(static_cast<std::size_t>(2) * kRow * kChunk, 0.0);
  b.assign(static_cast<std::size_t>(6) * T * kChunk, 0.0);
  hv.assign(kChunk, 0.0);
  gv.assign(kChunk, 0.0);
}

namespace {

// The body of processChunk, inlined into one function per instruction set below.
__attribute__((always_inline)) inline void chunkBody(const Camera& cam, const Filter& flt, int p0,
                                                     int n, const double* xn, const double* yn,
                                                     const double* d, const Edge* edges,
                                                     Accumulator& acc) {
  const int T6 = 6 * acc.T;
  double* b = acc.b.data();  // b[m * kChunk + p]: entry m of b_k for lane p
  double* hv = acc.hv.data();
  double* gv = acc.gv.data();
  for (int i = 0; i < T6 * kChunk; ++i) b[i] = 0.0;
  for (int p = 0; p < kChunk; ++p) hv[p] = gv[p] = 0.0;
  const bool has_min = flt.min_depth_ratio > 0, has_near = flt.near > 0, has_far = flt.far > 0;

  for (int q = 0; q < acc.E; ++q) {
    const Edge& e = edges[q];
    const double* R = e.R;
    // Row k of channel x at A0 + 2k·kChunk, of channel y right after it (A1 = A0 + kChunk), so that
    // both channels of a row form one vector of 2·kChunk lanes for the normal equations.
    double* A0 = acc.rows.data();
    double* A1 = A0 + kChunk;
    std::size_t used = 0, filtered = 0;
#pragma omp simd reduction(+ : used, filtered)
    for (int p = 0; p < n; ++p) {
      const double x = xn[p], y = yn[p], dd = d[p];
      const double w0 = flt.weight_scale * e.wx[p0 + p], w1 = flt.weight_scale * e.wy[p0 + p];
      // Y = R_ji [x y 1]ᵀ + t_ji d   (conventions §2)
      const double Y0 = R[0] * x + R[1] * y + R[2] + e.t[0] * dd;
      const double Y1 = R[3] * x + R[4] * y + R[5] + e.t[1] * dd;
      const double Y2 = R[6] * x + R[7] * y + R[8] + e.t[2] * dd;
      const bool any = (w0 > 0 || w1 > 0) && dd > 0;
      const bool keep = Y2 > 0 && (!has_min || Y2 >= flt.min_depth_ratio) &&
                        (!has_near || (dd * flt.near < 1.0 && Y2 > flt.near * dd)) &&
                        (!has_far || dd * flt.far > 1.0);
      const bool ok = any && keep;
      used += ok;
      filtered += any && !keep;
      const double s0 = ok ? std::sqrt(w0) : 0.0, s1 = ok ? std::sqrt(w1) : 0.0;
      const double iz = ok ? 1.0 / Y2 : 0.0;
      // −∂π/∂Y rows: m0 = [a 0 c], m1 = [0 e f]
      const double a = -cam.fx * iz, c = cam.fx * Y0 * iz * iz;
      const double ee = -cam.fy * iz, f = cam.fy * Y1 * iz * iz;
      // mR_c = m_c R_ji
      const double r00 = a * R[0] + c * R[6], r01 = a * R[1] + c * R[7], r02 = a * R[2] + c * R[8];
      const double r10 = ee * R[3] + f * R[6], r11 = ee * R[4] + f * R[7],
                   r12 = ee * R[5] + f * R[8];
      const double res0 = e.tx[p0 + p] - (cam.fx * Y0 * iz + cam.cx);
      const double res1 = e.ty[p0 + p] - (cam.fy * Y1 * iz + cam.cy);
      // J_i = [d·mR, p × mR],  J_j = [−d·m, m × Y],  J_d = m·t  (p = [x y 1])
      constexpr int S = 2 * kChunk;  // stride between rows
      double* o0 = A0 + p;
      o0[0 * S] = s0 * dd * r00;
      o0[1 * S] = s0 * dd * r01;
      o0[2 * S] = s0 * dd * r02;
      o0[3 * S] = s0 * (y * r02 - r01);
      o0[4 * S] = s0 * (r00 - x * r02);
      o0[5 * S] = s0 * (x * r01 - y * r00);
      o0[6 * S] = -s0 * dd * a;
      o0[7 * S] = 0.0;
      o0[8 * S] = -s0 * dd * c;
      o0[9 * S] = s0 * (-c * Y1);
      o0[10 * S] = s0 * (c * Y0 - a * Y2);
      o0[11 * S] = s0 * (a * Y1);
      o0[12 * S] = s0 * res0;
      o0[13 * S] = s0 * (a * e.t[0] + c * e.t[2]);
      double* o1 = A1 + p;
      o1[0 * S] = s1 * dd * r10;
      o1[1 * S] = s1 * dd * r11;
      o1[2 * S] = s1 * dd * r12;
      o1[3 * S] = s1 * (y * r12 - r11);
      o1[4 * S] = s1 * (r10 - x * r12);
      o1[5 * S] = s1 * (x * r11 - y * r10);
      o1[6 * S] = 0.0;
      o1[7 * S] = -s1 * dd * ee;
      o1[8 * S] = -s1 * dd * f;
      o1[9 * S] = s1 * (ee * Y2 - f * Y1);
      o1[10 * S] = s1 * (f * Y0);
      o1[11 * S] = s1 * (-ee * Y0);
      o1[12 * S] = s1 * res1;
      o1[13 * S] = s1 * (ee * e.t[1] + f * e.t[2]);
    }
    acc.factors_used += used;
    acc.factors_filtered += filtered;

    // Lanes past the end of a short last chunk hold stale rows: clear them, so that the
    // reductions below can run over whole rows.
    if (n < kChunk)
      for (int k = 0; k < kRow; ++k)
        for (int c = 0; c < 2; ++c)
          for (int p = n; p < kChunk; ++p) A0[(2 * k + c) * kChunk + p] = 0.0;
    // Normal equations of the edge: aug += Σ_lanes a aᵀ over both channels (lower triangle).
    syrkLower(13, 2 * kChunk, A0, &acc.aug[static_cast<std::size_t>(q) * 169], 13);
    // Depth coupling per lane: b_k[src] += J_iᵀ Λ J_d, b_k[tgt] += J_jᵀ Λ J_d, h_k, g_k.
    constexpr int S = 2 * kChunk;
    const double *d0 = A0 + 13 * S, *d1 = A1 + 13 * S;
    for (int k = 0; k < 6; ++k) {
      double* bs = b + k * kChunk;
      double* bt = b + (6 * e.target + k) * kChunk;
      const double *i0 = A0 + k * S, *i1 = A1 + k * S;
      const double *j0 = A0 + (6 + k) * S, *j1 = A1 + (6 + k) * S;
#pragma omp simd
      for (int p = 0; p < n; ++p) {
        bs[p] += i0[p] * d0[p] + i1[p] * d1[p];
        bt[p] += j0[p] * d0[p] + j1[p] * d1[p];
      }
    }
    const double *q0 = A0 + 12 * S, *q1 = A1 + 12 * S;
#pragma omp simd
    for (int p = 0; p < n; ++p) {
      hv[p] += d0[p] * d0[p] + d1[p] * d1[p];
      gv[p] += d0[p] * q0[p] + d1[p] * q1[p];
    }
  }

  // Eliminate the observable depths: scale b_k by 1/√h_k (others to zero) and accumulate
  // gS += b_k g_k / h_k and W += (b_k/√h_k)(b_k/√h_k)ᵀ over the lanes.
  double ratio[kChunk], scale[kChunk];
  for (int p = n; p < kChunk; ++p) ratio[p] = scale[p] = 0.0;  // b is zero there: rows stay zero
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
        for (int m = 0; m < T6; ++m) acc.B.push_back(b[m * kChunk + p]);
      }
    } else if (hv[p] > 0) {
      ++acc.depths_unobservable;
    }
  }
  for (int m = 0; m < T6; ++m) {
    double* bm = b + m * kChunk;
    double sum = 0.0;
#pragma omp simd reduction(+ : sum)
    for (int p = 0; p < kChunk; ++p) {
      sum += bm[p] * ratio[p];
      bm[p] *= scale[p];
    }
    acc.gS[m] += sum;
  }
  syrkLower(T6, kChunk, b, acc.W.data(), T6);
}

// Compiled for AVX2+FMA and for the x86-64 baseline; processChunk picks one at run time. (Not
// GCC's target_clones: clang 14 ignores it on a function declared earlier, and where it clones,
// it defines no symbol that other files can call.)
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

bool cpuHasAvx2Fma() {
  __builtin_cpu_init();
  return __builtin_cpu_supports("avx2") && __builtin_cpu_supports("fma");
}

}  // namespace

void processChunk(const Camera& cam, const Filter& flt, int p0, int n, const double* xn,
                  const double* yn, const double* d, const Edge* edges, Accumulator& acc) {
  static const bool avx2_fma = cpuHasAvx2Fma();
  if (avx2_fma)
    chunkAvx2Fma(cam, flt, p0, n, xn, yn, d, edges, acc);
  else
    chunkBaseline(cam, flt, p0, n, xn, yn, d, edges, acc);
}

}  // namespace dbacov::kernel
