// The executable dispatches Highway's kernels with core/highway_targets.h instead of
// libhwy (cli/process/highway_loader.cpp): it must choose what libhwy would, or a kernel
// runs with instructions the CPU lacks (or slower than it could).
#include "core/highway_targets.h"

#include <gtest/gtest.h>
#include <hwy/targets.h>

namespace lp {
namespace {

TEST(HighwayTargets, TheSameAsLibhwyOnThisCpu) {
#if defined(__x86_64__) || defined(__i386__)
  const int64_t ours = detect_highway_targets();
  EXPECT_EQ(ours, hwy::SupportedTargets()) << std::hex << "ours 0x" << ours;
  EXPECT_NE(ours & HWY_SSSE3, 0) << "SSSE3 (x86 CPUs since 2006) not detected";
#else
  EXPECT_EQ(detect_highway_targets(), 0) << "other architectures ask libhwy";
#endif
}

}  // namespace
}  // namespace lp
