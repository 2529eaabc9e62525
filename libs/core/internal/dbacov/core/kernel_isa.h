// The instruction sets of the pixel kernel (dba_kernel.h, private to dbacov_core): which variant
// linearizeDba runs, and a way to choose one (tests that compare the variants, benchmarks).
// Internal to dbacov_core and its tests (dbacov_core_internal).
#pragma once

#include <optional>

namespace dbacov::kernel {

/// The instruction sets the kernel is compiled for, narrowest first.
enum class Isa { Baseline, Avx2Fma };

/// "baseline", "avx2": the names DBACOV_KERNEL_ISA takes.
const char* isaName(Isa isa);
/// Whether this CPU (and its operating system) runs the variant.
bool isaSupported(Isa isa);
/// The variant to run: the one selectIsa() set, else the one named by the environment
/// variable DBACOV_KERNEL_ISA, else the widest this CPU supports. Throws std::invalid_argument
/// (naming the variable) when the variable names an unknown or unsupported variant; linearizeDba
/// calls it before its parallel loop, so the error reaches the caller.
Isa selectedIsa();
/// Forces a variant (tests, benchmarks); std::nullopt returns to the default above. Throws
/// std::invalid_argument for a variant this CPU does not support. Not for concurrent use with
/// running linearizations.
void selectIsa(std::optional<Isa> isa);

}  // namespace dbacov::kernel
