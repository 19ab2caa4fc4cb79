#include "eval/synthetic_sequence.h"

#include <gtest/gtest.h>

#include <cmath>
#include <string>

#include "core/error.h"
#include "core/image_io.h"
#include "core/resample.h"
#include "eval/synthetic_scene.h"

namespace lp {
namespace {

const std::string kData = LIGHTPROBE_SHARED_DATA;

double deg(double d) { return d * M_PI / 180.0; }

const EnvMap& scene_latlong() {
  static const EnvMap map = render_scene(describe_scene(), Layout::LatLong, 128, 64);
  return map;
}

SequenceOptions options_for(Scenario s) {
  SequenceOptions o;
  o.scenario = s;
  return o;
}

bool same_pixels(const EnvMap& a, const EnvMap& b) {
  return a.layout == b.layout && a.width == b.width && a.height == b.height && a.rgb == b.rgb && a.valid == b.valid;
}

// Power-weighted mean direction of a - b (the added light alone).
Vec3 added_centroid(const EnvMap& frame, const EnvMap& base) {
  Vec3 c;
  for (size_t i = 0; i < frame.pixel_count(); ++i) {
    const float* p = frame.pixel(i);
    const float* q = base.pixel(i);
    const double y = (luminance(p[0], p[1], p[2]) - luminance(q[0], q[1], q[2])) * pixel_solid_angle(frame, i);
    c = c + y * pixel_direction(frame, i);
  }
  return normalize(c);
}

TEST(SequenceScenario, NamesRoundTripAndUnknownNamesAreRejected) {
  ASSERT_EQ(all_scenarios().size(), 7u);
  for (Scenario s : all_scenarios()) EXPECT_EQ(scenario_from_string(to_string(s)), s);
  EXPECT_EQ(to_string(Scenario::StaticNoise), "static-noise");
  EXPECT_EQ(to_string(Scenario::CameraTurn), "camera-turn");
  EXPECT_EQ(scenario_from_string("swinging-bulb"), Scenario::SwingingBulb);
  EXPECT_FALSE(scenario_from_string("strobe"));
  EXPECT_FALSE(scenario_from_string("Flicker"));
}

TEST(SequenceOptions, OnlyStaticNoiseIsNoisyByDefault) {
  for (Scenario s : all_scenarios())
    EXPECT_DOUBLE_EQ(effective_noise_sigma(options_for(s)), s == Scenario::StaticNoise ? 0.02 : 0.0) << to_string(s);
  SequenceOptions o = options_for(Scenario::MovingLight);
  o.noise_sigma = 0.05;
  EXPECT_DOUBLE_EQ(effective_noise_sigma(o), 0.05);
}

TEST(SequenceOptions, NonsenseOptionsAndFramesOutsideTheSequenceThrowInputError) {
  const EnvMap& base = scene_latlong();
  SequenceOptions o = options_for(Scenario::MovingLight);
  EXPECT_THROW(render_sequence_frame(base, o, 48), InputError);
  EXPECT_THROW(render_sequence_frame(base, o, -1), InputError);
  o.frames = 0;
  EXPECT_THROW(render_sequence_frame(base, o, 0), InputError);
  o = options_for(Scenario::MovingLight);
  o.frame_rate_hz = 0;
  EXPECT_THROW(render_sequence_frame(base, o, 0), InputError);
  o = options_for(Scenario::MovingLight);
  o.light_radius_deg = 0;
  EXPECT_THROW(render_sequence_frame(base, o, 0), InputError);
  o = options_for(Scenario::StaticNoise);
  o.noise_sigma = -0.1;
  EXPECT_THROW(render_sequence_frame(base, o, 0), InputError);
  o = options_for(Scenario::Flicker);
  o.flicker_depth = 1.5;
  EXPECT_THROW(render_sequence_frame(base, o, 0), InputError);
  EXPECT_THROW(render_sequence_frame(make_latlong(16, 8), options_for(Scenario::MovingLight), 0), InputError)
      << "a black base gives the added light nothing to scale by";
}

TEST(SequenceStaticNoise, FramesAreReproducibleIndependentAndKeepTheBasePowerOnAverage) {
  const EnvMap& base = scene_latlong();
  const SequenceOptions o = options_for(Scenario::StaticNoise);
  const EnvMap f3 = render_sequence_frame(base, o, 3);
  EXPECT_TRUE(same_pixels(f3, render_sequence_frame(base, o, 3))) << "same frame, same map";
  EXPECT_FALSE(same_pixels(f3, render_sequence_frame(base, o, 4)));
  SequenceOptions other_seed = o;
  other_seed.seed = 8;
  EXPECT_FALSE(same_pixels(f3, render_sequence_frame(base, other_seed, 3)));

  // Per-pixel relative deviation has standard deviation sigma = 0.02 and mean 0.
  double sum = 0, sq = 0;
  size_t count = 0;
  for (size_t i = 0; i < base.pixel_count(); ++i)
    for (int c = 0; c < 3; ++c) {
      if (base.pixel(i)[c] <= 0) continue;
      const double r = double(f3.pixel(i)[c]) / double(base.pixel(i)[c]) - 1;
      sum += r;
      sq += r * r;
      ++count;
    }
  const double mean = sum / double(count);
  const double sd = std::sqrt(sq / double(count) - mean * mean);
  EXPECT_NEAR(sd, 0.02, 0.02 * 0.03) << count << " samples";
  EXPECT_NEAR(mean, 0.0, 4 * 0.02 / std::sqrt(double(count)));

  // Total luminance power: per frame its standard deviation is sigma * sqrt(sum over
  // pixels and channels of (coefficient * L * omega)^2); over N frames the mean is within
  // 4 of those / sqrt(N) of the base's.
  const double coef[3] = {0.2126, 0.7152, 0.0722};
  double var = 0;
  for (size_t i = 0; i < base.pixel_count(); ++i)
    for (int c = 0; c < 3; ++c) {
      const double v = coef[c] * base.pixel(i)[c] * pixel_solid_angle(base, i);
      var += v * v;
    }
  const double frame_sd = 0.02 * std::sqrt(var);
  const double base_power = total_luminance_power(base);
  double total = 0;
  for (int k = 0; k < o.frames; ++k) total += total_luminance_power(render_sequence_frame(base, o, k));
  const double mean_power = total / o.frames;
  EXPECT_NEAR(mean_power, base_power, 4 * frame_sd / std::sqrt(double(o.frames)))
      << "frame sd " << frame_sd / base_power << " of the base power";
  EXPECT_NE(mean_power, base_power);
}

TEST(SequenceMovingLight, AddsExactlyItsPowerEveryFrameAndMovesHalfADegreePerFrameAtFortyDegrees) {
  const EnvMap& base = scene_latlong();
  const SequenceOptions o = options_for(Scenario::MovingLight);
  const double base_power = total_luminance_power(base);
  for (int k : {0, 1, 17, 47}) {
    const EnvMap f = render_sequence_frame(base, o, k);
    EXPECT_NEAR(total_luminance_power(f) / (1.5 * base_power), 1.0, 1e-6) << "frame " << k;
    const Vec3 d = *added_light_direction(o, k);
    EXPECT_NEAR(90 - zenith_of(d) * 180 / M_PI, 40.0, 1e-9);
    // A 1 deg cap on 2.8 deg pixels: the deposited centroid is within one pixel.
    EXPECT_LT(angle_between(added_centroid(f, base), d), deg(2.9)) << "frame " << k;
    const auto rgb = added_light_rgb(base, o, k);
    EXPECT_NEAR(luminance(rgb.data()), 0.5 * base_power, 1e-9 * base_power);
  }
  for (int k = 1; k < o.frames; ++k)
    EXPECT_NEAR(angle_between(*added_light_direction(o, k - 1), *added_light_direction(o, k)), deg(0.5), 1e-12);
  EXPECT_NEAR(azimuth_of(*added_light_direction(o, 0)), deg(200), 1e-12);
  EXPECT_GT(azimuth_of(*added_light_direction(o, 1)), deg(200)) << "towards increasing azimuth";
}

TEST(SequenceMovingLight, PowerIsExactOnARealMapAndOnHealpix) {
  const EnvMap grace = read_envmap(kData + "/probes-probulator-latlong256/grace.hdr");
  const EnvMap healpix = render_scene(describe_scene(), Layout::Healpix, 32, 0);
  for (const EnvMap* base : {&grace, &healpix}) {
    SCOPED_TRACE(describe_size(*base));
    SequenceOptions o = options_for(Scenario::MovingLight);
    o.light_power_share = 0.25;
    const double p = total_luminance_power(*base);
    for (int k : {0, 30}) {
      const EnvMap f = render_sequence_frame(*base, o, k);
      EXPECT_NEAR(total_luminance_power(f) / (1.25 * p), 1.0, 1e-5);
      EXPECT_LT(angle_between(added_centroid(f, *base), *added_light_direction(o, k)), deg(2.0));
    }
  }
}

TEST(SequenceSwingingBulb, SwingsTwoDegreesAtOneHertzAroundTheRestPointWithConstantPower) {
  const EnvMap& base = scene_latlong();
  const SequenceOptions o = options_for(Scenario::SwingingBulb);
  const Vec3 rest = direction_from_angles(deg(50), deg(200));
  double largest = 0;
  for (int k = 0; k < o.frames; ++k) {
    const double expected = 2.0 * std::sin(2 * M_PI * 1.0 * k / 21.0);
    const Vec3 d = *added_light_direction(o, k);
    EXPECT_NEAR(angle_between(d, rest) * 180 / M_PI, std::fabs(expected), 1e-9) << "frame " << k;
    EXPECT_EQ(azimuth_of(d) > deg(200), expected > 0) << "frame " << k;
    largest = std::max(largest, angle_between(d, rest) * 180 / M_PI);
  }
  EXPECT_GT(largest, 1.99);  // frame 5: 2 sin(2 pi 5/21) = 1.99 deg
  EXPECT_LT(angle_between(*added_light_direction(o, 21), *added_light_direction(o, 0)), 1e-9) << "period 21 frames";
  const double p = total_luminance_power(base);
  for (int k : {0, 5, 11}) EXPECT_NEAR(total_luminance_power(render_sequence_frame(base, o, k)) / (1.5 * p), 1.0, 1e-6);
}

TEST(SequenceAbruptSwitch, PowerDropsByExactlyTheLightsPowerAtTheStepFrame) {
  const EnvMap& base = scene_latlong();
  const SequenceOptions o = options_for(Scenario::AbruptSwitch);
  ASSERT_EQ(step_frame(o), 24);
  const double p = total_luminance_power(base);
  const EnvMap before = render_sequence_frame(base, o, 23);
  const EnvMap after = render_sequence_frame(base, o, 24);
  const double light = luminance(added_light_rgb(base, o, 0).data());
  EXPECT_NEAR((total_luminance_power(before) - total_luminance_power(after)) / light, 1.0, 1e-5);
  EXPECT_NEAR(light / p, 0.5, 1e-12);
  EXPECT_TRUE(same_pixels(after, base)) << "off and noise-free: the base itself";
  EXPECT_TRUE(same_pixels(render_sequence_frame(base, o, 0), before));
  EXPECT_EQ(added_light_power_factor(o, 23), 1.0);
  EXPECT_EQ(added_light_power_factor(o, 24), 0.0);
}

TEST(SequenceFlicker, PowerFollowsTheSampledHundredHertzWaveformAliasedToFiveHertz) {
  const EnvMap& base = scene_latlong();
  const SequenceOptions o = options_for(Scenario::Flicker);
  EXPECT_NEAR(flicker_alias_hz(o), 5.0, 1e-12);
  const double p = total_luminance_power(base);
  double mean_factor = 0;
  for (int k = 0; k < 21; ++k) {
    const double expected = 1 - std::cos(2 * M_PI * 100.0 * k / 21.0);
    EXPECT_NEAR(added_light_power_factor(o, k), expected, 1e-9) << "frame " << k;
    // Same waveform as 5 Hz sampled at 21 fps.
    EXPECT_NEAR(added_light_power_factor(o, k), 1 - std::cos(2 * M_PI * 5.0 * k / 21.0), 1e-9);
    mean_factor += added_light_power_factor(o, k) / 21;
    const double added = total_luminance_power(render_sequence_frame(base, o, k)) - p;
    EXPECT_NEAR(added, 0.5 * p * expected, 1e-5 * p) << "frame " << k;
  }
  EXPECT_NEAR(mean_factor, 1.0, 1e-12) << "21 frames hold exactly 100 cycles: the average is the nominal power";
  SequenceOptions half = o;
  half.flicker_depth = 0.5;
  EXPECT_NEAR(added_light_power_factor(half, 2), 1 - 0.5 * std::cos(2 * M_PI * 200.0 / 21.0), 1e-12);
}

TEST(SequenceRisingLight, LightIsInvisibleBelowAHemisphereHorizonAndWholeAboveIt) {
  const EnvMap hemi = render_scene(describe_scene(), Layout::Hemisphere, 360, 90);
  const SequenceOptions o = options_for(Scenario::RisingLight);
  const double p = total_luminance_power(hemi);
  int below = 0, above = 0;
  for (int k = 0; k < o.frames; ++k) {
    const Vec3 d = *added_light_direction(o, k);
    const double elevation = 90 - zenith_of(d) * 180 / M_PI;
    EXPECT_NEAR(elevation, -10 + 40.0 * k / 47.0, 1e-9);
    if (elevation < -1.01) {
      EXPECT_TRUE(same_pixels(render_sequence_frame(hemi, o, k), hemi)) << "frame " << k;
      ++below;
    } else if (elevation > 1.01 && (k % 4 == 0 || k == 47)) {
      EXPECT_NEAR(total_luminance_power(render_sequence_frame(hemi, o, k)) / (1.5 * p), 1.0, 1e-6) << "frame " << k;
      ++above;
    }
  }
  EXPECT_EQ(below, 11);  // elevations -10 .. -1.49
  EXPECT_GT(above, 5);
  // On a full-sphere base the light is there (below the horizon) from the first frame.
  const EnvMap& sphere = scene_latlong();
  EXPECT_NEAR(total_luminance_power(render_sequence_frame(sphere, o, 0)) / (1.5 * total_luminance_power(sphere)), 1.0,
              1e-6);
}

TEST(SequenceCameraTurn, FrameKIsTheBaseRotatedByTwoKDegreesOfYaw) {
  const EnvMap& base = scene_latlong();
  const SequenceOptions o = options_for(Scenario::CameraTurn);
  EXPECT_TRUE(same_pixels(render_sequence_frame(base, o, 0), base));
  EXPECT_FALSE(added_light_direction(o, 3));
  EXPECT_EQ(added_light_power_factor(o, 3), 0.0);
  for (int k : {1, 7, 45}) {
    const EnvMap f = render_sequence_frame(base, o, k);
    EXPECT_TRUE(same_pixels(f, rotate(base, rotation_from_yaw_pitch_roll_deg(2.0 * k, 0, 0)))) << "frame " << k;
    EXPECT_NEAR(total_luminance_power(f) / total_luminance_power(base), 1.0, 1e-6);
  }
  // The sun (azimuth 30 deg) turns with the map: at frame 45 it sits at 120 deg.
  const EnvMap f = render_sequence_frame(base, o, 45);
  size_t brightest = 0;
  for (size_t i = 0; i < f.pixel_count(); ++i)
    if (f.pixel(i)[1] > f.pixel(brightest)[1]) brightest = i;
  EXPECT_NEAR(azimuth_of(pixel_direction(f, brightest)) * 180 / M_PI, 120.0, 2.9);
}

}  // namespace
}  // namespace lp
