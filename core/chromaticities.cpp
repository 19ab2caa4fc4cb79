#include "core/chromaticities.h"

#include <fmt/format.h>

#include <cmath>
#include <cstdint>

#include "core/error.h"

namespace lp {
namespace {

using M3 = std::array<double, 9>;

M3 multiply(const M3& a, const M3& b) {
  M3 r{};
  for (int i = 0; i < 3; ++i)
    for (int j = 0; j < 3; ++j)
      for (int k = 0; k < 3; ++k) r[size_t(3 * i + j)] += a[size_t(3 * i + k)] * b[size_t(3 * k + j)];
  return r;
}

double determinant(const M3& m) {
  return m[0] * (m[4] * m[8] - m[5] * m[7]) - m[1] * (m[3] * m[8] - m[5] * m[6]) + m[2] * (m[3] * m[7] - m[4] * m[6]);
}

M3 inverse(const M3& m) {
  const double d = determinant(m);
  return {(m[4] * m[8] - m[5] * m[7]) / d, (m[2] * m[7] - m[1] * m[8]) / d, (m[1] * m[5] - m[2] * m[4]) / d,
          (m[5] * m[6] - m[3] * m[8]) / d, (m[0] * m[8] - m[2] * m[6]) / d, (m[2] * m[3] - m[0] * m[5]) / d,
          (m[3] * m[7] - m[4] * m[6]) / d, (m[1] * m[6] - m[0] * m[7]) / d, (m[0] * m[4] - m[1] * m[3]) / d};
}

std::array<double, 3> xyz_of(const std::array<double, 2>& xy) { return {xy[0] / xy[1], 1.0, (1 - xy[0] - xy[1]) / xy[1]}; }

// RGB -> XYZ of a set of primaries, white mapped to Y = 1 (the usual derivation: the
// primaries' XYZ columns scaled so that they sum to the white).
M3 rgb_to_xyz(const Chromaticities& c, const char* source) {
  // A primary may lie outside the spectral locus (AP0's blue has y = -0.077), but not on y = 0,
  // and the white must be a colour.
  for (const auto* xy : {&c.red, &c.green, &c.blue, &c.white})
    if ((*xy)[1] == 0 || !std::isfinite((*xy)[0]) || !std::isfinite((*xy)[1]))
      throw InputError(fmt::format("{}: chromaticities with y = 0 or not finite", source));
  if (!(c.white[1] > 0)) throw InputError(fmt::format("{}: a white point with y <= 0", source));
  const auto r = xyz_of(c.red), g = xyz_of(c.green), b = xyz_of(c.blue), w = xyz_of(c.white);
  const M3 p{r[0], g[0], b[0], r[1], g[1], b[1], r[2], g[2], b[2]};
  if (!(std::fabs(determinant(p)) > 1e-9))
    throw InputError(fmt::format("{}: chromaticities whose primaries span no colour space", source));
  const M3 pi = inverse(p);
  const double s[3] = {pi[0] * w[0] + pi[1] * w[1] + pi[2] * w[2], pi[3] * w[0] + pi[4] * w[1] + pi[5] * w[2],
                       pi[6] * w[0] + pi[7] * w[1] + pi[8] * w[2]};
  M3 m = p;
  for (int row = 0; row < 3; ++row)
    for (int col = 0; col < 3; ++col) m[size_t(3 * row + col)] *= s[col];
  return m;
}

// Bradford chromatic adaptation of XYZ from white `from` to white `to`.
M3 bradford(const std::array<double, 2>& from, const std::array<double, 2>& to) {
  const M3 b{0.8951, 0.2664, -0.1614, -0.7502, 1.7135, 0.0367, 0.0389, -0.0685, 1.0296};
  const auto cone = [&](const std::array<double, 3>& xyz) {
    return std::array<double, 3>{b[0] * xyz[0] + b[1] * xyz[1] + b[2] * xyz[2],
                                 b[3] * xyz[0] + b[4] * xyz[1] + b[5] * xyz[2],
                                 b[6] * xyz[0] + b[7] * xyz[1] + b[8] * xyz[2]};
  };
  const auto s = cone(xyz_of(from)), d = cone(xyz_of(to));
  const M3 scale{d[0] / s[0], 0, 0, 0, d[1] / s[1], 0, 0, 0, d[2] / s[2]};
  return multiply(inverse(b), multiply(scale, b));
}

}  // namespace

void apply_colour_matrix(std::vector<float>& rgb, const std::array<double, 9>& m) {
  for (size_t i = 0; i + 2 < rgb.size(); i += 3) {
    const double r = rgb[i], g = rgb[i + 1], b = rgb[i + 2];
    rgb[i] = float(m[0] * r + m[1] * g + m[2] * b);
    rgb[i + 1] = float(m[3] * r + m[4] * g + m[5] * b);
    rgb[i + 2] = float(m[6] * r + m[7] * g + m[8] * b);
  }
}

bool same_chromaticities(const Chromaticities& a, const Chromaticities& b, double tolerance) {
  const std::array<const std::array<double, 2>*, 4> pa{&a.red, &a.green, &a.blue, &a.white},
      pb{&b.red, &b.green, &b.blue, &b.white};
  for (size_t i = 0; i < 4; ++i)
    for (size_t k = 0; k < 2; ++k)
      if (!(std::fabs((*pa[i])[k] - (*pb[i])[k]) <= tolerance)) return false;
  return true;
}

std::array<double, 9> to_rec709_matrix(const Chromaticities& file, const char* source) {
  const M3 to_xyz = rgb_to_xyz(file, source);
  const M3 from_xyz = inverse(rgb_to_xyz(kRec709, source));
  const M3 m = multiply(from_xyz, multiply(bradford(file.white, kRec709.white), to_xyz));
  for (double v : m)
    if (!std::isfinite(v)) throw InputError(fmt::format("{}: chromaticities that give no finite conversion", source));
  return m;
}

namespace {

uint32_t be32(std::string_view b, size_t at) {
  return uint32_t(uint8_t(b[at])) << 24 | uint32_t(uint8_t(b[at + 1])) << 16 | uint32_t(uint8_t(b[at + 2])) << 8 |
         uint32_t(uint8_t(b[at + 3]));
}

// The tag's bytes, or empty when absent or outside the profile.
std::string_view icc_tag(std::string_view icc, const char signature[5]) {
  const uint32_t count = be32(icc, 128);
  for (uint32_t i = 0; i < count && 132 + 12 * size_t(i) + 12 <= icc.size(); ++i) {
    const size_t entry = 132 + 12 * size_t(i);
    if (icc.substr(entry, 4) != std::string_view(signature, 4)) continue;
    const size_t offset = be32(icc, entry + 4), size = be32(icc, entry + 8);
    if (offset > icc.size() || size > icc.size() - offset) return {};
    return icc.substr(offset, size);
  }
  return {};
}

std::optional<std::array<double, 3>> icc_xyz(std::string_view icc, const char signature[5]) {
  const std::string_view t = icc_tag(icc, signature);
  if (t.size() < 20 || t.substr(0, 4) != "XYZ ") return std::nullopt;
  std::array<double, 3> v{};
  for (size_t k = 0; k < 3; ++k) v[k] = double(int32_t(be32(t, 8 + 4 * k))) / 65536.0;
  return v;
}

std::string icc_description(std::string_view icc) {
  const std::string_view t = icc_tag(icc, "desc");
  std::string out;
  auto keep = [&](uint32_t c) {
    if (c >= 32 && c < 127 && out.size() < 80) out += char(c);
  };
  if (t.size() >= 12 && t.substr(0, 4) == "desc") {  // v2 textDescriptionType: ASCII
    const size_t n = be32(t, 8);
    for (size_t i = 0; i < n && 12 + i < t.size(); ++i) keep(uint8_t(t[12 + i]));
  } else if (t.size() >= 28 && t.substr(0, 4) == "mluc") {  // v4: the first record, UTF-16BE
    const size_t length = be32(t, 20), offset = be32(t, 24);
    for (size_t i = 0; i + 1 < length && offset + i + 1 < t.size(); i += 2)
      keep(uint32_t(uint8_t(t[offset + i])) << 8 | uint8_t(t[offset + i + 1]));
  }
  while (!out.empty() && out.back() == ' ') out.pop_back();
  return out;
}

}  // namespace

std::optional<IccSummary> summarize_icc_profile(std::string_view icc) {
  if (icc.size() < 132 || icc.substr(36, 4) != "acsp") return std::nullopt;
  IccSummary s;
  s.description = icc_description(icc);
  const auto r = icc_xyz(icc, "rXYZ"), g = icc_xyz(icc, "gXYZ"), b = icc_xyz(icc, "bXYZ");
  if (r && g && b) {
    s.has_colorants = true;
    // sRGB's colorants as ICC profiles store them (IEC 61966-2-1, Bradford-adapted to D50).
    const std::array<std::array<double, 3>, 3> srgb{{{0.4361, 0.2225, 0.0139}, {0.3851, 0.7169, 0.0971},
                                                     {0.1431, 0.0606, 0.7141}}};
    const std::array<std::array<double, 3>, 3> file{*r, *g, *b};
    s.colorants = file;
    s.srgb = true;
    for (size_t i = 0; i < 3; ++i)
      for (size_t k = 0; k < 3; ++k) s.srgb = s.srgb && std::fabs(file[i][k] - srgb[i][k]) <= 3e-3;
  } else {
    s.srgb = s.description.find("sRGB") != std::string::npos;
  }
  return s;
}

std::array<double, 9> icc_colorants_to_rec709(const IccSummary& profile, const char* source) {
  if (!profile.has_colorants) throw InputError(fmt::format("{}: an ICC profile without colorants", source));
  auto xy = [&](const std::array<double, 3>& xyz) {
    const double sum = xyz[0] + xyz[1] + xyz[2];
    if (!(std::fabs(sum) > 1e-9)) throw InputError(fmt::format("{}: an ICC colorant of zero", source));
    return std::array<double, 2>{xyz[0] / sum, xyz[1] / sum};
  };
  const auto& c = profile.colorants;
  const std::array<double, 3> white{c[0][0] + c[1][0] + c[2][0], c[0][1] + c[1][1] + c[2][1], c[0][2] + c[1][2] + c[2][2]};
  return to_rec709_matrix(Chromaticities{xy(c[0]), xy(c[1]), xy(c[2]), xy(white)}, source);
}

}  // namespace lp
