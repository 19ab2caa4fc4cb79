// An environment map as a probability distribution over directions, for Monte Carlo
// rendering with a live probe (Kronander et al. 2015, seed 002): draw directions with
// known densities, frame after frame, from any layout.
//
// Exactness: a pixel is chosen with probability P(i) proportional to luminance x exact
// solid angle (optionally mixed with a uniform share, below), then a direction uniformly
// in solid angle inside that pixel:
//   latlong / hemisphere  phi uniform across the column, cos(theta) uniform across the row
//   healpix               uniform in the pixel's square of face coordinates (x, y); the
//                         HEALPix projection is equal-area, so this is uniform in solid angle
// so pdf(w) = P(pixel(w)) / solid_angle(pixel(w)) exactly, integrates to 1 over the layout's
// domain, and pdf() of a sampled direction equals the sampler's pdf (up to directions on
// pixel boundaries, a set of measure zero). The map is piecewise constant over pixels, as in
// core/accuracy's reference. Nothing special happens at phi = 0 or the poles: pixels there
// are sampled like any other, and the density is continuous wherever the map is.
#pragma once

#include <array>
#include <cstddef>
#include <vector>

#include "core/envmap.h"
#include "core/vec3.h"

namespace lp {

using Rgb = std::array<double, 3>;

struct EnvDistributionOptions {
  // Share of the probability spread uniformly over the valid solid angle (P(i) ∝ solid
  // angle). 0 (default): exactly ∝ luminance, so pixels of zero luminance are never drawn.
  // MIS does not need more (BRDF samples cover dark pixels); a small share (0.05) guards
  // map-only sampling against a map that is dark where the real lighting is not.
  double uniform_share = 0.0;
};

struct EnvSample {
  Vec3 direction;
  double pdf = 0;     // per steradian
  Rgb radiance{};     // of the pixel drawn
  size_t pixel = 0;
};

class EnvDistribution {
 public:
  // Throws InputError on a map with NaN/Inf/negative pixels, an empty map, a map whose
  // valid pixels are all zero ("nothing to sample": also with a uniform share, since a
  // black map lights nothing), or uniform_share outside [0, 1].
  explicit EnvDistribution(EnvMap map, const EnvDistributionOptions& options = {});

  // u in [0, 1)^3: u[0] picks the pixel, (u[1], u[2]) the point inside it.
  EnvSample sample(const std::array<double, 3>& u) const;
  // Density per steradian of drawing d (0 outside the layout's domain or on invalid pixels).
  double pdf(Vec3 d) const;
  // Radiance of the pixel holding d (0 outside the domain or on invalid pixels).
  Rgb radiance(Vec3 d) const;
  double luminance(Vec3 d) const;

  const EnvMap& map() const { return map_; }
  double pixel_probability(size_t pixel) const;
  double pixel_solid_angle(size_t pixel) const { return solid_angle_[pixel]; }
  // Integral of luminance over the valid region (the map's luminance power).
  double luminance_power() const { return luminance_power_; }

 private:
  EnvMap map_;
  std::vector<double> solid_angle_;  // per pixel, exact
  std::vector<double> cdf_;          // cumulative P, cdf_[i] = P(0) + ... + P(i), last = 1
  double luminance_power_ = 0;
};

// The point at (u1, u2) in [0, 1]^2 of a pixel's equal-solid-angle parametrisation (above):
// equal areas of (u1, u2) are equal solid angles. Used for sampling and for the
// supersampled reference integral.
Vec3 pixel_point(const EnvMap& map, size_t pixel, double u1, double u2);

}  // namespace lp
