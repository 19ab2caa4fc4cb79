// Camera response curves: recovering g(z) = ln(E dt) for every code level z from an
// exposure bracket (Debevec & Malik 1997; Robertson, Borman & Stevenson 2003), and
// storing it as JSON.
//
// Convention (Debevec–Malik): log_exposure[c][z] = g(z) = ln(E·Δt) for channel c at code
// level z in [0, levels). g is known up to one additive constant per channel; every
// recovered curve is normalised so that g(levels/2) = 0. A code value v in [0, 1] (as
// read_camera_image gives it) maps to level lround(v · (levels − 1)).
#pragma once

#include <array>
#include <cstdint>
#include <optional>
#include <string>
#include <vector>

#include "hdr/bracket.h"

namespace lp {

struct CameraResponse {
  int levels = 256;
  std::array<std::vector<float>, 3> log_exposure;  // g(z) per code level, per channel (R, G, B)
  bool linear = false;                              // made by linear_response
};

// g(z) = ln(z / (levels/2)), so that g(levels/2) = 0; level 0 (ln 0) is given half a level,
// ln(0.5 / (levels/2)), a finite upper bound.
CameraResponse linear_response(int levels = 256);
// The sRGB curve (IEC 61966-2-1's decoding) as a response, for codes a camera wrote as sRGB
// (a phone's JPEGs): g(z) = ln(srgb(z / (levels - 1)) / srgb(mid)), mid = levels/2 so that
// g(mid) = 0, level 0 given half a level as in linear_response.
CameraResponse srgb_response(int levels = 256);

struct DebevecOptions {
  double lambda = 50.0;  // smoothness weight (Debevec–Malik's λ, for 256 levels)
  int samples = 200;     // pixel locations, chosen deterministically (see sample_pixels)
  // Levels of the recovered curve: 0 = 2^bit_depth for 8-bit brackets, 1024 for deeper
  // ones (a 65536-level system is mostly unconstrained; merge reads any level count).
  int levels = 0;
  // Pixels of exactly this 8-bit colour in any frame (registration borders, e.g. pure
  // blue (0, 0, 255) in Debevec's Memorial set) are never sampled.
  std::optional<std::array<uint8_t, 3>> ignore_colour;
  // Observations the fitted curve misses by more than outlier_sigmas robust sigmas (1.4826
  // MAD of every residual, each weighted as the fit weighs it) are dropped and the curve
  // solved again, up to outlier_rounds times: a pixel that moved between frames is not the
  // curve's evidence. 0 rounds: the paper's plain least squares.
  int outlier_rounds = 2;
  double outlier_sigmas = 8.0;
};
// Solves Debevec–Malik's weighted least squares per channel (hat weights, second-difference
// smoothness, g(levels/2) = 0) through its sparse normal equations (Eigen SimplicialLDLT),
// without the observations it cannot explain (DebevecOptions::outlier_*); the curve is then
// made non-decreasing (its least-squares closest monotone curve), as every recovered one is.
// Throws InputError (via check_bracket) on a bad bracket.
CameraResponse recover_debevec(const Bracket& bracket, const DebevecOptions& options = {});

struct RobertsonOptions {
  // The iteration converges slowly: on the 5-frame synthetic brackets of the tests, g is
  // still 0.1 (ln units) away from its fixed point after 30 iterations, and within 0.01
  // after 100.
  int max_iterations = 100;
  double threshold = 1e-4;  // stop when no level's g (ln units) moves more than this
  int levels = 0;           // as DebevecOptions::levels
  // Every pixel is used; pixel/frame pairs of this 8-bit colour are skipped.
  std::optional<std::array<uint8_t, 3>> ignore_colour;
};
// Robertson et al. 2003: alternates the ML irradiance estimate x_j = Σ w t I(z) / Σ w t²
// with I(m) = mean of t x_j over the observations at level m, Gaussian-like weights
// w(m) = exp(−4 (m − c)² / c²), c = (levels − 1)/2, I normalised to I(levels/2) = 1.
// Levels never observed are interpolated in g from their observed neighbours; the curve is
// then made non-decreasing, as recover_debevec's.
// With no smoothness term, brackets whose exposure ratios are all equal leave g ambiguous
// by a function periodic in ln E with the period ln(ratio) (Grossberg & Nayar 2003): on
// such brackets prefer recover_debevec, whose smoothness term resolves it.
CameraResponse recover_robertson(const Bracket& bracket, const RobertsonOptions& options = {});

// Deterministic, stratified choice of pixel indices (row-major) for response fitting:
// Halton(2,3) points over the image, binned by a rough log-irradiance estimate (from each
// pixel's best-exposed frame) into `count` bins that are filled evenly, so that samples
// cover both the image and the radiance range. Pixels of `ignore_colour` in any frame, and
// pixels a frame has no data for (RgbImage::valid: alignment borders, transparency), are
// skipped; recover_robertson leaves both out too. Returns at most `count` distinct indices.
std::vector<size_t> sample_pixels(const Bracket& bracket, int count,
                                  const std::optional<std::array<uint8_t, 3>>& ignore_colour = std::nullopt);

// JSON: {"format": "lightprobe.response/1", "levels": N, "linear": false,
//        "log_exposure": {"r": [...], "g": [...], "b": [...]}}; written atomically.
void save_response(const std::string& path, const CameraResponse& response);
// Throws InputError naming the file and the problem (missing, not JSON, another format,
// curve lengths that differ from "levels", non-finite values).
CameraResponse load_response(const std::string& path);

// Throws InputError when the curve's shape is inconsistent (levels < 2, lengths differ,
// non-finite values); `who` names the file or option in the message.
void check_response(const CameraResponse& response, const std::string& who);

}  // namespace lp
