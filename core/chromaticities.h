// The colour space of a file's RGB, by its primaries and white point (CIE xy), and the
// matrix to CONVENTIONS.md's linear Rec. 709 (D65), the maps' one colour space. OpenEXR
// files name theirs in a `chromaticities` attribute (ACES2065-1 files: AP0 at the ACES
// white), Radiance files in a PRIMARIES line; a file without either is Rec. 709.
#pragma once

#include <array>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

namespace lp {

struct Chromaticities {
  // x, y of red, green, blue and white.
  std::array<double, 2> red{0.64, 0.33}, green{0.30, 0.60}, blue{0.15, 0.06}, white{0.3127, 0.3290};
};

inline constexpr Chromaticities kRec709{};

// rgb = M rgb for every pixel of an interleaved RGB buffer (M row-major, in double).
void apply_colour_matrix(std::vector<float>& rgb, const std::array<double, 9>& m);

// Whether two sets agree to `tolerance` in every coordinate.
bool same_chromaticities(const Chromaticities& a, const Chromaticities& b, double tolerance = 1e-4);

// Row-major M with rgb_709 = M rgb_file: to XYZ by the file's primaries, its white adapted to
// D65 by the Bradford transform (as OpenColorIO's ACES configs do, so that the file's white
// stays neutral), then to Rec. 709. Identity for Rec. 709 itself (to rounding). Throws
// InputError naming `source` for primaries that span no colour space (collinear, y = 0) or a
// white with y <= 0.
std::array<double, 9> to_rec709_matrix(const Chromaticities& file, const char* source);

// What an embedded ICC profile (of a camera JPEG, PNG or TIFF) says about its colours: its
// description, and whether it is sRGB, by its colorants (rXYZ, gXYZ, bXYZ within 3e-3 of
// sRGB's, adapted to D50 as ICC stores them) or, for a profile without colorants (a LUT
// profile), by its description naming sRGB. nullopt for bytes that are not an ICC profile
// with a tag table (nothing is read beyond them).
struct IccSummary {
  std::string description;  // ASCII of the 'desc' tag (v2 text or v4 mluc); empty when none
  bool srgb = false;
  bool has_colorants = false;
  std::array<std::array<double, 3>, 3> colorants{};  // rXYZ, gXYZ, bXYZ (D50), when has_colorants
};
std::optional<IccSummary> summarize_icc_profile(std::string_view icc);

// Row-major M with rgb_709 = M rgb_linear for a matrix profile's colorants: their
// chromaticities, the white their sum (D50, as ICC stores it), through to_rec709_matrix.
std::array<double, 9> icc_colorants_to_rec709(const IccSummary& profile, const char* source);

}  // namespace lp
