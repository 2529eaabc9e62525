// Runs a test body once per pixel-kernel variant this CPU supports (kernel_isa.h).
#pragma once

#include <stdexcept>
#include <string>

#include <gtest/gtest.h>

#include "dbacov/core/kernel_isa.h"

namespace dbacov::testing {

/// Forces one kernel variant for its lifetime, then returns to the default (also when the body
/// fails an ASSERT or throws).
class ForcedKernelIsa {
 public:
  explicit ForcedKernelIsa(kernel::Isa isa) { kernel::selectIsa(isa); }
  ~ForcedKernelIsa() { kernel::selectIsa(std::nullopt); }
  ForcedKernelIsa(const ForcedKernelIsa&) = delete;
  ForcedKernelIsa& operator=(const ForcedKernelIsa&) = delete;
};

/// body(isa) with each supported variant forced, narrowest first; the failures name the variant.
/// Returns how many variants ran (at least the baseline).
template <class Body>
int forEachKernelIsa(Body body) {
  int ran = 0;
  for (kernel::Isa isa : {kernel::Isa::Baseline, kernel::Isa::Avx2Fma}) {
    if (!kernel::isaSupported(isa)) {  // a variant this CPU cannot run is refused, not run
      EXPECT_THROW(kernel::selectIsa(isa), std::invalid_argument) << kernel::isaName(isa);
      continue;
    }
    SCOPED_TRACE(std::string("pixel kernel ") + kernel::isaName(isa));
    const ForcedKernelIsa forced(isa);
    EXPECT_EQ(kernel::selectedIsa(), isa);  // the body really runs this variant
    body(isa);
    ++ran;
  }
  return ran;
}

}  // namespace dbacov::testing
