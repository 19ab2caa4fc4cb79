// Colour of the light from what a camera's auto white balance already computed:
// white-balance gains (or a reported CCT) -> illuminant chromaticity -> correlated colour
// temperature (CCT), and back (black-body chromaticity) for synthetic cameras and tests.
//
//   gains -> illuminant   The gains (g_r, g_g, g_b) make the illuminant neutral, so the
//                         illuminant in camera RGB is (1/g_r, 1/g_g, 1/g_b). ASSUMPTION: the
//                         camera's raw RGB is linear Rec. 709 (the primaries of every map in
//                         lightprobe); a real sensor needs its colour matrix first.
//   RGB -> XYZ -> xy      Rec. 709 / sRGB matrix (D65 white), x = X/(X+Y+Z), y = Y/(X+Y+Z).
//   xy -> CCT             Robertson (1968): the 31 isotemperature lines of Wyszecki & Stiles
//                         (2nd ed., p. 228) in CIE 1960 (u, v), interpolated in mired. Duv is
//                         the signed distance from the Planckian locus (positive above it,
//                         towards green); |Duv| > 0.02 is hardly "white" any more.
//                         McCamy (1992), a cubic in n = (x - 0.3320)/(0.1858 - y), is kept
//                         for comparison: good to a few K for 2856-6504 K only.
//   CCT -> xy             Kim et al. (2002) cubic spline of the Planckian locus, 1667-25000 K.
// Valid range of the whole chain: 1667-25000 K; outside it the functions clamp and say so
// through the returned flag, never silently.
#pragma once

#include <array>
#include <string_view>

namespace lp {

struct Chromaticity {
  double x = 0, y = 0;
};

// Linear Rec. 709 RGB <-> CIE XYZ (D65).
std::array<double, 3> rec709_to_xyz(const std::array<double, 3>& rgb);
std::array<double, 3> xyz_to_rec709(const std::array<double, 3>& xyz);
// xy of an RGB colour; throws InputError (naming `what`) when X + Y + Z <= 0.
Chromaticity chromaticity_of_rgb(const std::array<double, 3>& rgb, const char* what = "colour");
// Rec. 709 RGB of chromaticity xy with luminance Y = 1 (channels may go negative outside
// the gamut).
std::array<double, 3> rgb_of_chromaticity(Chromaticity xy);

// Black-body chromaticity (Kim et al. 2002); t_kelvin clamped to [1667, 25000].
Chromaticity planckian_xy(double t_kelvin);
// Rec. 709 RGB of a black body at luminance 1.
std::array<double, 3> planckian_rgb(double t_kelvin);

struct CctEstimate {
  double kelvin = 0;
  double duv = 0;          // signed distance from the locus in (u, v)
  bool in_range = true;    // false when clamped to the ends of Robertson's table (1667 K .. inf)
};
// Robertson's method. Throws nothing; out-of-table colours are clamped and flagged.
CctEstimate cct_robertson(Chromaticity xy);
// McCamy's cubic (for comparison).
double cct_mccamy(Chromaticity xy);

// Illuminant RGB (luminance 1) from white-balance gains (r, g, b), all > 0. `source` names
// the frame in the InputError on non-finite or non-positive gains.
std::array<double, 3> illuminant_from_wb_gains(const std::array<double, 3>& gains, const std::string_view source);
// The gains an ideal auto white balance sets under an illuminant of this RGB (g_g = 1).
std::array<double, 3> wb_gains_for_illuminant(const std::array<double, 3>& illuminant_rgb);

}  // namespace lp
