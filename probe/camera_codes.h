// The code values of a probe photo (an 8- or 16-bit camera image, core/image_io.h
// read_rgb_image) as relative linear radiance. Maps are linear (CONVENTIONS.md); a JPEG's
// codes are not: unwrapped as they were, code 128 became 0.50 where its light is 0.22 of
// the top code's, and every gradient of the map was bent.
#pragma once

#include <array>
#include <string>
#include <vector>

#include "core/image_io.h"

namespace lp {

// How codes encode light.
struct CodeCurve {
  enum class Kind { Srgb, Linear, Table };
  Kind kind = Kind::Srgb;
  // Table: per channel (R, G, B), the relative radiance of every code level, such as a
  // camera response recovered by `hdr response` (exp g(z)); its size is the number of levels
  // and must be 2^bits of the images it is applied to.
  std::array<std::vector<double>, 3> table;
  std::string name = "srgb";  // for reports and messages: "srgb", "linear", or the response file
};

// A camera response recovered by `hdr response` (hdr/response.h: g(z) = ln E per level and
// channel) as a table curve of exp g(z), named `name` in reports and messages.
CodeCurve response_code_curve(const std::array<std::vector<float>, 3>& log_exposure, const std::string& name);

struct CodesReport {
  bool linearised = false;       // the image held codes (code_bits > 0) and now holds radiance
  double clipped_fraction = 0;   // share of pixels with a channel at the top code
};

// A curve's relative radiance for every level of `bits`-bit codes, per channel, in float:
// built once for a sequence or a stream and applied to every frame (for 16-bit codes it is
// 65,536 powers or exponentials a channel, milliseconds next to one frame's lookups).
struct CodeTable {
  int bits = 0;
  std::array<std::vector<float>, 3> linear;  // [channel][level]
};
// Throws InputError naming `file` when a table curve's levels are not 2^bits.
CodeTable make_code_table(const CodeCurve& curve, int bits, const std::string& file);

// `rgb` (pixels x 3 floats, each a code / (2^bits - 1)) through `table`, in place; returns
// how many pixels had a channel at the top code. A value outside [0, 1] takes the nearest
// level's entry (a NaN the lowest).
size_t apply_code_table(float* rgb, size_t pixels, const CodeTable& table);

// InputError naming `file` for camera codes deeper than 8 bits read without a curve
// (`curve_given` false): a raw developer writes linear 16-bit codes, an editor gamma-encoded
// ones, and nothing in the file tells them apart.
void require_curve_for_deep_codes(const RgbImage& image, bool curve_given, const std::string& file);

// `image`'s codes as relative linear radiance, in place (sRGB: IEC 61966-2-1's decoding; a
// table: the entry of each code's level); code_bits is then 0. An image that is radiance
// already (code_bits 0) is left alone. Pixels at the top code in any channel are clipped:
// their light is at least that, and their share is reported. Throws InputError naming
// `file` when a table's levels are not the image's 2^bits.
CodesReport linearise_codes(RgbImage& image, const CodeCurve& curve, const std::string& file);
// The same with a table built once (its bits must be the image's, else InputError naming `file`).
CodesReport linearise_codes(RgbImage& image, const CodeTable& table, const std::string& file);

}  // namespace lp
