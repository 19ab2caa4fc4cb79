// Temporal FIR filtering (Havran 2005, section 3.3): the paper's taps, Kaiser re-design for
// other frame rates (checked by their numerically computed frequency response), and the
// light-list filter over total power and per-id directions.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <complex>
#include <numeric>
#include <random>

#include "core/error.h"
#include "sampling/temporal_filter.h"

namespace lp {
namespace {

const std::vector<double> kPaperTaps = {0.06216, 0.01296, -0.13816, 0.28315, 0.65223,
                                        0.28315, -0.13816, 0.01296, 0.06216};

// |H(f)| = |sum_k w_k e^{-2 pi i f k / fs}|, evaluated directly.
double magnitude(const FirFilter& f, double hz) {
  std::complex<double> h = 0;
  for (size_t k = 0; k < f.taps.size(); ++k)
    h += f.taps[k] * std::exp(std::complex<double>(0, -2 * M_PI * hz / f.sample_rate_hz * k));
  return std::abs(h);
}

void expect_lowpass(const FirFilter& f, double pass_hz, double stop_hz) {
  ASSERT_EQ(f.taps.size() % 2, 1u);
  for (size_t k = 0; k < f.taps.size(); ++k) EXPECT_NEAR(f.taps[k], f.taps[f.taps.size() - 1 - k], 1e-15);
  EXPECT_NEAR(std::accumulate(f.taps.begin(), f.taps.end(), 0.0), 1.0, 1e-14);
  for (int i = 0; i <= 200; ++i) {
    const double hz = pass_hz * i / 200;
    EXPECT_NEAR(magnitude(f, hz), 1.0, 0.05) << hz << " Hz";
  }
  for (int i = 0; i <= 200; ++i) {
    const double hz = stop_hz + (f.sample_rate_hz / 2 - stop_hz) * i / 200;
    EXPECT_LT(20 * std::log10(magnitude(f, hz)), -30.0) << hz << " Hz";
  }
}

LightList one_light(double power, Vec3 direction = {0, 0, 1}, uint64_t id = 1) {
  LightList list;
  Light l;
  l.id = id;
  l.direction = direction;
  l.rgb = {power, 2 * power, 0.5 * power};
  list.lights.push_back(l);
  return list;
}

TEST(FirFilter, HavranTapsAreThePapersDividedByTheirSumOf1_09245) {
  const FirFilter f = havran2005_filter();
  ASSERT_EQ(f.taps.size(), 9u);
  EXPECT_EQ(f.delay_frames(), 4);
  EXPECT_EQ(f.sample_rate_hz, 21);
  const double paper_sum = 2 * (0.06216 + 0.01296 - 0.13816 + 0.28315) + 0.65223;
  EXPECT_NEAR(paper_sum, 1.09245, 1e-12);
  for (size_t k = 0; k < 9; ++k) EXPECT_NEAR(f.taps[k], kPaperTaps[k] / 1.09245, 1e-15);
  EXPECT_NEAR(std::accumulate(f.taps.begin(), f.taps.end(), 0.0), 1.0, 1e-15);
}

TEST(FirFilter, HavranTapsAreAGentleLowPassNotTheSharp7To9HzDesignThePaperNames) {
  // Symmetric taps: H(f) = w5 + 2 sum_{k=1..4} w_{5-k} cos(2 pi f k / fs), from the paper's
  // numbers; at 7 Hz of 21 Hz the cosines are -1/2, -1/2, 1, -1/2.
  const double at7 = (0.65223 + 2 * (-0.5 * 0.28315 + 0.5 * 0.13816 + 0.01296 - 0.5 * 0.06216)) / 1.09245;
  const FirFilter f = havran2005_filter();
  EXPECT_NEAR(magnitude(f, 7), at7, 1e-12);
  EXPECT_NEAR(at7, 0.4311, 1e-4);
  EXPECT_NEAR(magnitude(f, 0), 1.0, 1e-15);
  double worst_stop = 0;
  for (int i = 0; i <= 100; ++i) worst_stop = std::max(worst_stop, magnitude(f, 9 + 1.5 * i / 100));
  EXPECT_GT(20 * std::log10(worst_stop), -30.0);
  // The Kaiser design for the same spec meets it, at 3x the delay: Kaiser's order
  // (40 - 7.95) / (2.285 * 2 pi * 2 / 21) = 23.45 -> 24, so 25 taps and 12 frames.
  const FirFilter designed = design_lowpass_filter(21, 7, 9);
  EXPECT_EQ(designed.taps.size(), 25u);
  EXPECT_EQ(designed.delay_frames(), 3 * f.delay_frames());
  EXPECT_NEAR(magnitude(designed, 7), 1.0, 0.05);
}

TEST(FirFilter, ImpulseResponseEqualsTheCoefficients) {
  for (const FirFilter& f : {havran2005_filter(), design_lowpass_filter(60, 20, 25.7)}) {
    std::vector<double> impulse(f.taps.size() + 10, 0.0);
    impulse[3] = 1;  // after three zeros, so the start rule fills the history with 0
    const std::vector<double> out = apply_fir(f, impulse);
    for (size_t t = 0; t < out.size(); ++t) {
      const double expected = t >= 3 && t - 3 < f.taps.size() ? f.taps[t - 3] : 0.0;
      EXPECT_DOUBLE_EQ(out[t], expected) << t;
    }
  }
}

TEST(FirFilter, ConstantInputPassesUnchangedFromTheFirstFrame) {
  for (const FirFilter& f : {havran2005_filter(), filter_for_frame_rate(30), filter_for_frame_rate(60)}) {
    const std::vector<double> out = apply_fir(f, std::vector<double>(40, 3.7));
    for (double y : out) EXPECT_NEAR(y, 3.7, 1e-14);
  }
}

TEST(FirFilter, HavranStepReachesNinetyPercentFiveFramesAfterTheStep) {
  // Step response = running sum of the taps: 0.0569, 0.0688, -0.0577, 0.2015, 0.7985,
  // 1.0577 -> 90 % first reached 5 frames after the step (delay 4 + 1).
  const FirFilter f = havran2005_filter();
  std::vector<double> signal(30, 0.0);
  const int step = 10;
  for (int t = step; t < 30; ++t) signal[t] = 1;
  const std::vector<double> out = apply_fir(f, signal);
  double cumulative = 0;
  int first_90 = -1;
  for (int k = 0; k < 9; ++k) {
    cumulative += kPaperTaps[k] / 1.09245;
    EXPECT_NEAR(out[step + k], cumulative, 1e-14);
    if (first_90 < 0 && out[step + k] >= 0.9) first_90 = k;
  }
  EXPECT_EQ(first_90, 5);
  EXPECT_NEAR(out[step + 4], (0.06216 + 0.01296 - 0.13816 + 0.28315 + 0.65223) / 1.09245, 1e-14);  // 0.7985

  // The light filter's total power shows the same lag.
  LightTemporalFilter lights(f);
  int light_first_90 = -1;
  for (int t = 0; t < 30; ++t) {
    const LightList out_list = lights.push(one_light(signal[t]));
    if (light_first_90 < 0 && t >= step && out_list.lights[0].rgb[1] >= 0.9 * 2) light_first_90 = t - step;
  }
  EXPECT_EQ(light_first_90, 5);
}

TEST(FirDesign, At21HzPassesBelow7HzWithin5PercentAndStopsAbove9HzBelowMinus30dB) {
  const FirFilter f = design_lowpass_filter(21, 7, 9);
  EXPECT_EQ(f.sample_rate_hz, 21);
  EXPECT_EQ(f.delay_frames(), static_cast<int>(f.taps.size() - 1) / 2);
  expect_lowpass(f, 7, 9);
}

TEST(FirDesign, At60FpsTheRedesignPassesBelow20HzAndStopsAbove25_7Hz) {
  const FirFilter f = filter_for_frame_rate(60);
  EXPECT_EQ(f.sample_rate_hz, 60);
  expect_lowpass(f, 20, 3 * 60.0 / 7);
  // The same band edges relative to fs as at 21 Hz, so the same length.
  EXPECT_EQ(f.taps.size(), design_lowpass_filter(21, 7, 9).taps.size());
}

TEST(FirDesign, FrameRatesNear21HzUseHavransTaps) {
  const FirFilter havran = havran2005_filter();
  EXPECT_EQ(filter_for_frame_rate(21).taps, havran.taps);
  EXPECT_EQ(filter_for_frame_rate(20.6).taps, havran.taps);
  EXPECT_NE(filter_for_frame_rate(25).taps.size(), havran.taps.size());
}

TEST(FirDesign, ImpossibleBandsAreInputErrors) {
  EXPECT_THROW(design_lowpass_filter(21, 9, 7), InputError);
  EXPECT_THROW(design_lowpass_filter(21, 7, 7), InputError);
  EXPECT_THROW(design_lowpass_filter(21, 7, 10.5), InputError);
  EXPECT_THROW(design_lowpass_filter(0, 7, 9), InputError);
  EXPECT_THROW(design_lowpass_filter(21, -1, 9), InputError);
  EXPECT_THROW(design_lowpass_filter(NAN, 7, 9), InputError);
  EXPECT_THROW(filter_for_frame_rate(0), InputError);
  EXPECT_THROW(filter_for_frame_rate(-30), InputError);
  EXPECT_THROW(LightTemporalFilter(FirFilter{}), InputError);
}

// n lights at random directions and random power shares, scaled to total `power`.
LightList random_frame(std::mt19937& rng, int n, const std::array<double, 3>& power) {
  std::uniform_real_distribution<double> u(0, 1);
  LightList list;
  std::array<double, 3> sum{0, 0, 0};
  for (int i = 0; i < n; ++i) {
    Light l;
    l.id = i + 1;
    l.direction = direction_from_angles(std::acos(1 - 2 * u(rng)), 2 * M_PI * u(rng));
    for (int c = 0; c < 3; ++c) sum[c] += l.rgb[c] = 0.1 + u(rng);
    list.lights.push_back(l);
  }
  for (Light& l : list.lights)
    for (int c = 0; c < 3; ++c) l.rgb[c] *= power[c] / sum[c];
  return list;
}

TEST(TemporalFilter, ConstantPowerWithMovingLightsKeepsTheTotalExactEveryFrame) {
  std::mt19937 rng(3);
  const std::array<double, 3> power{2.5, 7.0, 0.25};
  LightTemporalFilter filter(havran2005_filter());
  for (int t = 0; t < 50; ++t) {
    const LightList in = random_frame(rng, 120, power);
    const LightList out = filter.push(in);
    ASSERT_EQ(out.lights.size(), in.lights.size());
    const std::array<double, 3> total = total_power(out.lights);
    for (int c = 0; c < 3; ++c) EXPECT_NEAR(total[c], power[c], 1e-12 * power[c]) << "frame " << t;
    // Shares come from the current frame.
    for (size_t i = 0; i < in.lights.size(); ++i) EXPECT_NEAR(out.lights[i].rgb[1], in.lights[i].rgb[1], 1e-12);
  }
}

TEST(TemporalFilter, TotalPowerFollowsTheScalarFirOfEachChannel) {
  std::mt19937 rng(5);
  std::uniform_real_distribution<double> u(0.5, 2);
  const FirFilter fir = filter_for_frame_rate(30);
  LightTemporalFilter filter(fir);
  std::vector<std::vector<double>> in(3), out(3);
  for (int t = 0; t < 60; ++t) {
    const std::array<double, 3> p{u(rng), u(rng), u(rng)};
    const std::array<double, 3> total = total_power(filter.push(random_frame(rng, 40, p)).lights);
    for (int c = 0; c < 3; ++c) {
      in[c].push_back(p[c]);
      out[c].push_back(total[c]);
    }
  }
  for (int c = 0; c < 3; ++c) {
    const std::vector<double> expected = apply_fir(fir, in[c]);
    for (int t = 0; t < 60; ++t) EXPECT_NEAR(out[c][t], expected[t], 1e-12) << "channel " << c << " frame " << t;
  }
}

TEST(TemporalFilter, ConstantInputPassesUnchangedFromTheFirstFrame) {
  std::mt19937 rng(9);
  const LightList in = random_frame(rng, 300, {1, 2, 3});
  LightTemporalFilter filter(havran2005_filter());
  for (int t = 0; t < 12; ++t) {
    const LightList out = filter.push(in);
    for (size_t i = 0; i < in.lights.size(); ++i) {
      EXPECT_EQ(out.lights[i].id, in.lights[i].id);
      EXPECT_LT(angle_between(out.lights[i].direction, in.lights[i].direction), 1e-14);
      for (int c = 0; c < 3; ++c) EXPECT_NEAR(out.lights[i].rgb[c], in.lights[i].rgb[c], 1e-15);
    }
  }
}

TEST(TemporalFilter, GreatCircleMotionIsFilteredToUnitVectorsBetweenPastPositions) {
  // A light moving at constant speed on a tilted great circle. With symmetric taps the
  // filtered vector is exactly the position delay_frames() ago (the odd parts cancel).
  const Vec3 a = normalize(Vec3{1, 0, 1}), b{0, 1, 0};
  const double speed = 0.1;  // radians per frame (30 frames stay below pi: no wrap)
  auto at = [&](int t) { return std::cos(speed * t) * a + std::sin(speed * t) * b; };
  const Vec3 normal = cross(a, b);
  LightTemporalFilter filter(havran2005_filter());
  for (int t = 0; t < 30; ++t) {
    const Vec3 d = filter.push(one_light(1, at(t), 42)).lights[0].direction;
    EXPECT_NEAR(length(d), 1.0, 1e-14);
    EXPECT_NEAR(dot(d, normal), 0.0, 1e-14);  // stays on the great circle
    const double along = std::atan2(dot(d, b), dot(d, a));  // position on the circle
    // Between the oldest position in the filter's window and the current one.
    EXPECT_GE(along, speed * std::max(0, t - 8) - 1e-14);
    EXPECT_LE(along, speed * t + 1e-14);
    if (t >= 8) { EXPECT_NEAR(along, speed * (t - 4), 1e-12); }
  }
}

TEST(TemporalFilter, NewIdsStartFromTheirOwnPositionAndMissingIdsAreForgotten) {
  LightTemporalFilter filter(havran2005_filter(), {.filter_power = false, .filter_directions = true});
  const Vec3 up{0, 0, 1}, east{1, 0, 0}, north{0, 1, 0};
  LightList frame = one_light(1, up, 7);
  for (int t = 0; t < 5; ++t) filter.push(frame);
  // Id 9 appears at its own position: it passes unchanged, not pulled towards id 7.
  frame.lights.push_back(one_light(1, east, 9).lights[0]);
  LightList out = filter.push(frame);
  EXPECT_LT(angle_between(out.lights[1].direction, east), 1e-15);
  // Id 7 leaves, then comes back somewhere else: its history starts again there.
  frame.lights.erase(frame.lights.begin());
  filter.push(frame);
  frame.lights.push_back(one_light(1, north, 7).lights[0]);
  out = filter.push(frame);
  EXPECT_LT(angle_between(out.lights[1].direction, north), 1e-15);
  EXPECT_LT(angle_between(out.lights[0].direction, east), 1e-15);
  // Power untouched with filter_power = false.
  EXPECT_EQ(out.lights[0].rgb, frame.lights[0].rgb);
}

TEST(TemporalFilter, LargeIdsLikeHealpixNodesAreTrackedToo) {
  const uint64_t id = (uint64_t{1} << 40) + 5;
  LightTemporalFilter filter(havran2005_filter());
  filter.push(one_light(1, {0, 0, 1}, id));
  const Vec3 d = filter.push(one_light(1, {1, 0, 0}, id)).lights[0].direction;
  // After one step the filter output is the normalised (sum of the last tap, rest) mix.
  const double w0 = havran2005_filter().taps[0];
  const Vec3 expected = normalize(Vec3{w0, 0, 1 - w0});
  EXPECT_LT(angle_between(d, expected), 1e-14);
}

TEST(TemporalFilter, ResetForgetsTheHistory) {
  LightTemporalFilter filter(havran2005_filter());
  for (int t = 0; t < 5; ++t) filter.push(one_light(1, {0, 0, 1}));
  filter.reset();
  const LightList out = filter.push(one_light(4, {1, 0, 0}));
  EXPECT_LT(angle_between(out.lights[0].direction, Vec3{1, 0, 0}), 1e-15);
  EXPECT_NEAR(out.lights[0].rgb[0], 4, 1e-15);
}

TEST(TemporalFilter, AnIdTwiceInOneFrameIsAnInputError) {
  LightList frame = one_light(1, {0, 0, 1}, 3);
  frame.lights.push_back(frame.lights[0]);
  LightTemporalFilter filter(havran2005_filter());
  EXPECT_THROW(filter.push(frame), InputError);
}

TEST(TemporalFilter, PowerDroppingToDarknessNeverGoesNegative) {
  LightTemporalFilter filter(havran2005_filter());
  for (int t = 0; t < 10; ++t) filter.push(one_light(1));
  for (int t = 0; t < 10; ++t) {
    const LightList out = filter.push(one_light(0));
    for (double v : out.lights[0].rgb) EXPECT_GE(v, 0.0);
  }
}

}  // namespace
}  // namespace lp
