// The accuracy yardstick of CONVENTIONS.md ("How accuracy is measured"). A reference is
// integrated once from the whole map, on luminance over every pixel with exact solid
// angles (as sums over arcs of the map's rings, core/ring_integrals.h: equal to the plain
// pixel-by-pixel sums); any light list is then scored against it in microseconds.
//
//   diffuse   rel_rms of E(n) = sum L max(0, n.d) dw over 256 normals on a spherical
//             Fibonacci lattice: sqrt(mean_k (E_lights - E_ref)^2) / mean_k E_ref
//   glossy    the same for a normalised Phong lobe (s+1)/(2 pi) max(0, r.d)^s,
//             s = 10 and 100, over the same 256 directions r
//   shadowed  the diffuse error with a spherical cap of half-angle 60 deg occluded, in the
//             reference and the lights alike; 64 caps with uniformly random centres from a
//             fixed seed; the reported value is the mean of the 64 per-cap errors
//
// Spherical Fibonacci lattice: for k = 0..N-1, z_k = 1 - (2k + 1)/N,
// phi_k = k * pi (3 - sqrt 5), d_k = (sqrt(1 - z^2) cos phi, sqrt(1 - z^2) sin phi, z).
#pragma once

#include <cstdint>
#include <span>
#include <vector>

#include "core/envmap.h"
#include "core/light_list.h"
#include "core/spherical_harmonics.h"
#include "core/vec3.h"

namespace lp {

struct AccuracyOptions {
  int directions = 256;                // normals / reflection directions
  std::vector<double> glossy_exponents{10.0, 100.0};
  bool shadowed = true;                // the costliest part (~35 ms of 55 at 1024x512); skip when not charted
  int caps = 64;
  double cap_half_angle_deg = 60.0;
  uint64_t cap_seed = 20051;           // fixed: every run scores against the same caps
};

std::vector<Vec3> fibonacci_sphere(int count);
// Centres of the occluding caps: uniform on the sphere from a 64-bit SplitMix generator.
std::vector<Vec3> occluder_caps(int count, uint64_t seed);

// Normalised Phong lobe value (s+1)/(2 pi) max(0, c)^s for c = r.d.
double phong_lobe(double cos_angle, double exponent);

struct AccuracyReference {
  AccuracyOptions options;
  std::vector<Vec3> directions;                // fibonacci_sphere(options.directions)
  std::vector<double> diffuse;                 // E_ref per direction
  std::vector<std::vector<double>> glossy;     // [exponent][direction]
  std::vector<Vec3> caps;                      // cap centres
  std::vector<std::vector<double>> shadowed;   // [cap][direction], diffuse with cap occluded
  double build_seconds = 0;
};

// Integrates the map (luminance over valid pixels). Parallel over directions/caps.
AccuracyReference make_accuracy_reference(const EnvMap& map, const AccuracyOptions& options = {});

struct LightError {
  double diffuse = 0;
  std::vector<double> glossy;  // one per options.glossy_exponents
  double shadowed = 0;         // 0 when options.shadowed is false
};
LightError light_error(const AccuracyReference& reference, std::span<const Light> lights);
// Lights plus an ambient SH9 (sample --residual sh9; or SH9 alone with no lights), scored
// as a renderer lights with them: the ambient's irradiance (and its radiance through the
// Phong lobe) adds to the lights' everywhere, and no cap occludes it (ambient is not
// shadowed), while the lights inside a cap are.
LightError light_error(const AccuracyReference& reference, std::span<const Light> lights, const Sh9& ambient);

// Single evaluations, for tests and tools: irradiance (luminance) at normal n from the
// map, and from lights; glossy radiance for reflection direction r.
double map_irradiance(const EnvMap& map, Vec3 normal);
double lights_irradiance(std::span<const Light> lights, Vec3 normal);
double map_glossy(const EnvMap& map, Vec3 reflection, double exponent);

}  // namespace lp
