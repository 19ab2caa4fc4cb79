// sampling/q2tree_sums.h: q2tree's bin sums and quad sums give a plain loop's bits on every
// compiled Highway target (every bin, the negative flag, every parent), with and without a
// mask, on odd map sizes, runs of a bin along a row and bins met again in later rows (some
// never), bins holding an earlier frame's sums (a first run must replace them, a later one
// add to them), the map's last pixel (the kernel's 16-byte load must not read past it), and
// negative, -0, huge and (in invalid pixels) NaN values. PrepareEquivalence.* and
// Q2TreeFloatBins.* check the whole q2tree prepare.
#include <gtest/gtest.h>

#include <hwy/aligned_allocator.h>
#include <hwy/targets.h>

#include <algorithm>
#include <cmath>
#include <cstring>
#include <limits>
#include <random>
#include <string>
#include <vector>

#include "sampling/q2tree_sums.h"

namespace lp {
namespace {

struct Case {
  size_t width = 0, height = 0, bins = 0;
  std::vector<float> rgb;
  std::vector<uint8_t> valid;
  std::vector<uint32_t> target;
  std::vector<float> row, col, cos_phi, sin_phi;
  detail::RunTags tags;  // bands, when tagged by the library (tag_bands)

  detail::RowSources view() const {
    return {target.data(),          row.data(),
            col.data(),             cos_phi.data(),
            sin_phi.data(),         tags.band_rows.data(),
            tags.band_later_runs.data(), tags.band_later_runs.size()};
  }
};

Case make_case(size_t width, size_t height, bool hostile, std::mt19937& rng) {
  Case c;
  c.width = width;
  c.height = height;
  const size_t pixels = width * height;
  std::lognormal_distribution<float> radiance(0.0f, 3.0f);
  c.rgb.resize(3 * pixels);
  for (float& v : c.rgb) v = radiance(rng);
  c.valid.resize(pixels);
  for (uint8_t& v : c.valid) v = rng() % 5 != 0;
  if (hostile) {
    for (size_t i = 0; i < pixels; i += 7) c.rgb[3 * i + rng() % 3] = -radiance(rng);
    for (size_t i = 3; i < pixels; i += 11) c.rgb[3 * i + 1] = -0.0f;
    for (size_t i = 5; i < pixels; i += 13) c.rgb[3 * i] = 3e38f;
    for (size_t i = 0; i < pixels; ++i)
      if (!c.valid[i] && i % 2) c.rgb[3 * i + 2] = std::numeric_limits<float>::quiet_NaN();
  }
  // Runs of 1 to 4 pixels share a bin, as along a healpix pixel (a run may go on into the
  // next row: it is two runs there); bins are drawn from half the pixel count, so some bins
  // collect several runs and some none. The first run of each bin is tagged.
  c.bins = std::max<size_t>(2, pixels / 2);
  c.target.resize(pixels);
  for (size_t i = 0; i < pixels;) {
    const uint32_t t = uint32_t(rng() % c.bins);
    for (size_t run = 1 + rng() % 4; run > 0 && i < pixels; --run) c.target[i++] = t;
  }
  std::vector<uint8_t> seen(c.bins, 0);
  for (size_t i = 0; i < pixels; ++i) {
    const uint32_t t = c.target[i];
    if ((i % width == 0 || (c.target[i - 1] & detail::kQ2Pixel) != t) && !seen[t])
      c.target[i] |= detail::kQ2FirstRun, seen[t] = 1;
  }
  std::uniform_real_distribution<float> unit(-1.0f, 1.0f);
  c.row.resize(8 * height);
  for (size_t v = 0; v < height; ++v) {
    float* r = c.row.data() + 8 * v;
    r[0] = r[1] = r[2] = 1.0f;
    r[3] = r[4] = unit(rng);
    r[5] = unit(rng);
    r[6] = 1e-3f * (1.0f + unit(rng));
  }
  c.col.resize(8 * width);
  for (size_t u = 0; u < width; ++u) {
    float* q = c.col.data() + 8 * u;
    q[0] = q[1] = q[2] = q[5] = 1.0f;
    q[3] = unit(rng);
    q[4] = unit(rng);
    c.cos_phi.push_back(q[3]);
    c.sin_phi.push_back(q[4]);
  }
  return c;
}

// The case's targets tagged by the library in `bands` bands of rows instead, after checking the
// tags against their definition: kQ2FirstRun where the test's own rule put it, kQ2LaterBand on
// exactly the runs whose bin an earlier band meets, and each band's count of them.
void tag_bands(Case& c, size_t bands) {
  std::vector<uint32_t> untagged(c.target.size());
  for (size_t i = 0; i < c.target.size(); ++i) untagged[i] = c.target[i] & detail::kQ2Pixel;
  std::vector<uint32_t> tagged = untagged;
  c.tags = detail::q2tree_tag_runs(tagged.data(), c.width, c.height, bands);
  bands = std::min(bands, c.height);  // no empty bands
  ASSERT_EQ(c.tags.band_rows.size(), bands + 1);
  ASSERT_EQ(c.tags.band_rows.front(), 0u);
  ASSERT_EQ(c.tags.band_rows.back(), c.height);
  std::vector<size_t> band_of_row(c.height);
  for (size_t b = 0; b < bands; ++b)
    for (size_t v = c.tags.band_rows[b]; v < c.tags.band_rows[b + 1]; ++v) band_of_row[v] = b;
  std::vector<size_t> first_band(c.bins, SIZE_MAX), later(bands, 0);
  for (size_t i = 0; i < untagged.size(); ++i) {
    const uint32_t t = untagged[i];
    const size_t band = band_of_row[i / c.width];
    const bool run_start = i % c.width == 0 || untagged[i - 1] != t;
    EXPECT_EQ(tagged[i] & detail::kQ2FirstRun, c.target[i] & detail::kQ2FirstRun) << "pixel " << i;
    EXPECT_EQ(bool(tagged[i] & detail::kQ2LaterBand), run_start && first_band[t] < band) << "pixel " << i;
    if (run_start && first_band[t] < band) ++later[band];
    first_band[t] = std::min(first_band[t], band);
  }
  for (size_t b = 0; b < bands; ++b) EXPECT_EQ(c.tags.band_later_runs[b], later[b]) << "band " << b;
  c.target = tagged;
}

// The definition written out plainly: each run's sum over its valid pixels, then added to
// its bin, or replacing it on the bin's first run. Row order, one pass: bands do not enter.
bool plain_bins(const Case& c, std::vector<float>& bins) {
  bool negative = false;
  for (size_t v = 0; v < c.height; ++v)
    for (size_t u = 0; u < c.width;) {
      const uint32_t tagged = c.target[v * c.width + u], t = tagged & detail::kQ2Pixel;
      float run[8] = {0, 0, 0, 0, 0, 0, 0, 0};
      for (; u < c.width && (c.target[v * c.width + u] & detail::kQ2Pixel) == t; ++u) {
        const size_t i = v * c.width + u;
        if (!c.valid.empty() && !c.valid[i]) continue;
        const float* row = c.row.data() + 8 * v;
        const float* col = c.col.data() + 8 * u;
        const float r = c.rgb[3 * i] * row[6], g = c.rgb[3 * i + 1] * row[6], b = c.rgb[3 * i + 2] * row[6];
        negative |= (r < 0) | (g < 0) | (b < 0);
        const float l = (0.2126f * r + 0.7152f * g) + (0.0722f * b + 0.0f);
        run[0] += r, run[1] += g, run[2] += b;
        for (int k = 3; k < 8; ++k) run[k] += l * (row[k] * col[k]);
      }
      float* bin = bins.data() + 8 * t;
      for (int k = 0; k < 8; ++k) bin[k] = (tagged & detail::kQ2FirstRun ? 0.0f : bin[k]) + run[k];
    }
  return negative;
}

template <typename T>
bool same_bits(const T* a, const std::vector<T>& b) {
  return std::memcmp(a, b.data(), b.size() * sizeof(T)) == 0;
}

// Bins in 32-byte aligned memory, each starting at `start` (the kernel adds to what is there).
hwy::AlignedFreeUniquePtr<float[]> aligned_bins(const std::vector<float>& start) {
  auto bins = hwy::AllocateAligned<float>(start.size());
  std::copy(start.begin(), start.end(), bins.get());
  return bins;
}

TEST(Q2treeSums, EveryTargetEqualsThePlainLoopBitForBit) {
  std::mt19937 rng(23);
  const std::vector<int64_t> targets = hwy::SupportedAndGeneratedTargets();
  ASSERT_GE(targets.size(), 2u);
  const size_t sizes[][2] = {{1, 1}, {2, 1}, {7, 3}, {37, 19}, {64, 16}, {202, 101}};
  size_t negative_cases = 0;
  for (const auto& size : sizes)
    for (int variant = 0; variant < 4; ++variant) {
      const bool masked = variant & 1, hostile = variant & 2;
      Case c = make_case(size[0], size[1], hostile, rng);
      const uint8_t* mask = masked ? c.valid.data() : nullptr;
      if (!masked) {  // the NaNs stand in invalid pixels only
        for (float& v : c.rgb)
          if (std::isnan(v)) v = 1.5f;
        c.valid.clear();
      }
      std::vector<float> start(8 * c.bins, 0.0f);
      if (variant != 0)  // an earlier frame's sums: first runs replace them, later runs add
        for (size_t k = 0; k < start.size(); ++k) start[k] = 0.25f + float(k % 7);
      std::vector<float> expected = start;
      const bool negative = plain_bins(c, expected);
      negative_cases += negative;
      // One level up, written out (the bins padded to whole quads with zeros).
      const size_t parents = (c.bins + 3) / 4;
      std::vector<float> children(32 * parents, 0.0f);
      std::copy(expected.begin(), expected.end(), children.begin());
      std::vector<float> expected_parents(8 * parents);
      for (size_t p = 0; p < parents; ++p)
        for (int k = 0; k < 8; ++k) {
          const float* q = children.data() + 32 * p + k;
          expected_parents[8 * p + k] = (q[0] + q[8]) + (q[16] + q[24]);
        }

      const std::string what = std::to_string(size[0]) + "x" + std::to_string(size[1]) + (masked ? ", masked" : "") +
                               (hostile ? ", hostile" : "");
      auto scalar = aligned_bins(start);
      EXPECT_EQ(detail::q2tree_bin_sums_scalar(c.rgb.data(), mask, c.width, c.height, c.view(), scalar.get()), negative)
          << what;
      EXPECT_TRUE(same_bits(scalar.get(), expected)) << "scalar, " << what;
      auto child_bins = aligned_bins(children);
      auto parent_bins = aligned_bins(std::vector<float>(8 * parents, -1.0f));
      detail::q2tree_quad_sums_scalar(child_bins.get(), parents, parent_bins.get());
      EXPECT_TRUE(same_bits(parent_bins.get(), expected_parents)) << "scalar quads, " << what;
      for (const int64_t target : targets) {
        hwy::SetSupportedTargetsForTest(target);
        auto bins = aligned_bins(start);
        EXPECT_EQ(detail::q2tree_bin_sums(c.rgb.data(), mask, c.width, c.height, c.view(), bins.get()), negative)
            << hwy::TargetName(target) << ", " << what;
        EXPECT_TRUE(same_bits(bins.get(), expected)) << hwy::TargetName(target) << ", " << what;
        auto parent = aligned_bins(std::vector<float>(8 * parents, -1.0f));
        detail::q2tree_quad_sums(child_bins.get(), parents, parent.get());
        EXPECT_TRUE(same_bits(parent.get(), expected_parents)) << hwy::TargetName(target) << " quads, " << what;
      }
      hwy::SetSupportedTargetsForTest(0);
    }
  EXPECT_GT(negative_cases, 4u);  // the hostile maps did reach the flag
}

// Bands of rows summed in parallel, with the runs into an earlier band's bins joined after,
// give the one-pass loop's bits on every target (in particular where bins straddle bands, a
// band holds a single row, or there are more bands than rows).
TEST(Q2treeSums, BandsOfRowsGiveTheOnePassBitsOnEveryTarget) {
  std::mt19937 rng(31);
  const size_t sizes[][2] = {{1, 1}, {7, 3}, {37, 19}, {202, 101}};
  size_t later_runs = 0;
  for (const auto& size : sizes)
    for (const size_t bands : {2, 3, 8})
      for (int variant = 0; variant < 2; ++variant) {
        const bool hostile = variant == 1;
        Case c = make_case(size[0], size[1], hostile, rng);
        tag_bands(c, bands);
        for (const uint32_t n : c.tags.band_later_runs) later_runs += n;
        std::vector<float> start(8 * c.bins);
        for (size_t k = 0; k < start.size(); ++k) start[k] = 0.25f + float(k % 7);
        std::vector<float> expected = start;
        const bool negative = plain_bins(c, expected);
        const std::string what = std::to_string(size[0]) + "x" + std::to_string(size[1]) + ", " +
                                 std::to_string(bands) + " bands" + (hostile ? ", hostile" : "");
        for (const int64_t target : hwy::SupportedAndGeneratedTargets()) {
          hwy::SetSupportedTargetsForTest(target);
          auto bins = aligned_bins(start);
          EXPECT_EQ(detail::q2tree_bin_sums(c.rgb.data(), c.valid.data(), c.width, c.height, c.view(), bins.get()),
                    negative)
              << hwy::TargetName(target) << ", " << what;
          EXPECT_TRUE(same_bits(bins.get(), expected)) << hwy::TargetName(target) << ", " << what;
        }
        hwy::SetSupportedTargetsForTest(0);
        // The plain loop reads the tagged targets too, in one pass.
        auto scalar = aligned_bins(start);
        detail::q2tree_bin_sums_scalar(c.rgb.data(), c.valid.data(), c.width, c.height, c.view(), scalar.get());
        EXPECT_TRUE(same_bits(scalar.get(), expected)) << "scalar, " << what;
      }
  EXPECT_GT(later_runs, 1000u);  // the joins were exercised
}

// Three levels in one pass equal three passes of the plain quad sums, on every target.
TEST(Q2treeSums, ThreeLevelsAtOnceEqualThreePlainPasses) {
  std::mt19937 rng(5);
  std::lognormal_distribution<float> value(0.0f, 4.0f);
  const size_t groups = 5;
  std::vector<float> children(8 * 64 * groups);
  for (size_t k = 0; k < children.size(); ++k) children[k] = k % 17 == 0 ? -0.0f : k % 5 ? value(rng) : -value(rng);
  std::vector<float> level1(8 * 16 * groups), level2(8 * 4 * groups), level3(8 * groups);
  auto child_bins = aligned_bins(children);
  auto l1 = aligned_bins(level1), l2 = aligned_bins(level2), l3 = aligned_bins(level3);
  detail::q2tree_quad_sums_scalar(child_bins.get(), 16 * groups, l1.get());
  detail::q2tree_quad_sums_scalar(l1.get(), 4 * groups, l2.get());
  detail::q2tree_quad_sums_scalar(l2.get(), groups, l3.get());
  std::copy(l1.get(), l1.get() + level1.size(), level1.begin());
  std::copy(l2.get(), l2.get() + level2.size(), level2.begin());
  std::copy(l3.get(), l3.get() + level3.size(), level3.begin());
  EXPECT_NE(level3[0], 0.0f);
  for (const int64_t target : hwy::SupportedAndGeneratedTargets()) {
    hwy::SetSupportedTargetsForTest(target);
    auto a = aligned_bins(std::vector<float>(level1.size(), -1.0f));
    auto b = aligned_bins(std::vector<float>(level2.size(), -1.0f));
    auto c = aligned_bins(std::vector<float>(level3.size(), -1.0f));
    detail::q2tree_quad_sums3(child_bins.get(), groups, a.get(), b.get(), c.get());
    EXPECT_TRUE(same_bits(a.get(), level1)) << hwy::TargetName(target);
    EXPECT_TRUE(same_bits(b.get(), level2)) << hwy::TargetName(target);
    EXPECT_TRUE(same_bits(c.get(), level3)) << hwy::TargetName(target);
  }
  hwy::SetSupportedTargetsForTest(0);
}

// The plain loop itself against numbers worked out by hand: two pixels, one invalid, both
// in bin 1 (its first run, so the 7s there go); bin 0 untouched.
TEST(Q2treeSums, ScalarLoopFollowsItsDefinition) {
  const std::vector<float> rgb = {1, 2, 4, 8, 16, 32};
  const uint8_t valid[2] = {1, 0};
  const uint32_t target[2] = {1 | detail::kQ2FirstRun, 1};
  const float row[8] = {1, 1, 1, 0.25f, 0.25f, 2.0f, 0.5f, 0};
  const float col[16] = {1, 1, 1, 1.0f, -1.0f, 1, 0, 0, 1, 1, 1, 0.5f, 3.0f, 1, 0, 0};
  const detail::RowSources s{target, row, col};
  auto bins = aligned_bins(std::vector<float>(16, 7.0f));
  EXPECT_FALSE(detail::q2tree_bin_sums_scalar(rgb.data(), valid, 2, 1, s, bins.get()));
  const float l = (0.2126f * 0.5f + 0.7152f * 1.0f) + 0.0722f * 2.0f;  // pixel 0 only: pixel 1 is invalid
  const float* b = bins.get() + 8;
  for (int k = 0; k < 8; ++k) EXPECT_EQ(bins[k], 7.0f);
  EXPECT_EQ(b[0], 0.5f);
  EXPECT_EQ(b[1], 1.0f);
  EXPECT_EQ(b[2], 2.0f);
  EXPECT_EQ(b[3], l * 0.25f);
  EXPECT_EQ(b[4], -l * 0.25f);
  EXPECT_EQ(b[5], l * 2.0f);
  // Once more without the tag: the run adds to what the bin holds.
  const uint32_t again[2] = {1, 1};
  const detail::RowSources s2{again, row, col};
  EXPECT_FALSE(detail::q2tree_bin_sums_scalar(rgb.data(), valid, 2, 1, s2, bins.get()));
  EXPECT_EQ(b[0], 1.0f);
  EXPECT_EQ(b[5], l * 2.0f + l * 2.0f);
}

}  // namespace
}  // namespace lp
