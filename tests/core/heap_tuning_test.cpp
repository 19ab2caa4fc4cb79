// The solvers' heap settings (core/heap_tuning.h), read back through glibc's own counters.
#include "core/heap_tuning.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cstdlib>
#include <cstring>

#if defined(__GLIBC__)
#include <malloc.h>
#endif

// Under AddressSanitizer malloc is the sanitizer's: glibc's settings do not apply.
#if defined(__has_feature)
#if __has_feature(address_sanitizer)
#define LIGHTPROBE_ASAN 1
#endif
#endif
#if defined(__SANITIZE_ADDRESS__)
#define LIGHTPROBE_ASAN 1
#endif

namespace lp {
namespace {

#if defined(__GLIBC__) && !defined(LIGHTPROBE_ASAN)
// A 16 MB block, as a solver's normal matrix: from the heap, not a fresh mapping, and once
// freed its pages stay with the process (64 MB kept at the top) instead of going back to
// the kernel to be faulted in and zeroed again by the next solve.
TEST(HeapTuning, ASolversLargeBlockComesFromTheHeapAndStaysAfterItsFree) {
  keep_heap_for_reuse();
  keep_heap_for_reuse();  // idempotent
  const struct mallinfo2 before = mallinfo2();
  void* volatile block = std::malloc(std::size_t(16) << 20);  // volatile: not elided
  ASSERT_NE(block, nullptr);
  std::memset(block, 1, std::size_t(16) << 20);
  const struct mallinfo2 during = mallinfo2();
  EXPECT_EQ(during.hblks, before.hblks) << "the block was mmapped: the threshold was not raised";
  std::free(block);
  const struct mallinfo2 after = mallinfo2();
  // At least 64 MB of the heap stayed with the process (the trim threshold), or all of it
  // when it is smaller: earlier tests in the same process may have left the free chunk the
  // block came from, and then the top never moved.
  EXPECT_GE(after.arena, std::min(during.arena, std::size_t(64) << 20)) << "the heap's top went back to the kernel";
  EXPECT_GE(after.fordblks, std::size_t(16) << 20);
}

// A probe frame's images: ten 24 MB blocks freed together stay with the process (the trim
// threshold of 512 MB), where the top pad alone gave all but 64 MB of them back.
TEST(HeapTuning, AFramesWorthOfFreedImagesStaysWithTheProcess) {
  keep_heap_for_reuse();
  constexpr std::size_t kBlock = std::size_t(24) << 20;
  void* blocks[10];
  for (void*& b : blocks) {
    b = std::malloc(kBlock);
    ASSERT_NE(b, nullptr);
    std::memset(b, 1, kBlock);
  }
  const struct mallinfo2 during = mallinfo2();
  for (void* b : blocks) std::free(b);
  const struct mallinfo2 after = mallinfo2();
  EXPECT_GE(after.arena, during.arena) << "the heap's top went back to the kernel";
  EXPECT_GE(after.fordblks, 10 * kBlock);
}
#endif

}  // namespace
}  // namespace lp
