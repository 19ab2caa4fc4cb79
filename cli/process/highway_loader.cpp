// Highway's run-time dispatch without libhwy. libhwy 1.0 measures its timer's resolution
// in a static initializer (nanobenchmark.cc: 65,536 rdtsc pairs), 3.4 ms of every process
// that opens it, though the vector kernels of hdr/, probe/ and sampling/ only call the two
// functions of the dispatch (HWY_DYNAMIC_DISPATCH) defined here, in the executable. On x86
// the targets are detected as libhwy 1.0.3 does (core/highway_targets.h, compared with
// libhwy's own answer by a test) and libhwy is never opened; elsewhere the first dispatch
// opens it and forwards. The linker finds no use of libhwy and leaves it out (--as-needed).
//
// The definitions are checked against hwy/targets.h by the compiler. Programs without this
// file (the tests, the benchmarks) link libhwy as before. A Highway function the kernels
// start to call links libhwy again at start; tests/cli/startup_cli_test.cpp notices.
#include <hwy/targets.h>

#include "core/highway_targets.h"
#include "core/lazy_libs.h"

namespace {
constexpr const char* kHighwayLibrary = "libhwy.so.1";
const bool kDetectedHere = lp::detect_highway_targets() != 0;
}  // namespace

namespace hwy {

ChosenTarget& GetChosenTarget() {
  if (kDetectedHere) {
    static ChosenTarget chosen;  // as libhwy's own, in targets.cc
    return chosen;
  }
  using Real = ChosenTarget& (*)();
  static ChosenTarget& chosen = reinterpret_cast<Real>(
      lp::lazy::library_symbol(kHighwayLibrary, "_ZN3hwy15GetChosenTargetEv", "Highway 1.x"))();
  return chosen;
}

int64_t SupportedTargets() {
  if (kDetectedHere) {
    // As libhwy 1.0.3's SupportedTargets: the chosen target is updated before returning.
    const int64_t targets = lp::detect_highway_targets();
    GetChosenTarget().Update(targets);
    return targets;
  }
  using Real = int64_t (*)();
  static const Real real =
      reinterpret_cast<Real>(lp::lazy::library_symbol(kHighwayLibrary, "_ZN3hwy16SupportedTargetsEv", "Highway 1.x"));
  return real();
}

}  // namespace hwy
