#pragma once
// Issue 23 measures its per-frame figures "with caches evicted": a live frame arrives from the
// camera or the decoder, not from a cache that the previous call of the same benchmark
// warmed (1280x960 frames and their output, 26-59 MB, fit this machine's L3 otherwise, so a
// warm loop measures L3, not memory). evict_caches() writes back and drops every cache line of
// the given buffers; benchmarks call it between timed calls (timing paused) for ours, the
// floor and the peer alike.
#include <cstddef>
#include <initializer_list>
#include <utility>

#if defined(__x86_64__)
#include <immintrin.h>
#endif

namespace lp::bench {

// True where evict_caches() can do its job (x86-64's clflush); elsewhere rows that need it skip.
constexpr bool kCanEvictCaches =
#if defined(__x86_64__)
    true;
#else
    false;
#endif

// Every line of each (pointer, bytes) buffer out of every cache level.
inline void evict_caches(std::initializer_list<std::pair<const void*, size_t>> buffers) {
#if defined(__x86_64__)
  for (const auto& [p, bytes] : buffers) {
    const char* c = static_cast<const char*>(p);
    for (size_t i = 0; i < bytes; i += 64) _mm_clflush(c + i);
    if (bytes) _mm_clflush(c + bytes - 1);
  }
  _mm_mfence();
#else
  (void)buffers;
#endif
}

}  // namespace lp::bench
