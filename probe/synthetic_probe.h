// Synthetic mirror-ball photos with known ground truth: ray-trace a ball (the geometry of
// probe/mirror_ball.h) reflecting any environment map, for round-trip tests of
// unwrapping and ball detection, and jittered ball tracks for sequences.
#pragma once

#include <array>
#include <cstdint>
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

}  // namespace lp
