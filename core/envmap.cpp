#include "core/envmap.h"

#include <fmt/format.h>

#include <algorithm>
#include <bit>
#include <cstdint>
#include <cmath>
#include <limits>

#include "core/error.h"

#include "core/healpix.h"

namespace lp {

std::string_view to_string(Layout layout) {
  switch (layout) {
    case Layout::LatLong: return "latlong";
    case Layout::Hemisphere: return "hemisphere";
    case Layout::Healpix: return "healpix";
  }
  return "?";
}

std::optional<Layout> layout_from_string(std::string_view name) {
  if (name == "latlong") return Layout::LatLong;
  if (name == "hemisphere") return Layout::Hemisphere;
  if (name == "healpix") return Layout::Healpix;
  return std::nullopt;
}

std::string_view to_string(Units units) { return units == Units::Radiance ? "radiance" : "relative"; }

std::optional<Units> units_from_string(std::string_view name) {
  if (name == "relative") return Units::Relative;
  if (name == "radiance") return Units::Radiance;
  return std::nullopt;
}

namespace {

EnvMap blank(Layout layout, int width, int height) {
  EnvMap m;
  m.layout = layout;
  m.width = width;
  m.height = height;
  m.rgb.assign(3 * m.pixel_count(), 0.0f);
  return m;
}

bool is_power_of_two(int n) { return n > 0 && (n & (n - 1)) == 0; }

// Zenith range covered by a row grid: [0, pi] for latlong, [0, pi/2] for hemisphere.
double theta_span(Layout layout) { return layout == Layout::Hemisphere ? M_PI / 2 : M_PI; }

}  // namespace

EnvMap make_latlong(int width, int height) {
  if (height <= 0 || width != 2 * height)
    throw InputError(fmt::format("latlong map must be 2H x H, got {}x{}", width, height));
  return blank(Layout::LatLong, width, height);
}

EnvMap make_hemisphere(int width, int height) {
  if (width <= 0 || height <= 0)
    throw InputError(fmt::format("hemisphere map needs a positive size, got {}x{}", width, height));
  return blank(Layout::Hemisphere, width, height);
}

EnvMap make_healpix(int nside) {
  if (!is_power_of_two(nside) || nside > 8192)
    throw InputError(fmt::format("healpix nside must be a power of two up to 8192, got {}", nside));
  EnvMap m = blank(Layout::Healpix, 12 * nside * nside, 1);
  m.nside = nside;
  return m;
}

EnvMap make_envmap(Layout layout, int width, int height) {
  switch (layout) {
    case Layout::LatLong: return make_latlong(width, height);
    case Layout::Hemisphere: return make_hemisphere(width, height);
    case Layout::Healpix: return make_healpix(width);
  }
  throw InputError("unknown layout");
}

Vec3 pixel_direction(const EnvMap& map, size_t pixel) {
  if (map.layout == Layout::Healpix) {
    return healpix_direction(map.nside, int64_t(pixel));
  }
  const size_t u = pixel % size_t(map.width), row = pixel / size_t(map.width);
  const double phi = 2 * M_PI * (double(u) + 0.5) / map.width;
  const double theta = theta_span(map.layout) * (double(row) + 0.5) / map.height;
  return direction_from_angles(theta, phi);
}

double pixel_solid_angle(const EnvMap& map, size_t pixel) {
  if (map.layout == Layout::Healpix) return 4 * M_PI / double(map.pixel_count());
  const size_t row = pixel / size_t(map.width);
  const double span = theta_span(map.layout);
  const double t0 = span * double(row) / map.height, t1 = span * double(row + 1) / map.height;
  return (2 * M_PI / map.width) * (std::cos(t0) - std::cos(t1));
}

std::optional<size_t> pixel_at(const EnvMap& map, Vec3 d) {
  if (map.layout == Layout::Healpix) {
    return size_t(healpix_pixel(map.nside, d));
  }
  const double span = theta_span(map.layout);
  const double theta = zenith_of(d);
  if (theta > span) return std::nullopt;
  int row = int(theta / span * map.height);
  int u = int(azimuth_of(d) / (2 * M_PI) * map.width);
  row = std::min(std::max(row, 0), map.height - 1);
  u = std::min(std::max(u, 0), map.width - 1);
  return size_t(row) * size_t(map.width) + size_t(u);
}

double layout_solid_angle(Layout layout) { return layout == Layout::Hemisphere ? 2 * M_PI : 4 * M_PI; }

PixelTable make_pixel_table(const EnvMap& map) {
  const size_t n = map.pixel_count();
  PixelTable t;
  t.x.resize(n);
  t.y.resize(n);
  t.z.resize(n);
  t.solid_angle.resize(n);
  for (size_t i = 0; i < n; ++i) {
    const Vec3 d = pixel_direction(map, i);
    t.x[i] = float(d.x);
    t.y[i] = float(d.y);
    t.z[i] = float(d.z);
    t.solid_angle[i] = float(pixel_solid_angle(map, i));
  }
  return t;
}

std::array<double, 3> total_power(const EnvMap& map) {
  // Sum radiance per row first: every pixel of a row (or of a healpix map) has the same
  // solid angle, so one multiplication per row instead of two cosines per pixel.
  std::array<double, 3> sum{0, 0, 0};
  const size_t width = size_t(map.width);
  for (size_t row = 0; row < size_t(map.height); ++row) {
    std::array<double, 3> row_sum{0, 0, 0};
    for (size_t i = row * width; i < (row + 1) * width; ++i) {
      if (!map.is_valid(i)) continue;
      const float* p = map.pixel(i);
      for (int c = 0; c < 3; ++c) row_sum[c] += double(p[c]);
    }
    const double w = pixel_solid_angle(map, row * width);
    for (int c = 0; c < 3; ++c) sum[c] += w * row_sum[c];
  }
  return sum;
}

double total_luminance_power(const EnvMap& map) {
  const auto p = total_power(map);
  return luminance(p.data());
}

std::string find_bad_pixel(const EnvMap& map, std::string_view source) {
  const size_t n = map.pixel_count();
  // First one branch-free pass on the bits, which the compiler vectorises (integer ops only:
  // float comparisons with NaN did not vectorise): the common answer, "none", at about the
  // cost of one read (the classification below ran ~2 ns a value, a third of project_sh9's
  // time on a 1024x512 map). With m the bits without the sign: NaN and Inf have
  // m >= 0x7f800000, which carries into bit 31 once 0x00800000 is added; a negative value
  // has the sign bit and m != 0 (-0 is not negative, as below).
  const float* values = map.rgb.data();
  uint32_t flags = 0;
  for (size_t i = 0, m = 3 * n; i < m; ++i) {
    const uint32_t bits = std::bit_cast<uint32_t>(values[i]);
    const uint32_t magnitude = bits & 0x7fffffffu;
    const uint32_t nan_or_inf = (magnitude + 0x00800000u) & 0x80000000u;
    const uint32_t negative = (0u - (bits >> 31)) & magnitude;
    flags |= nan_or_inf | negative;
  }
  if (flags == 0) return {};
  for (size_t i = 0; i < n; ++i) {
    const float* p = map.pixel(i);
    for (int c = 0; c < 3; ++c) {
      const float v = p[c];
      const char* what = std::isnan(v) ? "NaN" : std::isinf(v) ? "infinite" : v < 0 ? "negative" : nullptr;
      if (!what) continue;
      if (map.layout == Layout::Healpix)
        return fmt::format("{}: healpix pixel {} is {}", source, i, what);
      return fmt::format("{}: pixel ({}, {}) is {}", source, i % size_t(map.width), i / size_t(map.width), what);
    }
  }
  return {};
}

NegativeValues find_negative_values(const EnvMap& map) {
  NegativeValues r;
  std::array<double, 3> positive{0, 0, 0}, negative{0, 0, 0};
  // Row by row: a row-grid pixel's solid angle depends on its row only (healpix: on nothing).
  const size_t width = map.layout == Layout::Healpix ? map.pixel_count() : size_t(map.width);
  for (size_t start = 0, n = map.pixel_count(); start < n; start += width) {
    const double dw = pixel_solid_angle(map, start);
    std::array<double, 3> row_positive{0, 0, 0}, row_negative{0, 0, 0};
    for (size_t i = start; i < start + width; ++i) {
      const float* p = map.pixel(i);
      const bool has_negative = p[0] < 0 || p[1] < 0 || p[2] < 0;
      r.count += has_negative ? 1 : 0;
      if (has_negative) r.lowest = std::min({r.lowest, p[0], p[1], p[2]});
      if (!map.is_valid(i)) continue;
      for (int c = 0; c < 3; ++c) {
        const float v = p[c];
        if (v < 0)
          row_negative[size_t(c)] -= v;
        else if (v < std::numeric_limits<float>::infinity())  // NaN and Inf are find_bad_pixel's
          row_positive[size_t(c)] += v;
      }
    }
    for (int c = 0; c < 3; ++c) positive[size_t(c)] += dw * row_positive[size_t(c)], negative[size_t(c)] += dw * row_negative[size_t(c)];
  }
  for (int c = 0; c < 3; ++c)
    if (negative[size_t(c)] > 0)
      r.share = std::max(r.share, positive[size_t(c)] > 0 ? negative[size_t(c)] / positive[size_t(c)]
                                                            : std::numeric_limits<double>::infinity());
  return r;
}

void clamp_negative_values(EnvMap& map) {
  for (float& v : map.rgb)
    if (v < 0) v = 0.0f;
}

std::string describe_size(const EnvMap& map) {
  if (map.layout == Layout::Healpix) return fmt::format("healpix nside {}", map.nside);
  return fmt::format("{} {}x{}", to_string(map.layout), map.width, map.height);
}

}  // namespace lp
