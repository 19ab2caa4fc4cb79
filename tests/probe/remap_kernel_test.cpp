// The unwrap's vector kernel (probe/remap_kernel.cpp) on every Highway target compiled into
// it and supported by this CPU, against the scalar loop (RemapOptions::simd = false): the same
// image bit for bit and the same valid mask.
#include <gtest/gtest.h>
#include <hwy/targets.h>

#include <algorithm>
#include <cmath>
#include <cstring>
#include <limits>
#include <random>
#include <string>
#include <vector>

#include "probe/remap.h"
#include "probe/remap_kernel.h"

namespace lp {
namespace {

// Random coordinates over the image and a margin around it (off the image: invalid), NaN,
// and the border cases of the tap: exactly 0, the first and last pixel centres, the far edge.
RemapTable random_table(int out_w, int out_h, int src_w, int src_h, std::mt19937& rng) {
  RemapTable t;
  t.out_width = out_w;
  t.out_height = out_h;
  std::uniform_real_distribution<float> ux(-1.0f, float(src_w) + 1.0f), uy(-1.0f, float(src_h) + 1.0f);
  std::uniform_int_distribution<int> kind(0, 19);
  const float nan = std::numeric_limits<float>::quiet_NaN();
  for (int i = 0; i < out_w * out_h; ++i) {
    float x = ux(rng), y = uy(rng);
    switch (kind(rng)) {
      case 0: x = nan; break;
      case 1: y = 0.0f; break;
      case 2: x = 0.5f; break;
      case 3: x = float(src_w) - 0.5f; break;
      case 4: y = float(src_h); break;
      default: break;
    }
    t.src_x.push_back(x);
    t.src_y.push_back(y);
  }
  return t;
}

bool same_bits(const std::vector<float>& a, const std::vector<float>& b) {
  return a.size() == b.size() && std::memcmp(a.data(), b.data(), a.size() * sizeof(float)) == 0;
}

TEST(RemapKernel, EveryTargetEqualsTheScalarLoopBitForBit) {
  const std::vector<int64_t> targets = hwy::SupportedAndGeneratedTargets();
  ASSERT_GE(targets.size(), 2u);  // on x86-64 at least the scalar fallback and SSSE3
  std::mt19937 rng(5);
  std::uniform_real_distribution<float> value(-2.0f, 50.0f);
  struct Case {
    int src_w, src_h, out_w, out_h;
    bool all_valid;  // coordinates inside the image only (no mask in the output)
  };
  // Output sizes around every vector length (4, 8, 16 pixels; 1 for the scalar target): whole
  // runs, tails, runs shorter than one vector.
  const Case cases[] = {{2, 2, 3, 1, false}, {5, 3, 17, 3, false}, {37, 21, 31, 7, false},
                        {64, 48, 67, 5, false}, {40, 30, 64, 9, true}, {13, 9, 5, 2, true}};
  for (const Case& c : cases) {
    RgbImage src;
    src.width = c.src_w;
    src.height = c.src_h;
    for (int i = 0; i < 3 * c.src_w * c.src_h; ++i) src.rgb.push_back(value(rng));
    RemapTable table = random_table(c.out_w, c.out_h, c.src_w, c.src_h, rng);
    if (c.all_valid)
      for (size_t i = 0; i < table.src_x.size(); ++i) {
        table.src_x[i] = std::clamp(std::isnan(table.src_x[i]) ? 1.0f : table.src_x[i], 0.0f, float(c.src_w));
        table.src_y[i] = std::clamp(table.src_y[i], 0.0f, float(c.src_h));
      }
    const CompiledRemap compiled = compile_remap(table, c.src_w, c.src_h);
    ASSERT_EQ(compiled.any_invalid, !c.all_valid);
    for (const int threads : {1, 2}) {
      RemapOptions o;
      o.threads = threads;
      o.simd = false;
      RgbImage scalar;
      apply_remap(src, compiled, &scalar, o);
      o.simd = true;
      for (const int64_t target : targets) {
        hwy::SetSupportedTargetsForTest(target);
        ASSERT_STREQ(detail::remap_simd_target(), hwy::TargetName(target));  // the dispatch took it
        RgbImage vec;
        apply_remap(src, compiled, &vec, o);
        const std::string where = std::string(hwy::TargetName(target)) + ", source " + std::to_string(c.src_w) +
                                  "x" + std::to_string(c.src_h) + ", output " + std::to_string(c.out_w) + "x" +
                                  std::to_string(c.out_h) + ", threads " + std::to_string(threads);
        EXPECT_TRUE(same_bits(vec.rgb, scalar.rgb)) << where;
        EXPECT_EQ(vec.valid, scalar.valid) << where;
      }
      hwy::SetSupportedTargetsForTest(0);
    }
  }
}

// The kernel alone, without the scalar loop finishing anything: a run of whole vectors on the
// best target gives the scalar values, and invalid taps give 0.
TEST(RemapKernel, AWholeRunIsTheKernelsAndMatchesTheScalarLoop) {
  RgbImage src;
  src.width = 9;
  src.height = 7;
  std::mt19937 rng(8);
  std::uniform_real_distribution<float> value(0.0f, 10.0f);
  for (int i = 0; i < 3 * 9 * 7; ++i) src.rgb.push_back(value(rng));
  const RemapTable table = random_table(64, 1, 9, 7, rng);
  const CompiledRemap compiled = compile_remap(table, 9, 7);
  RgbImage scalar;
  RemapOptions o;
  o.threads = 1;
  o.simd = false;
  apply_remap(src, compiled, &scalar, o);
  std::vector<float> out(3 * 64, -1.0f);
  ASSERT_EQ(detail::remap_run_simd(src.rgb.data(), 9, compiled.taps.data(), 64, out.data()), 64u);
  EXPECT_TRUE(same_bits(out, scalar.rgb));
  size_t invalid = 0;
  for (size_t i = 0; i < 64; ++i)
    if (compiled.taps[i].index < 0) {
      ++invalid;
      EXPECT_EQ(out[3 * i] + out[3 * i + 1] + out[3 * i + 2], 0.0f);
    }
  EXPECT_GT(invalid, 0u);
}

}  // namespace
}  // namespace lp
