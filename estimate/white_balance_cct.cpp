#include "estimate/white_balance_cct.h"

#include <fmt/format.h>

#include <algorithm>
#include <cmath>

#include "core/error.h"

namespace lp {

namespace {

// Robertson's isotemperature lines: reciprocal megakelvin (mired), u, v of the locus point
// and the slope t of the isotherm in (u, v). Wyszecki & Stiles p. 228, with u at 325 mired
// as Robertson printed it (0.24792; the 0.24702 that many copies carry breaks the smooth
// run of the column, steps 0.00782 / 0.00799 instead of 0.00692 / 0.00889).
struct Isotherm {
  double mired, u, v, t;
};
constexpr Isotherm kIsotherms[] = {
    {0, 0.18006, 0.26352, -0.24341},   {10, 0.18066, 0.26589, -0.25479},  {20, 0.18133, 0.26846, -0.26876},
    {30, 0.18208, 0.27119, -0.28539},  {40, 0.18293, 0.27407, -0.30470},  {50, 0.18388, 0.27709, -0.32675},
    {60, 0.18494, 0.28021, -0.35156},  {70, 0.18611, 0.28342, -0.37915},  {80, 0.18740, 0.28668, -0.40955},
    {90, 0.18880, 0.28997, -0.44278},  {100, 0.19032, 0.29326, -0.47888}, {125, 0.19462, 0.30141, -0.58204},
    {150, 0.19962, 0.30921, -0.70471}, {175, 0.20525, 0.31647, -0.84901}, {200, 0.21142, 0.32312, -1.0182},
    {225, 0.21807, 0.32909, -1.2168},  {250, 0.22511, 0.33439, -1.4512},  {275, 0.23247, 0.33904, -1.7298},
    {300, 0.24010, 0.34308, -2.0637},  {325, 0.24792, 0.34655, -2.4681},  {350, 0.25591, 0.34951, -2.9641},
    {375, 0.26400, 0.35200, -3.5814},  {400, 0.27218, 0.35407, -4.3633},  {425, 0.28039, 0.35577, -5.3762},
    {450, 0.28863, 0.35714, -6.7262},  {475, 0.29685, 0.35823, -8.5955},  {500, 0.30505, 0.35907, -11.324},
    {525, 0.31320, 0.35968, -15.628},  {550, 0.32129, 0.36011, -23.325},  {575, 0.32931, 0.36038, -40.770},
    {600, 0.33724, 0.36051, -116.45},
};
constexpr int kIsothermCount = int(sizeof(kIsotherms) / sizeof(kIsotherms[0]));

}  // namespace

std::array<double, 3> rec709_to_xyz(const std::array<double, 3>& c) {
  return {0.4124564 * c[0] + 0.3575761 * c[1] + 0.1804375 * c[2],
          0.2126729 * c[0] + 0.7151522 * c[1] + 0.0721750 * c[2],
          0.0193339 * c[0] + 0.1191920 * c[1] + 0.9503041 * c[2]};
}

std::array<double, 3> xyz_to_rec709(const std::array<double, 3>& c) {
  return {3.2404542 * c[0] - 1.5371385 * c[1] - 0.4985314 * c[2],
          -0.9692660 * c[0] + 1.8760108 * c[1] + 0.0415560 * c[2],
          0.0556434 * c[0] - 0.2040259 * c[1] + 1.0572252 * c[2]};
}

Chromaticity chromaticity_of_rgb(const std::array<double, 3>& rgb, const char* what) {
  const auto xyz = rec709_to_xyz(rgb);
  const double s = xyz[0] + xyz[1] + xyz[2];
  if (!(s > 0) || !std::isfinite(s)) throw InputError(fmt::format("{}: colour has no positive XYZ sum", what));
  return {xyz[0] / s, xyz[1] / s};
}

std::array<double, 3> rgb_of_chromaticity(Chromaticity xy) {
  // Y = 1: X = x / y, Z = (1 - x - y) / y.
  const std::array<double, 3> xyz{xy.x / xy.y, 1.0, (1 - xy.x - xy.y) / xy.y};
  auto rgb = xyz_to_rec709(xyz);
  // Normalise to the luminance of lightprobe (0.2126 R + 0.7152 G + 0.0722 B), which
  // differs from the matrix's Y row in the fifth digit.
  const double y = 0.2126 * rgb[0] + 0.7152 * rgb[1] + 0.0722 * rgb[2];
  for (double& c : rgb) c /= y;
  return rgb;
}

Chromaticity planckian_xy(double t) {
  t = std::clamp(t, 1667.0, 25000.0);
  const double t1 = 1e3 / t, t2 = t1 * t1, t3 = t2 * t1;  // in units of 1000 K
  const double x = t <= 4000 ? -0.2661239 * t3 - 0.2343589 * t2 + 0.8776956 * t1 + 0.179910
                             : -3.0258469 * t3 + 2.1070379 * t2 + 0.2226347 * t1 + 0.240390;
  const double x2 = x * x, x3 = x2 * x;
  double y;
  if (t <= 2222)
    y = -1.1063814 * x3 - 1.34811020 * x2 + 2.18555832 * x - 0.20219683;
  else if (t <= 4000)
    y = -0.9549476 * x3 - 1.37418593 * x2 + 2.09137015 * x - 0.16748867;
  else
    y = 3.0817580 * x3 - 5.87338670 * x2 + 3.75112997 * x - 0.37001483;
  return {x, y};
}

std::array<double, 3> planckian_rgb(double t_kelvin) { return rgb_of_chromaticity(planckian_xy(t_kelvin)); }

CctEstimate cct_robertson(Chromaticity xy) {
  const double den = 1.5 - xy.x + 6.0 * xy.y;  // CIE 1960 UCS: u = 4X/(X+15Y+3Z), in xy
  const double u = 2.0 * xy.x / den, v = 3.0 * xy.y / den;
  // Signed distance of (u, v) to each isotherm; the CCT lies between the two isotherms
  // where it changes sign, interpolated linearly in mired.
  auto distance = [&](int i) {
    const Isotherm& k = kIsotherms[i];
    return ((v - k.v) - k.t * (u - k.u)) / std::sqrt(1 + k.t * k.t);
  };
  CctEstimate out;
  double prev = distance(0);
  int i = 1;
  for (; i < kIsothermCount; ++i) {
    const double d = distance(i);
    if ((prev <= 0) != (d <= 0) || i == kIsothermCount - 1) {
      if ((prev <= 0) == (d <= 0)) out.in_range = false;
      const double f = (prev <= 0) == (d <= 0) ? 1.0 : prev / (prev - d);
      const double mired = kIsotherms[i - 1].mired + f * (kIsotherms[i].mired - kIsotherms[i - 1].mired);
      out.kelvin = mired > 0 ? 1e6 / mired : INFINITY;
      if (mired <= 0) out.in_range = false;
      // Duv: distance from the locus point interpolated between the two table points.
      const double lu = kIsotherms[i - 1].u + f * (kIsotherms[i].u - kIsotherms[i - 1].u);
      const double lv = kIsotherms[i - 1].v + f * (kIsotherms[i].v - kIsotherms[i - 1].v);
      const double du = u - lu, dv = v - lv;
      out.duv = std::copysign(std::sqrt(du * du + dv * dv), dv);
      break;
    }
    prev = d;
  }
  return out;
}

double cct_mccamy(Chromaticity xy) {
  const double n = (xy.x - 0.3320) / (0.1858 - xy.y);
  return 449.0 * n * n * n + 3525.0 * n * n + 6823.3 * n + 5520.33;
}

std::array<double, 3> illuminant_from_wb_gains(const std::array<double, 3>& g, const std::string_view source) {
  for (double c : g)
    if (!std::isfinite(c) || c <= 0)
      throw InputError(fmt::format("{}: white-balance gains must be finite and positive, got [{}, {}, {}]", source,
                                   g[0], g[1], g[2]));
  std::array<double, 3> rgb{1 / g[0], 1 / g[1], 1 / g[2]};
  const double y = 0.2126 * rgb[0] + 0.7152 * rgb[1] + 0.0722 * rgb[2];
  for (double& c : rgb) c /= y;
  return rgb;
}

std::array<double, 3> wb_gains_for_illuminant(const std::array<double, 3>& rgb) {
  return {rgb[1] / rgb[0], 1.0, rgb[1] / rgb[2]};
}

}  // namespace lp
