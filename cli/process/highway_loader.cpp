// Highway's run-time dispatch, its library loaded on first use. libhwy 1.0 measures its
// timer's resolution in a static initializer (nanobenchmark.cc: 65,536 rdtsc pairs), which
// ran at every command's start, ~2.5 ms, though only the vector kernels of hdr/ and probe/
// dispatch through it. The two functions those kernels call (HWY_DYNAMIC_DISPATCH) are
// defined here, in the executable, and forward to libhwy.so.1 opened by the first dispatch:
// the linker then finds no use of libhwy and leaves it out (--as-needed). The dispatch
// state stays in libhwy's own ChosenTarget, which ours returns.
//
// The definitions are checked against hwy/targets.h by the compiler. Programs without this
// file (the tests, the benchmarks) link libhwy as before. A Highway function the kernels
// start to call links libhwy again at start; tests/cli/startup_cli_test.cpp notices.
#include <hwy/targets.h>

#include "core/lazy_libs.h"

namespace {
constexpr const char* kHighwayLibrary = "libhwy.so.1";
}  // namespace

namespace hwy {

ChosenTarget& GetChosenTarget() {
  using Real = ChosenTarget& (*)();
  static ChosenTarget& chosen = reinterpret_cast<Real>(
      lp::lazy::library_symbol(kHighwayLibrary, "_ZN3hwy15GetChosenTargetEv", "Highway 1.x"))();
  return chosen;
}

int64_t SupportedTargets() {
  using Real = int64_t (*)();
  static const Real real =
      reinterpret_cast<Real>(lp::lazy::library_symbol(kHighwayLibrary, "_ZN3hwy16SupportedTargetsEv", "Highway 1.x"));
  return real();
}

}  // namespace hwy
