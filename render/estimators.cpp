#include "render/estimators.h"

#include <fmt/format.h>

#include <algorithm>
#include <cmath>

#include "core/error.h"

namespace lp {

namespace {

bool visible(const ShadingPoint& p, Vec3 w) { return !p.visible || p.visible(w); }

double lum(const Rgb& c) { return luminance(c.data()); }

bool is_unit(Vec3 v) { return std::isfinite(length(v)) && std::abs(length(v) - 1) < 1e-6; }

}  // namespace

void validate(const ShadingPoint& point) {
  if (!is_unit(point.normal)) throw InputError("shading point: the normal is not a unit vector");
  if (!is_unit(point.view)) throw InputError("shading point: the view direction is not a unit vector");
  if (dot(point.normal, point.view) <= 0) throw InputError("shading point: the view direction is below the surface");
  validate(point.brdf);
}

double product_target(const EnvDistribution& map, const ShadingPoint& p, Vec3 w) {
  const Rgb f = eval_lobe(p.brdf, p.normal, p.view, w);
  const double fy = lum(f);
  if (fy <= 0) return 0;
  return map.luminance(w) * fy;
}

Rgb colour_ratio(const EnvDistribution& map, const ShadingPoint& p, Vec3 w) {
  const Rgb f = eval_lobe(p.brdf, p.normal, p.view, w);
  const Rgb l = map.radiance(w);
  const double gamma = lum(l) * lum(f);
  if (gamma <= 0 || !visible(p, w)) return {0, 0, 0};
  return {l[0] * f[0] / gamma, l[1] * f[1] / gamma, l[2] * f[2] / gamma};
}

Rgb reference_reflected(const EnvMap& map, const ShadingPoint& p, const ReferenceOptions& options) {
  validate(p);
  if (options.subdivision < 0) throw InputError("reference: subdivision must be >= 0");
  // Narrow lobes: supersample the pixels near the lobe's peak, k x k equal solid angles.
  double max_pixel_angle = 0;
  for (size_t i = 0; i < map.pixel_count(); i += std::max<size_t>(1, map.pixel_count() / 4096))
    max_pixel_angle = std::max(max_pixel_angle, std::sqrt(pixel_solid_angle(map, i)));
  max_pixel_angle *= 1.5;  // rows differ in shape; be generous
  int k = 1;
  double near_cos = 2;  // cos of the half-vector angle within which pixels are refined (2: none)
  if (p.brdf.type == LobeType::BlinnPhong) {
    const double sigma_h = 1.0 / std::sqrt(p.brdf.exponent);  // (n.h)^e ~ exp(-e t^2 / 2)
    const double sigma_w = 2 * sigma_h;                          // wi moves twice as fast as h
    k = std::clamp(int(std::ceil(6.5 * max_pixel_angle / sigma_w)), 1, 16);
    near_cos = std::cos(std::min(M_PI, 6 * sigma_h + max_pixel_angle));
  }
  if (options.subdivision > 0) {
    k = options.subdivision;
    near_cos = -2;  // everywhere
  }
  Rgb sum{0, 0, 0};
  for (size_t i = 0; i < map.pixel_count(); ++i) {
    if (!map.is_valid(i)) continue;
    const float* l = map.pixel(i);
    if (l[0] == 0 && l[1] == 0 && l[2] == 0) continue;
    const Vec3 c = pixel_direction(map, i);
    int kk = 1;
    if (k > 1) {
      const Vec3 h = p.view + c;
      const double len = length(h);
      if (len > 1e-9 && dot(p.normal, (1.0 / len) * h) > near_cos) kk = k;
      if (near_cos < -1) kk = k;
    }
    const double dw = pixel_solid_angle(map, i) / double(kk * kk);
    Rgb acc{0, 0, 0};
    for (int a = 0; a < kk; ++a)
      for (int b = 0; b < kk; ++b) {
        const Vec3 w = kk == 1 ? c : pixel_point(map, i, (a + 0.5) / kk, (b + 0.5) / kk);
        const Rgb f = eval_lobe(p.brdf, p.normal, p.view, w);
        if (f[0] == 0 && f[1] == 0 && f[2] == 0) continue;
        if (!visible(p, w)) continue;
        for (int ch = 0; ch < 3; ++ch) acc[ch] += f[ch];
      }
    for (int ch = 0; ch < 3; ++ch) sum[ch] += double(l[ch]) * acc[ch] * dw;
  }
  return sum;
}

Rgb estimate_mis(const EnvDistribution& map, const ShadingPoint& p, const MisOptions& o, Rng& rng) {
  if (o.lobe_samples < 0 || o.map_samples < 0 || o.lobe_samples + o.map_samples == 0)
    throw InputError(fmt::format("mis: need a positive number of samples, got {} lobe + {} map", o.lobe_samples,
                                 o.map_samples));
  validate(p);
  const double n_rho = o.lobe_samples, n_l = o.map_samples;
  Rgb sum{0, 0, 0};
  auto add = [&](Vec3 w, const Rgb& l, const Rgb& f, double q_rho, double q_l) {
    const double denom = n_rho * q_rho + n_l * q_l;
    if (denom <= 0 || !visible(p, w)) return;
    for (int c = 0; c < 3; ++c) sum[c] += l[c] * f[c] / denom;
  };
  for (int j = 0; j < o.lobe_samples; ++j) {
    const double u1 = rng.uniform(), u2 = rng.uniform();
    const LobeSample s = sample_lobe(p.brdf, p.normal, p.view, u1, u2);
    if (!s.valid) continue;
    const Rgb f = eval_lobe(p.brdf, p.normal, p.view, s.direction);
    if (f[0] == 0 && f[1] == 0 && f[2] == 0) continue;
    const Rgb l = map.radiance(s.direction);
    if (l[0] == 0 && l[1] == 0 && l[2] == 0) continue;
    add(s.direction, l, f, s.pdf, n_l > 0 ? map.pdf(s.direction) : 0.0);
  }
  for (int j = 0; j < o.map_samples; ++j) {
    const EnvSample s = map.sample(rng.uniform3());
    const Rgb f = eval_lobe(p.brdf, p.normal, p.view, s.direction);
    if (f[0] == 0 && f[1] == 0 && f[2] == 0) continue;
    add(s.direction, s.radiance, f, n_rho > 0 ? lobe_pdf(p.brdf, p.normal, p.view, s.direction) : 0.0, s.pdf);
  }
  return sum;
}

Resampled sample_importance_resample(const EnvDistribution& map, const ShadingPoint& p, int proposals, int samples,
                                     double share, Rng& rng) {
  if (proposals <= 0 || samples <= 0)
    throw InputError(fmt::format("bis: need positive proposal and sample counts, got M = {}, N = {}", proposals, samples));
  if (!(share >= 0 && share <= 1)) throw InputError(fmt::format("bis: proposal_map_share must be in [0, 1], got {}", share));
  std::vector<Vec3> dir(static_cast<size_t>(proposals));
  std::vector<double> gamma(size_t(proposals), 0.0), cum(size_t(proposals), 0.0);
  double total = 0;
  for (int j = 0; j < proposals; ++j) {
    const double pick = rng.uniform();
    Vec3 w;
    if (pick < share) {
      w = map.sample(rng.uniform3()).direction;
    } else {
      const double u1 = rng.uniform(), u2 = rng.uniform();
      const LobeSample s = sample_lobe(p.brdf, p.normal, p.view, u1, u2);
      if (!s.valid) {
        cum[size_t(j)] = total;
        continue;
      }
      w = s.direction;
    }
    // Mixture density at w (the proposal actually used is the mixture).
    const double q = share * (share > 0 ? map.pdf(w) : 0.0) + (1 - share) * lobe_pdf(p.brdf, p.normal, p.view, w);
    const double g = product_target(map, p, w);
    dir[size_t(j)] = w;
    gamma[size_t(j)] = g;
    if (q > 0 && g > 0) total += g / q;
    cum[size_t(j)] = total;
  }
  Resampled r;
  r.z = total / proposals;
  if (!(total > 0)) return r;
  // Systematic resampling: one uniform, N evenly spaced points through the cumulative weights.
  r.directions.reserve(size_t(samples));
  r.target.reserve(size_t(samples));
  const double u0 = rng.uniform();
  size_t j = 0;
  for (int i = 0; i < samples; ++i) {
    const double t = (i + u0) / samples * total;
    while (j + 1 < cum.size() && cum[j] <= t) ++j;
    r.directions.push_back(dir[j]);
    r.target.push_back(gamma[j]);
  }
  return r;
}

Rgb estimate_bis(const EnvDistribution& map, const ShadingPoint& p, const BisOptions& o, Rng& rng) {
  if (o.samples <= 0 || o.proposals_per_sample <= 0)
    throw InputError(fmt::format("bis: need positive samples and proposals per sample, got {} and {}", o.samples,
                                 o.proposals_per_sample));
  validate(p);
  const Resampled r =
      sample_importance_resample(map, p, o.samples * o.proposals_per_sample, o.samples, o.proposal_map_share, rng);
  Rgb sum{0, 0, 0};
  for (const Vec3& w : r.directions) {
    const Rgb c = colour_ratio(map, p, w);
    for (int ch = 0; ch < 3; ++ch) sum[ch] += c[ch];
  }
  const double scale = r.directions.empty() ? 0 : r.z / double(r.directions.size());
  return {sum[0] * scale, sum[1] * scale, sum[2] * scale};
}

}  // namespace lp
