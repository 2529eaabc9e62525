// Dense products in dot-product form for the passes outside the pixel kernel (the
// self-calibration's sums over pixels): the kernel's register-blocked dot products, compiled for
// the same instruction sets and run in the variant it runs (kernel_isa.h). Internal to
// dbacov_core and its tests (dbacov_core_internal).
#pragma once

#include <cstddef>

namespace dbacov::kernel {

/// C += A Bᵀ: A has m rows (row r at A + r·lda), B has n rows (at B + r·ldb), each of K
/// contiguous entries; C is row-major with leading dimension ldc. With lower, only the outputs
/// with column <= row are written (for A = B, m = n: the lower triangle of a symmetric rank
/// update). Suited to long rows (sums over pixels) and small C; runs the variant selectedIsa()
/// names. Empty sizes do nothing.
void gemmNT(int m, int n, int K, const double* A, std::ptrdiff_t lda, const double* B,
            std::ptrdiff_t ldb, double* C, std::ptrdiff_t ldc, bool lower = false);

}  // namespace dbacov::kernel
