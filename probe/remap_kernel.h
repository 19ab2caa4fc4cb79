// The unwrap's vector kernel (probe/remap_kernel.cpp): the bilinear gather of
// apply_remap(src, CompiledRemap, out) in Google Highway, compiled for every x86 target
// Highway knows (SSSE3, SSE4, AVX2, AVX-512, and its scalar fallback) and dispatched at run
// time to the best one the CPU has. Internal to probe/: apply_remap calls it,
// tests/probe/remap_kernel_test.cpp compares it with the scalar loop on every compiled target.
#pragma once

#include <cstddef>
#include <cstdint>

#include "probe/remap.h"

namespace lp::detail {

// Output pixels of one run of taps (out[3i + c] for taps[i], i < count): the bilinear value
// of channel c (0 where the tap is invalid, index < 0), with the scalar loop's operations in
// its order (bit-identical). src is packed RGB, src_width pixels a row, and the taps are
// compile_remap's for it. Returns the count done from the start, a multiple of the vector
// width (the rest are the caller's; 0 on Highway's one-lane target); writes no mask. When
// it returns less than count it may also have written the first float of the next pixel:
// the caller's scalar loop writes that pixel next.
size_t remap_run_simd(const float* src, ptrdiff_t src_width, const CompiledRemap::Tap* taps, size_t count,
                      float* out);

// The Highway target remap_run_simd dispatches to on this CPU.
const char* remap_simd_target();

}  // namespace lp::detail
