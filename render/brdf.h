// Reflectance lobes for the Monte Carlo estimators (render/estimators.h): each can be
// evaluated, sampled and asked for its density, all in the world frame around a shading
// normal n with the view direction wo (unit, from the surface towards the viewer).
//
//   lambertian   f cos = albedo / pi * max(0, n.wi); sampled cosine-weighted, pdf = max(0, n.wi) / pi
//   blinn-phong  half vector h drawn with density (e + 1) / (2 pi) (n.h)^e on the upper
//                hemisphere, wi = reflect(wo, h); pdf(wi) = (e + 1) / (2 pi) (n.h)^e / (4 wo.h)
//                with h = normalize(wo + wi) (the Jacobian of the reflection), and
//                f cos = albedo * pdf(wi) for wi above the surface, 0 below.
// Both lobes are *normalised*: the integral of f cos over incident directions is albedo
// (lambertian) or albedo x the share of the lobe above the horizon (blinn-phong, <= albedo),
// so an albedo in [0, 1] never reflects more than arrives. f cos = albedo x pdf makes BRDF
// sampling exact for the lobe, which isolates what the estimators differ in: the light.
// (The blinn-phong f is not reciprocal; it is a lighting lobe, not a complete material.)
#pragma once

#include <array>
#include <optional>
#include <string>
#include <string_view>

#include "core/vec3.h"
#include "render/env_distribution.h"

namespace lp {

enum class LobeType { Lambertian, BlinnPhong };

struct Brdf {
  LobeType type = LobeType::Lambertian;
  Rgb albedo{0.8, 0.8, 0.8};  // each channel in [0, 1]
  double exponent = 0;        // blinn-phong exponent e > 0 (10 rough ... 1000 near mirror)
};

// Throws InputError naming the problem: an albedo channel outside [0, 1] (a lobe that is
// not normalised: it would reflect more than it receives), a non-finite value, or a
// blinn-phong exponent <= 0.
void validate(const Brdf& brdf);
// "lambertian" or "blinn-phong-<e>".
std::string describe(const Brdf& brdf);

struct LobeSample {
  Vec3 direction;
  double pdf = 0;
  bool valid = false;  // false: the draw fell outside the lobe's support (contributes 0)
};

// n, wo unit vectors; u in [0, 1)^2.
LobeSample sample_lobe(const Brdf& brdf, Vec3 n, Vec3 wo, double u1, double u2);
double lobe_pdf(const Brdf& brdf, Vec3 n, Vec3 wo, Vec3 wi);
// f(wo, wi) * max(0, n.wi), per channel.
Rgb eval_lobe(const Brdf& brdf, Vec3 n, Vec3 wo, Vec3 wi);

// An orthonormal basis (t, b, n) around a unit n (Duff et al. 2017, no singularity).
void orthonormal_basis(Vec3 n, Vec3* t, Vec3* b);

}  // namespace lp
