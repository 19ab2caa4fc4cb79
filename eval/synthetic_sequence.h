// Dynamic sequences with known ground truth, made from any base map (a real probe or the
// procedural scene, in any layout), for the temporal measures of CONVENTIONS.md (flicker,
// jitter, lag). Every frame is a pure function of (base, options, frame): the same frame
// always renders the same map, whatever order frames are asked for in.
//
// Most scenarios add one light to the base: a spherical cap of uniform radiance,
// light_radius_deg in half-angle, neutral colour (equal rgb, so luminance = each channel),
// carrying light_power_share x the base map's luminance power. Its power is deposited
// exactly (64 x 64 equal-area strata over the cap, each carrying 1/4096 of the power, put
// into the pixel holding it as radiance = power / pixel solid angle), so the frame's total
// power is the base's plus the light's to float rounding, at any layout and resolution.
// Strata that fall outside the layout (below a hemisphere map's horizon) or on invalid
// pixels are dropped: that part of the light is not seen.
//
// The light rests at elevation light_elevation_deg, azimuth light_azimuth_deg (defaults
// 40 deg / 200 deg, well away from the procedural scene's sun at 40 deg / 30 deg).
//   static-noise   the base alone, with multiplicative Gaussian sensor noise every frame
//   moving-light   the light moves along the circle of constant elevation, starting at the
//                  rest point towards increasing azimuth, exactly move_deg_per_frame (0.5)
//                  of great-circle angle between consecutive frames
//   swinging-bulb  the light swings horizontally (along the azimuth direction) about the
//                  rest point by swing_amplitude_deg * sin(2 pi swing_hz t), t = frame / fps
//                  (+-2 deg at 1 Hz: one period every 21 frames at 21 fps)
//   abrupt-switch  the light is on for frames < step_frame() = frames / 2, off from there on
//   flicker        the light's power follows a lamp on AC mains: P(t) = P (1 - depth cos(2 pi
//                  f t)), f = flicker_hz = 100 Hz (twice the 50 Hz mains frequency; with
//                  depth 1 this is exactly 2 P sin^2(2 pi 50 t)), time-average P, sampled
//                  instantly at t = frame / fps. Sampled at 21 fps the 100 Hz flicker
//                  aliases to |100 - 21 * 5| = 5 Hz (flicker_alias_hz): a slow 4.2-frame beat.
//   rising-light   the light rises at the rest azimuth from elevation -10 deg (frame 0) to
//                  +30 deg (last frame), linearly; on a hemisphere base it is invisible
//                  while wholly below the horizon
//   camera-turn    no light: frame k is rotate(base, Rz(camera_turn_deg_per_frame * k)), i.e.
//                  content at azimuth phi moves to phi + 2k deg (the camera yaws by -2k deg)
// Noise: pixel value L becomes max(0, L (1 + sigma g)) per channel with g standard normal,
// seeded by (seed, frame, pixel) so frames are independent and reproducible. By default only
// static-noise is noisy (sigma 0.02); set noise_sigma to make any scenario noisy (or 0 to
// make static-noise clean). Noise applies to the whole frame, added light included.
#pragma once

#include <array>
#include <cstdint>
#include <functional>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include "core/envmap.h"
#include "core/vec3.h"

namespace lp {

enum class Scenario { StaticNoise, MovingLight, SwingingBulb, AbruptSwitch, Flicker, RisingLight, CameraTurn };
// "static-noise", "moving-light", "swinging-bulb", "abrupt-switch", "flicker",
// "rising-light", "camera-turn".
std::string_view to_string(Scenario scenario);
std::optional<Scenario> scenario_from_string(std::string_view name);
const std::vector<Scenario>& all_scenarios();

struct SequenceOptions {
  Scenario scenario = Scenario::StaticNoise;
  int frames = 48;
  double frame_rate_hz = 21;
  uint64_t seed = 7;
  // Relative per-pixel, per-channel sigma of the multiplicative Gaussian noise. Unset:
  // 0.02 for static-noise, 0 for every other scenario.
  std::optional<double> noise_sigma;
  // The added light: luminance power = light_power_share x the base's luminance power.
  double light_power_share = 0.5;
  double light_radius_deg = 1.0;
  double light_elevation_deg = 40;
  double light_azimuth_deg = 200;
  double move_deg_per_frame = 0.5;       // moving-light, great-circle angle per frame
  double swing_amplitude_deg = 2.0;      // swinging-bulb
  double swing_hz = 1.0;                 // swinging-bulb
  double flicker_hz = 100.0;             // flicker (2 x mains)
  double flicker_depth = 1.0;            // flicker, in [0, 1]
  double rise_from_deg = -10, rise_to_deg = 30;  // rising-light elevations, first/last frame
  double camera_turn_deg_per_frame = 2.0;        // camera-turn
};

// Throws InputError (one line, naming the option) on options that make no sequence:
// frames < 1, frame rate <= 0, negative noise or power share, radius outside (0, 90],
// flicker depth outside [0, 1].
void validate(const SequenceOptions& options);

// The noise sigma in effect (see noise_sigma).
double effective_noise_sigma(const SequenceOptions& options);
// The frame where abrupt-switch turns its light off: frames / 2.
int step_frame(const SequenceOptions& options);
// The frequency (Hz) at which the sampled flicker appears: flicker_hz folded into
// [0, fps / 2] (5 Hz for 100 Hz at 21 fps).
double flicker_alias_hz(const SequenceOptions& options);

// Ground truth of the added light at a frame. Direction: unit, towards the light (nullopt
// for static-noise and camera-turn, which add none). Power factor: the light's power as a
// multiple of its nominal power (1; 0 when switched off; the flicker waveform; 0 for
// scenarios without a light). added_light_rgb: nominal power x factor per channel for a
// base map (the emitted power; a hemisphere base shows only the part above the horizon).
std::optional<Vec3> added_light_direction(const SequenceOptions& options, int frame);
double added_light_power_factor(const SequenceOptions& options, int frame);
std::array<double, 3> added_light_rgb(const EnvMap& base, const SequenceOptions& options, int frame);
// camera-turn's world_from_base rotation at a frame (identity for other scenarios).
Mat3 camera_rotation(const SequenceOptions& options, int frame);

// Frame `frame` (0 <= frame < frames, else InputError) of the sequence built on `base`, in
// the base's layout, size, mask and units.
EnvMap render_sequence_frame(const EnvMap& base, const SequenceOptions& options, int frame);

// Writes a sequence as tools and replays read it into `dir` (created): frame_NNNN.exr,
// timestamps.txt (frame / rate, seconds) and truth.json (scenario, step frame or alias
// frequency, per-frame power and the added light), `base_label` recorded as the base.
// `frame_done` is called after each frame. Returns truth.json's path.
std::string write_sequence_files(const std::string& dir, const EnvMap& base, const std::string& base_label,
                                 const SequenceOptions& options, const std::function<void()>& frame_done = {});

}  // namespace lp
