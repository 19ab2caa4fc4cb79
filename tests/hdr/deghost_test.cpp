#include "hdr/deghost.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <random>
#include <vector>

#include "core/error.h"

namespace lp {
namespace {

constexpr int kW = 160, kH = 120, kSide = 24;

struct Square {
  int x, y;  // top-left corner
  bool contains(int px, int py) const { return px >= x && px < x + kSide && py >= y && py < y + kSide; }
};

// Background radiance: a smooth colour gradient between 0.1 and 0.2; the square 0.6.
double radiance(int x, int y, int c, const Square& sq) {
  if (sq.contains(x, y)) return 0.6;
  return 0.1 + 0.1 * (0.5 * double(x) / kW + 0.5 * double(y) / kH) * (1.0 - 0.2 * c);
}

// A frame of exposure t through `encode` (radiance*t -> code), quantised to 8 bits,
// with Gaussian code noise of `noise` (in 8-bit levels).
template <class Encode>
RgbImage frame(double t, const Square& sq, Encode encode, double noise = 0.0, unsigned seed = 1) {
  std::mt19937 rng(seed);
  std::normal_distribution<double> gauss(0.0, noise);
  RgbImage f;
  f.width = kW;
  f.height = kH;
  f.rgb.resize(size_t(kW) * kH * 3);
  for (int y = 0; y < kH; ++y)
    for (int x = 0; x < kW; ++x)
      for (int c = 0; c < 3; ++c) {
        double level = encode(std::min(1.0, radiance(x, y, c, sq) * t)) * 255.0;
        if (noise > 0) level += gauss(rng);
        f.rgb[(size_t(y) * kW + x) * 3 + c] = float(std::clamp(std::round(level), 0.0, 255.0) / 255.0);
      }
  return f;
}

const auto kLinear = [](double v) { return v; };
const auto kGamma = [](double v) { return std::pow(v, 1.0 / 2.2); };

// Dropped pixels of `mask` must contain every pixel of `expected` more than `tol` px inside
// it and nothing more than `tol` px outside it (Chebyshev distance).
void expect_drops_match(const std::vector<uint8_t>& mask, const std::vector<Square>& expected, int tol,
                        const char* what) {
  size_t wrong = 0;
  for (int y = 0; y < kH; ++y)
    for (int x = 0; x < kW; ++x) {
      bool core = false, hull = false;
      for (const Square& s : expected) {
        core |= x >= s.x + tol && x < s.x + kSide - tol && y >= s.y + tol && y < s.y + kSide - tol;
        hull |= x >= s.x - tol && x < s.x + kSide + tol && y >= s.y - tol && y < s.y + kSide + tol;
      }
      const bool dropped = mask[size_t(y) * kW + x] == 0;
      if ((core && !dropped) || (!hull && dropped)) ++wrong;
    }
  EXPECT_EQ(wrong, 0u) << what;
}

struct Moving {
  std::vector<RgbImage> frames;
  std::vector<double> times = {0.25, 1.0, 4.0};
  std::vector<Square> squares = {{20, 30}, {70, 50}, {115, 80}};
};

template <class Encode>
Moving moving_square(Encode encode) {
  Moving m;
  for (size_t i = 0; i < 3; ++i) m.frames.push_back(frame(m.times[i], m.squares[i], encode));
  return m;
}

TEST(Ghost, TheMovingSquareIsDroppedFromTheOtherFramesAndNothingElse) {
  const Moving m = moving_square(kLinear);
  const auto masks = ghost_masks(m.frames, m.times);
  ASSERT_EQ(masks.size(), 3u);
  // The reference (1 s) keeps everything.
  EXPECT_EQ(count_dropped(masks)[1], 0u);
  // The others lose where they show the square and where the reference does.
  expect_drops_match(masks[0], {m.squares[0], m.squares[1]}, 2, "short frame");
  expect_drops_match(masks[2], {m.squares[2], m.squares[1]}, 2, "long frame");
  const auto dropped = count_dropped(masks);
  EXPECT_NEAR(double(dropped[0]), 2.0 * 26 * 26, 2.0 * 4 * 26 + 16);  // two squares grown by 1 px
  EXPECT_NEAR(double(dropped[2]), 2.0 * 26 * 26, 2.0 * 4 * 26 + 16);
}

TEST(Ghost, WithoutDilationTheDropsAreExactlyTheSquares) {
  const Moving m = moving_square(kLinear);
  DeghostOptions o;
  o.dilate_px = 0;
  const auto masks = ghost_masks(m.frames, m.times, nullptr, o);
  expect_drops_match(masks[0], {m.squares[0], m.squares[1]}, 0, "short frame");
  expect_drops_match(masks[2], {m.squares[2], m.squares[1]}, 0, "long frame");
  EXPECT_EQ(count_dropped(masks), (std::vector<size_t>{2 * kSide * kSide, 0, 2 * kSide * kSide}));
}

TEST(Ghost, AGammaEncodedBracketWithItsResponseGivesTheSameDrops) {
  const Moving m = moving_square(kGamma);
  LogResponse g;
  for (auto& ch : g) {
    ch.resize(256);
    for (int k = 0; k < 256; ++k) ch[size_t(k)] = float(2.2 * std::log(std::max(k, 1) / 255.0));
  }
  DeghostOptions o;
  o.dilate_px = 0;
  const auto masks = ghost_masks(m.frames, m.times, &g, o);
  expect_drops_match(masks[0], {m.squares[0], m.squares[1]}, 0, "short frame");
  expect_drops_match(masks[2], {m.squares[2], m.squares[1]}, 0, "long frame");
}

TEST(Ghost, AStaticNoisyBracketKeepsEveryPixel) {
  const Square same{70, 50};
  std::vector<RgbImage> frames;
  const std::vector<double> times = {0.25, 1.0, 4.0};
  for (size_t i = 0; i < 3; ++i) frames.push_back(frame(times[i], same, kLinear, 1.0, unsigned(7 + i)));
  const auto masks = ghost_masks(frames, times);
  EXPECT_EQ(count_dropped(masks), (std::vector<size_t>{0, 0, 0}));
}

TEST(Ghost, InvalidPixelsAreDroppedAndTheReferenceCanBeChosen) {
  Moving m = moving_square(kLinear);
  m.frames[0].valid.assign(size_t(kW) * kH, 1);
  m.frames[0].valid[5] = 0;
  DeghostOptions o;
  o.dilate_px = 0;
  o.reference = 0;
  const auto masks = ghost_masks(m.frames, m.times, nullptr, o);
  EXPECT_EQ(masks[0][5], 0);
  EXPECT_EQ(count_dropped(masks)[0], 1u);
  // The long frame is compared with the short one now (no other usable anchor needed).
  expect_drops_match(masks[1], {m.squares[0], m.squares[1]}, 0, "middle frame vs short reference");
}

TEST(Ghost, MalformedInputsAreRefused) {
  const Moving m = moving_square(kLinear);
  EXPECT_THROW(ghost_masks(m.frames, {1.0}), InputError);
  EXPECT_THROW(ghost_masks(m.frames, {1.0, -1.0, 2.0}), InputError);
  LogResponse bad;
  bad[0] = {0.0f, -1.0f};
  bad[1] = bad[2] = {0.0f, 1.0f};
  EXPECT_THROW(ghost_masks(m.frames, m.times, &bad), InputError);
}

}  // namespace
}  // namespace lp
