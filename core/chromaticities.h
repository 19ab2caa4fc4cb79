// The colour space of a file's RGB, by its primaries and white point (CIE xy), and the
// matrix to CONVENTIONS.md's linear Rec. 709 (D65), the maps' one colour space. OpenEXR
// files name theirs in a `chromaticities` attribute (ACES2065-1 files: AP0 at the ACES
// white), Radiance files in a PRIMARIES line; a file without either is Rec. 709.
#pragma once

#include <array>

namespace lp {

struct Chromaticities {
  // x, y of red, green, blue and white.
  std::array<double, 2> red{0.64, 0.33}, green{0.30, 0.60}, blue{0.15, 0.06}, white{0.3127, 0.3290};
};

inline constexpr Chromaticities kRec709{};

// Whether two sets agree to `tolerance` in every coordinate.
bool same_chromaticities(const Chromaticities& a, const Chromaticities& b, double tolerance = 1e-4);

// Row-major M with rgb_709 = M rgb_file: to XYZ by the file's primaries, its white adapted to
// D65 by the Bradford transform (as OpenColorIO's ACES configs do, so that the file's white
// stays neutral), then to Rec. 709. Identity for Rec. 709 itself (to rounding). Throws
// InputError naming `source` for primaries that span no colour space (collinear, y = 0) or a
// white with y <= 0.
std::array<double, 9> to_rec709_matrix(const Chromaticities& file, const char* source);

}  // namespace lp
