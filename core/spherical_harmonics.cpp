#include "core/spherical_harmonics.h"

#include <fmt/format.h>

#include <cmath>
#include <vector>

#include "core/error.h"
#include "core/sh9_json.h"

namespace lp {

namespace {

// Ramamoorthi & Hanrahan 2001, eq. 3, exact: three.js and most engines print them rounded
// to 6 digits (0.282095, 0.488603, 1.092548, 0.315392, 0.546274), 1e-6 relative away.
// Exact, sqrt(4 pi) L00 is the map's integral and the Y-up rotation is exact.
const double kSqrtPi = std::sqrt(M_PI);
const double kY0 = 1 / (2 * kSqrtPi);
const double kY1 = std::sqrt(3.0) / (2 * kSqrtPi);
const double kY2 = std::sqrt(15.0) / (2 * kSqrtPi);
const double kY20 = std::sqrt(5.0) / (4 * kSqrtPi);
const double kY22 = std::sqrt(15.0) / (4 * kSqrtPi);

[[noreturn]] void fail(const std::string& source, const std::string& what) {
  throw InputError(fmt::format("{}: {}", source, what));
}

// doc[key] when it is a string, else "" (absent or of another type).
std::string string_field(const nlohmann::json& doc, const char* key) {
  auto it = doc.find(key);
  return it != doc.end() && it->is_string() ? it->get<std::string>() : std::string();
}

}  // namespace

std::array<double, kSh9Count> sh9_basis(Vec3 d) {
  const double x = d.x, y = d.y, z = d.z;
  return {kY0,
          kY1 * y,
          kY1 * z,
          kY1 * x,
          kY2 * x * y,
          kY2 * y * z,
          kY20 * (3 * z * z - 1),
          kY2 * x * z,
          kY22 * (x * x - y * y)};
}

double sh9_cosine_weight(int i) { return i == 0 ? M_PI : i < 4 ? 2 * M_PI / 3 : M_PI / 4; }

namespace {

// Latlong and hemisphere maps: with x = sin(theta) cos(phi), y = sin(theta) sin(phi),
// z = cos(theta), every basis function is a function of the row times one of five of the
// column: 1, sin(phi), cos(phi), cos(phi) sin(phi), cos^2(phi) - sin^2(phi). So each row
// costs 15 multiply-adds a pixel (five column sums per channel) instead of the nine basis
// values and 27 multiply-adds of a per-pixel projection: about half the time (CPU time of
// bench sampling/sh9_*, with find_bad_pixel's fast path: a 1024x512 map 5.7 -> 2.1 ms,
// the live 360x90 frame 0.37 -> 0.13 ms). The sums are regrouped, so the coefficients move
// in the last bits (1e-15 relative; RowMapsEqualThePerPixelProjection).
Sh9 project_rows(const EnvMap& map, size_t* used) {
  const size_t width = size_t(map.width);
  // The column factors, from the same angle expressions as pixel_direction.
  std::vector<std::array<double, 5>> column(width);
  for (size_t u = 0; u < width; ++u) {
    const double phi = 2 * M_PI * (double(u) + 0.5) / map.width;
    const double c = std::cos(phi), s = std::sin(phi);
    column[u] = {1.0, s, c, c * s, c * c - s * s};
  }
  const double span = map.layout == Layout::Hemisphere ? M_PI / 2 : M_PI;  // as envmap.cpp
  const bool masked = !map.valid.empty();
  Sh9 sh;
  for (size_t row = 0; row < size_t(map.height); ++row) {
    double sums[5][3] = {};  // column factor t, channel c: sum of p_c * t over the row
    const size_t first = row * width;
    const float* p = map.rgb.data() + 3 * first;
    for (size_t u = 0; u < width; ++u, p += 3) {
      if (masked && !map.valid[first + u]) continue;
      ++*used;
      const double r = p[0], g = p[1], b = p[2];
      for (int t = 0; t < 5; ++t) {
        sums[t][0] += r * column[u][size_t(t)];
        sums[t][1] += g * column[u][size_t(t)];
        sums[t][2] += b * column[u][size_t(t)];
      }
    }
    const double dw = pixel_solid_angle(map, first);  // every pixel of a row has the same
    const double theta = span * (double(row) + 0.5) / map.height;
    const double st = std::sin(theta), ct = std::cos(theta);
    // Basis k = row factor * column factor index, in sh9_basis' order.
    const double row_factor[kSh9Count] = {kY0,      kY1 * st,      kY1 * ct,      kY1 * st,     kY2 * st * st,
                                          kY2 * st * ct, kY20 * (3 * ct * ct - 1), kY2 * st * ct, kY22 * st * st};
    static constexpr int kColumnFactor[kSh9Count] = {0, 1, 0, 2, 3, 1, 0, 2, 4};
    for (int k = 0; k < kSh9Count; ++k)
      for (int c = 0; c < 3; ++c) sh.coefficients[k][c] += dw * row_factor[k] * sums[kColumnFactor[k]][c];
  }
  return sh;
}

}  // namespace

Sh9 project_sh9(const EnvMap& map, std::string_view source) {
  if (const std::string bad = find_bad_pixel(map, source); !bad.empty()) throw InputError(bad);
  size_t used = 0;
  Sh9 sh;
  if (map.layout != Layout::Healpix) {
    sh = project_rows(map, &used);
  } else {
    const double dw = pixel_solid_angle(map, 0);  // equal-area
    for (size_t i = 0, n = map.pixel_count(); i < n; ++i) {
      if (!map.is_valid(i)) continue;
      ++used;
      const float* p = map.pixel(i);
      if (p[0] == 0 && p[1] == 0 && p[2] == 0) continue;
      const auto y = sh9_basis(pixel_direction(map, i));
      for (int k = 0; k < kSh9Count; ++k)
        for (int c = 0; c < 3; ++c) sh.coefficients[k][c] += double(p[c]) * y[k] * dw;
    }
  }
  if (used == 0) fail(std::string(source), "no valid pixels to project");
  return sh;
}

std::array<double, 3> sh9_radiance(const Sh9& sh, Vec3 direction) {
  const auto y = sh9_basis(direction);
  std::array<double, 3> out{0, 0, 0};
  for (int k = 0; k < kSh9Count; ++k)
    for (int c = 0; c < 3; ++c) out[c] += sh.coefficients[k][c] * y[k];
  return out;
}

std::array<double, 3> sh9_irradiance(const Sh9& sh, Vec3 normal) {
  const auto y = sh9_basis(normal);
  std::array<double, 3> out{0, 0, 0};
  for (int k = 0; k < kSh9Count; ++k)
    for (int c = 0; c < 3; ++c) out[c] += sh9_cosine_weight(k) * sh.coefficients[k][c] * y[k];
  return out;
}

std::array<double, 3> sh9_phong(const Sh9& sh, Vec3 reflection, double exponent) {
  const double s = exponent;
  const double band[3] = {1.0, (s + 1) / (s + 2), (3 * (s + 1) / (s + 3) - 1) / 2};
  const auto y = sh9_basis(reflection);
  std::array<double, 3> out{0, 0, 0};
  for (int k = 0; k < kSh9Count; ++k) {
    const double w = band[k == 0 ? 0 : k < 4 ? 1 : 2] * y[k];
    for (int c = 0; c < 3; ++c) out[c] += w * sh.coefficients[k][c];
  }
  return out;
}

std::array<double, 3> sh9_power(const Sh9& sh) {
  // Only Y00 integrates to non-zero: 4 pi Y00 L00 = sqrt(4 pi) L00 with Y00 = 1/sqrt(4 pi).
  const double k = 4 * M_PI * kY0;
  return {k * sh.coefficients[0][0], k * sh.coefficients[0][1], k * sh.coefficients[0][2]};
}

Sh9 scaled(const Sh9& sh, double factor) {
  Sh9 out = sh;
  for (auto& row : out.coefficients)
    for (double& v : row) v *= factor;
  return out;
}

Sh9 sh9_yup_from_zup(const Sh9& sh) {
  // With t = (x, z, -y) the Y-up direction of our d = (x, y, z): x = tx, y = -tz, z = ty.
  //   band 1: y -> -tz, z -> ty, x -> tx;
  //   band 2: xy -> -tx tz, yz -> -ty tz, xz -> tx ty,
  //           3z^2 - 1 -> -(3tz^2 - 1)/2 - (3/2)(tx^2 - ty^2),
  //           x^2 - y^2 -> -(3tz^2 - 1)/2 + (tx^2 - ty^2)/2;
  //   and kY20 / kY22 = 1 / sqrt 3 turns the Y20/Y22 mix into the weights sqrt(3)/2.
  const auto& c = sh.coefficients;
  const double h = std::sqrt(3.0) / 2;
  Sh9 out;
  for (int ch = 0; ch < 3; ++ch) {
    auto set = [&](int i, double v) { out.coefficients[i][ch] = v; };
    set(0, c[0][ch]);
    set(1, c[2][ch]);   // Y1-1 ~ ty   <- z
    set(2, -c[1][ch]);  // Y10  ~ tz   <- -y
    set(3, c[3][ch]);   // Y11  ~ tx   <- x
    set(4, c[7][ch]);   // Y2-2 ~ tx ty <- xz
    set(5, -c[5][ch]);  // Y2-1 ~ ty tz <- -yz
    set(6, -0.5 * c[6][ch] - h * c[8][ch]);
    set(7, -c[4][ch]);  // Y21  ~ tx tz <- -xy
    set(8, -h * c[6][ch] + 0.5 * c[8][ch]);
  }
  return out;
}

nlohmann::ordered_json sh9_rows_json(const Sh9& sh) {
  nlohmann::ordered_json rows = nlohmann::ordered_json::array();
  for (const auto& row : sh.coefficients) rows.push_back({row[0], row[1], row[2]});
  return rows;
}

Sh9 sh9_from_json_object(const nlohmann::json& object, const std::string& source, const std::string& where) {
  auto order = object.find("order");
  if (order == object.end()) fail(source, where + "missing \"order\"");
  if (!order->is_number_integer() || order->get<int64_t>() != kSh9Order)
    fail(source, fmt::format("{}order is {}, only order 2 (9 coefficients) is supported", where, order->dump()));
  auto rows = object.find("coefficients");
  if (rows == object.end()) fail(source, where + "missing \"coefficients\"");
  if (!rows->is_array() || rows->size() != kSh9Count)
    fail(source, where + "coefficients is not an array of 9 [r, g, b] rows");
  Sh9 sh;
  for (int k = 0; k < kSh9Count; ++k) {
    const auto& row = (*rows)[size_t(k)];
    if (!row.is_array() || row.size() != 3) fail(source, fmt::format("{}coefficient {} is not [r, g, b]", where, k));
    for (int c = 0; c < 3; ++c) {
      const auto& v = row[size_t(c)];
      if (!v.is_number() || !std::isfinite(v.get<double>()))
        fail(source, fmt::format("{}coefficient {} has a missing or non-finite component", where, k));
      sh.coefficients[k][c] = v.get<double>();
    }
  }
  return sh;
}

std::string sh9_to_json(const Sh9& sh, Units units) {
  nlohmann::ordered_json doc;
  doc["format"] = kShFormat;
  doc["order"] = kSh9Order;
  doc["frame_convention"] = "z-up";
  doc["units"] = std::string(to_string(units));
  doc["coefficients"] = sh9_rows_json(sh);
  return doc.dump(2) + "\n";
}

Sh9 sh9_from_json(const std::string& text, const std::string& source, Units* units) {
  nlohmann::json doc;
  try {
    doc = nlohmann::json::parse(text);
  } catch (const nlohmann::json::parse_error& e) {
    fail(source, fmt::format("not valid JSON (byte {})", e.byte));
  }
  if (!doc.is_object()) fail(source, "not a JSON object");
  if (string_field(doc, "format") != kShFormat) fail(source, fmt::format("format is not \"{}\"", kShFormat));
  if (string_field(doc, "frame_convention") != "z-up") fail(source, "frame_convention is not \"z-up\"");
  if (units) {
    const auto u = doc.contains("units") ? units_from_string(string_field(doc, "units")) : Units::Relative;
    if (!u) fail(source, "units is not \"relative\" or \"radiance\"");
    *units = *u;
  }
  return sh9_from_json_object(doc, source, "");
}

}  // namespace lp
