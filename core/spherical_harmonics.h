// Second-order real spherical harmonics (SH9) of radiance: the ambient term engines light
// with (three.js LightProbe, Filament, Unity, Unreal, ARCore). Convention (docs/sampling.md,
// "Spherical harmonics"):
//   - coefficients L_lm = integral of L(d) Y_lm(d) dw over the map's valid region, per
//     RGB channel, in the world frame of CONVENTIONS.md (+Z up);
//   - basis order (0,0) (1,-1) (1,0) (1,1) (2,-2) (2,-1) (2,0) (2,1) (2,2) with
//     Ramamoorthi-Hanrahan's normalisation:
//       Y00 = 0.282095; Y1-1, Y10, Y11 = 0.488603 (y, z, x);
//       Y2-2, Y2-1, Y21 = 1.092548 (xy, yz, xz); Y20 = 0.315392 (3z^2 - 1);
//       Y22 = 0.546274 (x^2 - y^2)
//     (exact: 1/(2 sqrt pi), sqrt 3/(2 sqrt pi), sqrt 15/(2 sqrt pi), sqrt 5/(4 sqrt pi),
//     sqrt 15/(4 sqrt pi); the same order and constants, rounded, as three.js'
//     SphericalHarmonics3 in its own frame);
//   - radiance L(d) ~ sum L_lm Y_lm(d); irradiance E(n) = sum A_l L_lm Y_lm(n) with
//     A0 = pi, A1 = 2 pi / 3, A2 = pi / 4 (the clamped cosine's SH9 convolution);
//   - projection: every valid pixel with its exact solid angle (core/envmap.h) and the
//     basis at its centre, so a one-pixel map gives L_lm = Y_lm(d) * power exactly and the
//     reconstructed power sqrt(4 pi) L00 equals the map's integral.
// Coefficients carry the map's units times steradians (the same units as a light's rgb).
#pragma once

#include <array>
#include <string>
#include <string_view>

#include "core/envmap.h"
#include "core/vec3.h"

namespace lp {

inline constexpr int kSh9Order = 2;  // bands l = 0, 1, 2
inline constexpr int kSh9Count = 9;
inline constexpr const char* kShFormat = "lightprobe.sh/1";

struct Sh9 {
  std::array<std::array<double, 3>, kSh9Count> coefficients{};  // [basis][r, g, b]
};

// Y_lm(d) in the order above, for a unit vector d.
std::array<double, kSh9Count> sh9_basis(Vec3 d);
// A_l of basis function i (pi, 2 pi / 3 or pi / 4).
double sh9_cosine_weight(int i);

// Projection of the valid pixels of a map. Throws InputError naming `source` on a map
// with no valid pixels, or with a NaN, infinite or negative value.
Sh9 project_sh9(const EnvMap& map, std::string_view source = "map");

// Radiance and irradiance (per channel) the coefficients give at a unit direction.
std::array<double, 3> sh9_radiance(const Sh9& sh, Vec3 direction);
std::array<double, 3> sh9_irradiance(const Sh9& sh, Vec3 normal);
// The SH9 radiance seen through the normalised Phong lobe (s+1)/(2 pi) max(0, r.d)^s of
// core/accuracy.h, by Funk-Hecke: sum Lambda_l L_lm Y_lm(r), Lambda_l = (s+1) int_0^1 t^s P_l(t) dt.
std::array<double, 3> sh9_phong(const Sh9& sh, Vec3 reflection, double exponent);
// Integral of the reconstructed radiance over the sphere: sqrt(4 pi) L00 per channel.
std::array<double, 3> sh9_power(const Sh9& sh);
Sh9 scaled(const Sh9& sh, double factor);

// The same radiance in the Y-up frame of glTF and three.js, where our (x, y, z) is
// (x, z, -y) (the rotation exporters.h uses): band 1 permutes like a vector, band 2 mixes
// Y20 and Y22. three.js' SphericalHarmonics3.fromArray takes these rows flattened.
Sh9 sh9_yup_from_zup(const Sh9& sh);

// The sh.json document: {"format": "lightprobe.sh/1", "order": 2, "frame_convention":
// "z-up", "units": ..., "coefficients": [[r, g, b] x 9]}.
std::string sh9_to_json(const Sh9& sh, Units units);
// Parses it; throws InputError naming `source` on another format or frame, an order
// other than 2, or a malformed or non-finite coefficient.
Sh9 sh9_from_json(const std::string& text, const std::string& source, Units* units = nullptr);

}  // namespace lp
