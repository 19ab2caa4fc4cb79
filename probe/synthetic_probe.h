// Synthetic mirror-ball photos with known ground truth: ray-trace a ball (the geometry of
// probe/mirror_ball.h) reflecting any environment map, for round-trip tests of
// unwrapping and ball detection, and jittered ball tracks for sequences.
#pragma once

#include <array>
#include <nlohmann/json.hpp>

#include <cstdint>
#include <string>
#include <vector>

#include "core/envmap.h"
#include "core/image_io.h"
#include "probe/mirror_ball.h"

namespace lp {

struct RenderBallOptions {
  // k x k sub-samples per pixel on a regular grid; pixels on the rim average ball
  // samples with background samples (partial coverage). >= 1.
  int samples_per_pixel_edge = 4;
  // Radiance of everything that is not the ball.
  std::array<float, 3> background{0, 0, 0};
  // Multiplicative Gaussian noise per pixel and channel: value *= 1 + noise_relative * N(0, 1),
  // clamped at 0 (a background of 0 stays 0). 0 = noise-free.
  double noise_relative = 0;
  // Additive Gaussian noise (absolute sigma) on every pixel, clamped at 0.
  double noise_absolute = 0;
  uint64_t seed = 1;
};

// Image of `width` x `height` pixels of the ball reflecting `world` (any layout; each
// sub-sample takes the value of the map pixel containing its direction, i.e. the map is
// read as piecewise constant; invalid map pixels reflect black). The ball's reflectivity
// (camera.reflectivity / fresnel) multiplies the reflected radiance. Units are copied
// from the map. Throws InputError on non-positive sizes or a bad camera/ball.
RgbImage render_mirror_ball(const EnvMap& world, const BallInImage& ball, const MirrorBallCamera& camera,
                            int width, int height, const RenderBallOptions& options);
RgbImage render_mirror_ball(const EnvMap& world, const BallInImage& ball, const MirrorBallCamera& camera,
                            int width, int height, int samples_per_pixel_edge = 4);

// `frames` copies of `ball` whose centres move by independent Gaussian offsets of
// standard deviation jitter_px per axis (seeded, reproducible); the radius is kept.
std::vector<BallInImage> jittered_track(BallInImage ball, int frames, double jitter_px, uint64_t seed);

// `lightprobe synth probe`: a probe image of `world` with its truth.
struct SyntheticProbeOptions {
  std::string type = "mirrorball";  // mirrorball|fisheye (equidistant)
  int width = 512, height = 512;
  double radius_px = 0;             // ball radius (0: 40 % of the short side)
  double distance_in_radii = 0;     // camera distance from the ball centre (0: orthographic)
  double fov_deg = 190;             // fisheye field of view
  double noise_relative = 0;        // mirror ball: RenderBallOptions::noise_relative
  int frames = 1;                   // > 1: a jittered mirror-ball sequence
  double jitter_px = 1.0;           // ball centre jitter per frame (sequences)
  uint64_t seed = 1;                // noise seed of frame 0 (frame f: seed + f) and of the jitter
};

// Renders the probe and writes it to `output`: one image, or for a sequence a directory
// (created) of frame_NNNN.exr and truth.json. Returns the truth: type, input (the label of
// `world`), frames, per frame the ball (cx, cy, radius_px; none for a fisheye), and
// distance_in_radii or fov_deg. InputError for an unknown type, a fisheye sequence, no
// frames, or a negative (or NaN) radius, distance or noise, before anything is written.
nlohmann::json write_synthetic_probe(const EnvMap& world, const std::string& input_label,
                                     const SyntheticProbeOptions& options, const std::string& output);

}  // namespace lp
