// The instruction sets Google Highway's run-time dispatch may use on this CPU, detected
// here rather than by libhwy: opening libhwy.so.1 runs its timer calibration (a static
// initializer of nanobenchmark.cc, 3.4 ms measured on this machine's 2 cores), which every
// command that dispatched a vector kernel paid (cli/process/highway_loader.cpp).
#pragma once

#include <cstdint>

namespace lp {

// The HWY_* target bits hwy::SupportedTargets() of Highway 1.0.3 returns on x86 (CPUID
// feature groups, cleared where the OS does not save the registers, XCR0), or 0 on other
// architectures, where the caller must ask libhwy. tests/core/highway_targets_test.cpp
// compares the two on the machine it runs on.
int64_t detect_highway_targets();

}  // namespace lp
