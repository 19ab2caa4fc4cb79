#include "core/highway_targets.h"

#include <hwy/targets.h>  // the HWY_* target bits only: nothing of libhwy is called

#if defined(__x86_64__) || defined(__i386__)
#include <cpuid.h>
#endif

namespace lp {

#if defined(__x86_64__) || defined(__i386__)
namespace {

// The feature groups of Highway 1.0.3's hwy/targets.cc (DetectTargets), bit for bit: a
// target is supported when every feature of its group is (BMI2/FMA and F16C included, as
// Highway builds by default).
enum Feature : int {
  kSSE, kSSE2, kSSE3, kSSSE3, kSSE41, kSSE42, kCLMUL, kAES, kAVX, kAVX2, kF16C, kFMA, kLZCNT, kBMI, kBMI2,
  kAVX512F, kAVX512VL, kAVX512DQ, kAVX512BW, kVNNI, kVPCLMULQDQ, kVBMI, kVBMI2, kVAES, kPOPCNTDQ, kBITALG
};
constexpr uint64_t bit(Feature f) { return uint64_t(1) << f; }
constexpr uint64_t kGroupSSSE3 = bit(kSSE) | bit(kSSE2) | bit(kSSE3) | bit(kSSSE3);
constexpr uint64_t kGroupSSE4 = bit(kSSE41) | bit(kSSE42) | bit(kCLMUL) | bit(kAES) | kGroupSSSE3;
constexpr uint64_t kGroupAVX2 =
    bit(kAVX) | bit(kAVX2) | bit(kLZCNT) | bit(kBMI) | bit(kBMI2) | bit(kFMA) | bit(kF16C) | kGroupSSE4;
constexpr uint64_t kGroupAVX3 = bit(kAVX512F) | bit(kAVX512VL) | bit(kAVX512DQ) | bit(kAVX512BW) | kGroupAVX2;
constexpr uint64_t kGroupAVX3_DL = bit(kVNNI) | bit(kVPCLMULQDQ) | bit(kVBMI) | bit(kVBMI2) | bit(kVAES) |
                                   bit(kPOPCNTDQ) | bit(kBITALG) | kGroupAVX3;

bool has(uint32_t reg, int index) { return (reg >> index) & 1u; }

}  // namespace

int64_t detect_highway_targets() {
  int64_t targets = HWY_SCALAR | HWY_EMU128;
  unsigned a = 0, b = 0, c = 0, d = 0;
  __cpuid_count(0, 0, a, b, c, d);
  const unsigned max_level = a;
  uint64_t flags = 0;
  __cpuid_count(1, 0, a, b, c, d);
  const auto set = [&](bool on, Feature f) { flags |= on ? bit(f) : 0; };
  set(has(d, 25), kSSE), set(has(d, 26), kSSE2), set(has(c, 0), kSSE3), set(has(c, 1), kCLMUL);
  set(has(c, 9), kSSSE3), set(has(c, 12), kFMA), set(has(c, 19), kSSE41), set(has(c, 20), kSSE42);
  set(has(c, 25), kAES), set(has(c, 28), kAVX), set(has(c, 29), kF16C);
  const bool osxsave = has(c, 27);
  __cpuid_count(0x80000001u, 0, a, b, c, d);
  set(has(c, 5), kLZCNT);
  if (max_level >= 7) {
    __cpuid_count(7, 0, a, b, c, d);
    set(has(b, 3), kBMI), set(has(b, 5), kAVX2), set(has(b, 8), kBMI2);
    set(has(b, 16), kAVX512F), set(has(b, 17), kAVX512DQ), set(has(b, 30), kAVX512BW), set(has(b, 31), kAVX512VL);
    set(has(c, 1), kVBMI), set(has(c, 6), kVBMI2), set(has(c, 9), kVAES), set(has(c, 10), kVPCLMULQDQ);
    set(has(c, 11), kVNNI), set(has(c, 12), kBITALG), set(has(c, 14), kPOPCNTDQ);
  }
  const auto all = [&](uint64_t group) { return (flags & group) == group; };
  if (all(kGroupAVX3_DL)) targets |= HWY_AVX3_DL;
  if (all(kGroupAVX3)) targets |= HWY_AVX3;
  if (all(kGroupAVX2)) targets |= HWY_AVX2;
  if (all(kGroupSSE4)) targets |= HWY_SSE4;
  if (all(kGroupSSSE3)) targets |= HWY_SSSE3;
  // Registers the OS does not save across context switches must not be used (XCR0).
  if (osxsave) {
    uint32_t xcr0 = 0, xcr0_high = 0;
    asm volatile("xgetbv" : "=a"(xcr0), "=d"(xcr0_high) : "c"(0));
    const int64_t avx3 = HWY_AVX3 | HWY_AVX3_DL, avx2 = HWY_AVX2 | avx3;
    if (!has(xcr0, 1)) targets &= ~(HWY_SSSE3 | HWY_SSE4 | avx2);        // XMM
    if (!has(xcr0, 2)) targets &= ~avx2;                                 // YMM
    if (!has(xcr0, 5) || !has(xcr0, 6) || !has(xcr0, 7)) targets &= ~avx3;  // opmask, ZMM
  }
  return targets;
}

#else

int64_t detect_highway_targets() { return 0; }

#endif

}  // namespace lp
