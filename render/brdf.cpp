#include "render/brdf.h"

#include <fmt/format.h>

#include <cmath>

#include "core/error.h"

namespace lp {

void orthonormal_basis(Vec3 n, Vec3* t, Vec3* b) {
  const double sign = std::copysign(1.0, n.z);
  const double a = -1.0 / (sign + n.z);
  const double c = n.x * n.y * a;
  *t = {1 + sign * n.x * n.x * a, sign * c, -sign * n.x};
  *b = {c, sign + n.y * n.y * a, -n.y};
}

void validate(const Brdf& brdf) {
  for (int c = 0; c < 3; ++c) {
    if (!std::isfinite(brdf.albedo[c]))
      throw InputError(fmt::format("brdf: albedo channel {} is not a finite number", c));
    if (brdf.albedo[c] < 0 || brdf.albedo[c] > 1)
      throw InputError(fmt::format("brdf: albedo {} outside [0, 1]: the lobe is not normalised (it would reflect more than it receives)",
                                   brdf.albedo[c]));
  }
  if (brdf.type == LobeType::BlinnPhong && !(brdf.exponent > 0 && std::isfinite(brdf.exponent)))
    throw InputError(fmt::format("brdf: blinn-phong exponent must be a positive number, got {}", brdf.exponent));
}

std::string describe(const Brdf& brdf) {
  return brdf.type == LobeType::Lambertian ? std::string("lambertian") : fmt::format("blinn-phong-{:g}", brdf.exponent);
}

LobeSample sample_lobe(const Brdf& brdf, Vec3 n, Vec3 wo, double u1, double u2) {
  Vec3 t, b;
  orthonormal_basis(n, &t, &b);
  const double phi = 2 * M_PI * u2;
  LobeSample s;
  if (brdf.type == LobeType::Lambertian) {
    const double r = std::sqrt(u1), z = std::sqrt(std::max(0.0, 1 - u1));
    s.direction = r * std::cos(phi) * t + r * std::sin(phi) * b + z * n;
    s.pdf = z / M_PI;
    s.valid = s.pdf > 0;
    return s;
  }
  const double cos_h = std::pow(1 - u1, 1.0 / (brdf.exponent + 1));  // (n.h) with density ∝ (n.h)^e
  const double sin_h = std::sqrt(std::max(0.0, 1 - cos_h * cos_h));
  const Vec3 h = sin_h * std::cos(phi) * t + sin_h * std::sin(phi) * b + cos_h * n;
  const double wo_h = dot(wo, h);
  if (wo_h <= 0) return s;  // the reflection's half vector would be -h: outside the lobe
  s.direction = normalize(2 * wo_h * h - wo);
  s.pdf = lobe_pdf(brdf, n, wo, s.direction);
  s.valid = s.pdf > 0;
  return s;
}

double lobe_pdf(const Brdf& brdf, Vec3 n, Vec3 wo, Vec3 wi) {
  if (brdf.type == LobeType::Lambertian) return std::max(0.0, dot(n, wi)) / M_PI;
  const Vec3 sum = wo + wi;
  const double len = length(sum);
  if (len < 1e-12) return 0;
  const Vec3 h = (1.0 / len) * sum;
  const double cos_h = dot(n, h), wo_h = dot(wo, h);
  if (cos_h <= 0 || wo_h <= 0) return 0;
  return (brdf.exponent + 1) / (2 * M_PI) * std::pow(cos_h, brdf.exponent) / (4 * wo_h);
}

Rgb eval_lobe(const Brdf& brdf, Vec3 n, Vec3 wo, Vec3 wi) {
  const double cos_i = dot(n, wi);
  if (cos_i <= 0) return {0, 0, 0};
  const double k = brdf.type == LobeType::Lambertian ? cos_i / M_PI : lobe_pdf(brdf, n, wo, wi);
  return {brdf.albedo[0] * k, brdf.albedo[1] * k, brdf.albedo[2] * k};
}

}  // namespace lp
