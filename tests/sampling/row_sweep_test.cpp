// sampling/row_sweep.h: the row kernels of the samplers' prepare give the scalar loops' bits
// on every compiled Highway target (colours, clamped luminance with and without the colours,
// the bad-pixel flag, the channel sums in both orders, the summed-area table rows), forwards
// and reversed, with and without a mask, on widths around every vector length, with
// negative, NaN, -0 and huge values among the pixels.
#include <gtest/gtest.h>

#include <hwy/targets.h>

#include <cmath>
#include <cstring>
#include <limits>
#include <random>
#include <string>
#include <vector>

#include "sampling/row_sweep.h"

namespace lp {
namespace {

template <class T>
bool same_bits(const std::vector<T>& a, const std::vector<T>& b) {
  return a.size() == b.size() && std::memcmp(a.data(), b.data(), a.size() * sizeof(T)) == 0;
}

std::vector<float> random_row(size_t pixels, std::mt19937& rng, bool hostile) {
  std::lognormal_distribution<float> radiance(0.0f, 3.0f);
  std::vector<float> row(3 * pixels);
  for (float& v : row) v = radiance(rng);
  if (hostile && pixels > 2) {  // values whose clamp or sign the kernel must get right
    row[1] = -0.0f;
    row[3] = -2.0f, row[4] = 0.1f, row[5] = 0.1f;  // negative luminance
    row[3 * pixels - 2] = std::numeric_limits<float>::quiet_NaN();
    row[6 % row.size()] = 3e38f;
  }
  return row;
}

TEST(RowSweep, EveryTargetEqualsTheScalarLoopsBitForBit) {
  std::mt19937 rng(11);
  const std::vector<int64_t> targets = hwy::SupportedAndGeneratedTargets();
  ASSERT_GE(targets.size(), 2u);  // at least the fallback and SSSE3: one would test nothing
  const size_t widths[] = {1, 2, 3, 7, 8, 9, 15, 16, 17, 33, 360, 1025};
  size_t flagged = 0;
  for (const size_t w : widths)
    for (int variant = 0; variant < 8; ++variant) {
      const bool reversed = variant & 1, masked = variant & 2, hostile = variant & 4;
      const std::vector<float> rgb = random_row(w, rng, hostile);
      std::vector<uint8_t> valid(w);
      for (uint8_t& v : valid) v = rng() % 4 != 0;
      const uint8_t* mask = masked ? valid.data() : nullptr;
      std::vector<float> colour0(3 * w), lum0(w);
      const bool bad0 = detail::colour_and_luminance_row_scalar(rgb.data(), mask, w, reversed, colour0.data(),
                                                                lum0.data());
      flagged += bad0;
      // 13 rows of sums: the kernel's lockstep groups of eight and four, and one row on its own.
      constexpr size_t kRows = 13;
      std::vector<std::vector<float>> rows;
      const float* row_ptr[kRows];
      for (size_t k = 0; k < kRows; ++k) {
        rows.push_back(random_row(w, rng, false));
        row_ptr[k] = rows[k].data();
      }
      std::vector<double> sums_single0(6 * kRows, 0.5), sums_pairs0(6 * kRows, 0.25);
      detail::add_channel_sums_scalar(row_ptr, kRows, w, false, sums_single0.data());
      detail::add_channel_sums_scalar(row_ptr, kRows, w, true, sums_pairs0.data());
      for (const int64_t target : targets) {
        hwy::SetSupportedTargetsForTest(target);
        ASSERT_STREQ(detail::row_sweep_simd_target(), hwy::TargetName(target));
        const std::string where = std::string(hwy::TargetName(target)) + ", width " + std::to_string(w) +
                                  (reversed ? ", reversed" : "") + (masked ? ", masked" : "") +
                                  (hostile ? ", hostile" : "");
        std::vector<float> colour(3 * w), lum(w);
        const bool bad = detail::colour_and_luminance_row(rgb.data(), mask, w, reversed, colour.data(), lum.data());
        EXPECT_EQ(bad, bad0) << where;
        EXPECT_TRUE(same_bits(colour, colour0)) << where;
        EXPECT_TRUE(same_bits(lum, lum0)) << where;
        // Without a colour buffer (the luminances only): the same luminances and flag.
        std::vector<float> lum_only(w, -1.0f);
        EXPECT_EQ(detail::colour_and_luminance_row(rgb.data(), mask, w, reversed, nullptr, lum_only.data()), bad0)
            << where;
        EXPECT_TRUE(same_bits(lum_only, lum0)) << where;
        std::vector<double> single(6 * kRows, 0.5), pairs(6 * kRows, 0.25);
        detail::add_channel_sums(row_ptr, kRows, w, false, single.data());
        detail::add_channel_sums(row_ptr, kRows, w, true, pairs.data());
        // Single sums use entries 0..2 of each row's six; the rest must stay untouched.
        EXPECT_TRUE(same_bits(single, sums_single0)) << where;
        EXPECT_TRUE(same_bits(pairs, sums_pairs0)) << where;
      }
      hwy::SetSupportedTargetsForTest(0);
    }
  EXPECT_GT(flagged, 10u);  // the hostile rows did reach the flag
}

// A summed-area table's rows, and rows' own running sums, from the kernels equal the plain
// loops' on every target: 15 rows (the kernels' groups of eight and four, then three left
// to the plain loop), widths around every vector length, luminances from zero to huge,
// weights per row.
TEST(RowSweep, RunningSumRowsEqualThePlainLoopsOnEveryTarget) {
  std::mt19937 rng(23);
  std::lognormal_distribution<float> radiance(0.0f, 3.0f);
  const std::vector<int64_t> targets = hwy::SupportedAndGeneratedTargets();
  constexpr size_t kRows = 15;
  for (const size_t w : {1, 2, 3, 4, 5, 7, 8, 9, 15, 16, 17, 33, 360, 1025}) {
    std::vector<std::vector<float>> lum(kRows, std::vector<float>(w));
    double weight[kRows];
    const float* lum_ptr[kRows];
    for (size_t k = 0; k < kRows; ++k) {
      for (float& v : lum[k]) v = rng() % 5 == 0 ? 0.0f : radiance(rng);
      weight[k] = 1e-3 * (1 + double(k)) + 1e-7 * double(rng() % 1000);
      lum_ptr[k] = lum[k].data();
    }
    lum[1][0] = 3e38f;
    std::vector<double> above(w + 1);
    for (size_t x = 1; x <= w; ++x) above[x] = above[x - 1] + 0.1 * double(rng() % 100);
    // Rows of width + 1 entries with a guard entry on each side that must stay untouched.
    auto run = [&](auto kernel) {
      std::vector<double> table(kRows * (w + 3), -7.0);
      double* out[kRows];
      for (size_t k = 0; k < kRows; ++k) out[k] = table.data() + k * (w + 3) + 1;
      kernel(lum_ptr, weight, kRows, w, above.data(), out);
      return table;
    };
    const std::vector<double> want = run(detail::summed_area_rows_scalar);
    // The plain loop follows the definition: row 0 starts from `above`.
    double sum = 0;
    for (size_t x = 0; x < w; ++x) sum += weight[0] * double(lum[0][x]);
    ASSERT_EQ(want[1 + w], above[w] + sum);
    ASSERT_EQ(want[0], -7.0);
    ASSERT_EQ(want[1], 0.0);
    // Each row's own running sums (hemigon's), from the same rows.
    auto own = [&](auto kernel) {
      return run([&](const float* const* l, const double*, size_t count, size_t width, const double*,
                     double* const* out) { kernel(l, count, width, out); });
    };
    const std::vector<double> want_own = own(detail::running_sums_rows_scalar);
    sum = 0;
    for (size_t x = 0; x < w; ++x) sum += double(lum[kRows - 1][x]);
    ASSERT_EQ(want_own[(kRows - 1) * (w + 3) + 1 + w], sum);
    ASSERT_EQ(want_own[(kRows - 1) * (w + 3) + w + 2], -7.0);
    for (const int64_t target : targets) {
      hwy::SetSupportedTargetsForTest(target);
      EXPECT_TRUE(same_bits(run(detail::summed_area_rows), want)) << hwy::TargetName(target) << ", width " << w;
      EXPECT_TRUE(same_bits(own(detail::running_sums_rows), want_own)) << hwy::TargetName(target) << ", width " << w;
    }
    hwy::SetSupportedTargetsForTest(0);
  }
}

// The scalar loops themselves against the definitions written out by hand.
TEST(RowSweep, ScalarLoopsFollowTheirDefinition) {
  const std::vector<float> rgb = {1, 2, 3, -5, 0, 0, 4, 5, 6};
  const uint8_t valid[3] = {1, 1, 0};
  std::vector<float> colour(9), lum(3);
  EXPECT_TRUE(detail::colour_and_luminance_row_scalar(rgb.data(), valid, 3, true, colour.data(), lum.data()));
  // Reversed: pixel 2 (invalid: zero), then pixel 1 (negative luminance: clamped), pixel 0.
  EXPECT_EQ(colour, (std::vector<float>{0, 0, 0, -5, 0, 0, 1, 2, 3}));
  EXPECT_EQ(lum[0], 0.0f);
  EXPECT_EQ(lum[1], 0.0f);
  EXPECT_EQ(lum[2], 0.2126f * 1 + 0.7152f * 2 + 0.0722f * 3);
  const float* rows[1] = {rgb.data()};
  double pairs[6] = {0, 0, 0, 0, 0, 0};
  detail::add_channel_sums_scalar(rows, 1, 3, true, pairs);
  EXPECT_EQ(pairs[0], 5.0);   // even pixels 0 and 2
  EXPECT_EQ(pairs[3], -5.0);  // odd pixel 1
  double single[6] = {0, 0, 0, 9, 9, 9};
  detail::add_channel_sums_scalar(rows, 1, 3, false, single);
  EXPECT_EQ(single[2], 9.0);
  EXPECT_EQ(single[3], 9.0);
}

}  // namespace
}  // namespace lp
