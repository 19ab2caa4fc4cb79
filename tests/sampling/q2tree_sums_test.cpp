// sampling/q2tree_sums.h: q2tree's nested-order prefix sums give a plain loop's bits on every
// compiled Highway target (the running sums in every written entry, the negative flag), with
// and without a mask, on odd map sizes, sources in a scrambled order that ends pixels at
// irregular places and leaves some entries unwritten, the map's last pixel among them (the
// kernel's 16-byte load must not read past it), and negative, -0, huge and (in invalid
// pixels) NaN values. PrepareEquivalence.* checks the whole q2tree prepare against the lists
// of the scalar code it replaced.
#include <gtest/gtest.h>

#include <hwy/targets.h>

#include <algorithm>
#include <cmath>
#include <cstring>
#include <limits>
#include <numeric>
#include <random>
#include <string>
#include <vector>

#include "sampling/q2tree_sums.h"

namespace lp {
namespace {

constexpr double kUnwritten = -12345.0;

struct Case {
  size_t width = 0, height = 0;
  std::vector<float> rgb;
  std::vector<uint8_t> valid;
  std::vector<uint32_t> source, entry;
  std::vector<double> row, col;
  size_t entries = 0;

  detail::NestedSources view() const { return {source.data(), entry.data(), source.size(), row.data(), col.data()}; }
};

// Sources: a random subset of the pixels (the last one always in) in random order, grouped
// into healpix "pixels" of 1 to 5 sources with empty ones between some of them.
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
  std::vector<uint32_t> order(pixels);
  std::iota(order.begin(), order.end(), 0u);
  std::shuffle(order.begin(), order.end(), rng);
  order.resize(pixels - pixels / 4);
  if (std::find(order.begin(), order.end(), uint32_t(pixels - 1)) == order.end()) order[order.size() / 2] = uint32_t(pixels - 1);
  uint32_t entry = 1 + rng() % 3;
  for (size_t k = 0; k < order.size();) {
    const size_t group = 1 + rng() % 5;
    for (size_t g = 0; g < group && k < order.size(); ++g, ++k) {
      c.source.push_back(uint32_t(order[k] % width) | uint32_t(order[k] / width) << 16);
      c.entry.push_back(entry);
    }
    entry += 1 + (rng() % 4 == 0 ? rng() % 3 : 0);
  }
  c.entries = entry + 1;
  std::uniform_real_distribution<double> unit(-1.0, 1.0);
  c.row.resize(4 * height);
  for (size_t v = 0; v < height; ++v) {
    c.row[4 * v] = 1e-3 * (1.0 + unit(rng));
    c.row[4 * v + 1] = unit(rng);
    c.row[4 * v + 2] = unit(rng);
  }
  c.col.resize(2 * width);
  for (double& x : c.col) x = unit(rng);
  return c;
}

// The definition written as q2tree's scalar prepare had it: invalid pixels skipped.
bool plain_sums(const Case& c, std::vector<double>& prefix) {
  double s[6] = {0, 0, 0, 0, 0, 0};
  bool negative = false;
  for (size_t k = 0; k < c.source.size(); ++k) {
    const size_t u = c.source[k] & 0xFFFF, v = c.source[k] >> 16, i = v * c.width + u;
    if (c.valid.empty() || c.valid[i]) {
      const double dw = c.row[4 * v];
      const double r = c.rgb[3 * i] * dw, g = c.rgb[3 * i + 1] * dw, b = c.rgb[3 * i + 2] * dw;
      negative |= (r < 0) | (g < 0) | (b < 0);
      const double l = 0.2126 * r + 0.7152 * g + 0.0722 * b;
      const double t = l * c.row[4 * v + 1];
      s[0] += r, s[1] += g, s[2] += b;
      s[3] += t * c.col[2 * u], s[4] += t * c.col[2 * u + 1], s[5] += l * c.row[4 * v + 2];
    }
    std::copy(s, s + 6, prefix.begin() + 6 * c.entry[k]);
  }
  return negative;
}

bool same_bits(const std::vector<double>& a, const std::vector<double>& b) {
  return a.size() == b.size() && std::memcmp(a.data(), b.data(), a.size() * sizeof(double)) == 0;
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
      std::vector<double> expected(6 * c.entries, kUnwritten);
      const bool negative = plain_sums(c, expected);
      negative_cases += negative;
      std::vector<double> scalar(6 * c.entries, kUnwritten);
      const std::string what = std::to_string(size[0]) + "x" + std::to_string(size[1]) + (masked ? ", masked" : "") +
                               (hostile ? ", hostile" : "");
      EXPECT_EQ(detail::q2tree_prefix_sums_scalar(c.rgb.data(), mask, c.width, c.height, c.view(), scalar.data()),
                negative)
          << what;
      EXPECT_TRUE(same_bits(scalar, expected)) << "scalar, " << what;
      for (const int64_t target : targets) {
        hwy::SetSupportedTargetsForTest(target);
        std::vector<double> prefix(6 * c.entries, kUnwritten);
        EXPECT_EQ(detail::q2tree_prefix_sums(c.rgb.data(), mask, c.width, c.height, c.view(), prefix.data()), negative)
            << hwy::TargetName(target) << ", " << what;
        EXPECT_TRUE(same_bits(prefix, expected)) << hwy::TargetName(target) << ", " << what;
      }
      hwy::SetSupportedTargetsForTest(0);
    }
  EXPECT_GT(negative_cases, 4u);  // the hostile maps did reach the flag
}

// The plain loop itself against numbers worked out by hand: two pixels, one invalid.
TEST(Q2treeSums, ScalarLoopFollowsItsDefinition) {
  const std::vector<float> rgb = {1, 2, 4, 8, 16, 32};
  const uint8_t valid[2] = {1, 0};
  const uint32_t source[2] = {1, 0};  // pixel (1, 0) first, then (0, 0)
  const uint32_t entry[2] = {1, 1};
  const double row[4] = {0.5, 0.25, 2.0, 0.0};
  const double col[4] = {1.0, -1.0, 0.5, 3.0};
  const detail::NestedSources s{source, entry, 2, row, col};
  std::vector<double> prefix(12, kUnwritten);
  EXPECT_FALSE(detail::q2tree_prefix_sums_scalar(rgb.data(), valid, 2, 1, s, prefix.data()));
  const double l = 0.2126 * 0.5 + 0.7152 * 1.0 + 0.0722 * 2.0;  // pixel 0 only: pixel 1 is invalid
  const double t = l * 0.25;
  EXPECT_EQ(prefix[0], kUnwritten);
  EXPECT_EQ(prefix[6], 0.5);
  EXPECT_EQ(prefix[7], 1.0);
  EXPECT_EQ(prefix[8], 2.0);
  EXPECT_EQ(prefix[9], t * 1.0);
  EXPECT_EQ(prefix[10], t * -1.0);
  EXPECT_EQ(prefix[11], l * 2.0);
}

}  // namespace
}  // namespace lp
