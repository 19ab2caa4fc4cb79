#include "probe/camera_codes.h"

#include <cmath>
#include <cstdint>

#include <fmt/format.h>

#include "core/error.h"
#include "core/tonemap.h"

namespace lp {

CodesReport linearise_codes(RgbImage& image, const CodeCurve& curve, const std::string& file) {
  CodesReport report;
  if (image.code_bits <= 0) return report;
  const int bits = image.code_bits;
  const size_t levels = size_t(1) << bits;
  const double top = double(levels - 1);
  // One table per channel, by level: 256 or 65536 entries, cheaper than a pow per sample.
  std::array<std::vector<float>, 3> lut;
  for (int c = 0; c < 3; ++c) {
    lut[size_t(c)].resize(levels);
    if (curve.kind == CodeCurve::Kind::Table && curve.table[size_t(c)].size() != levels)
      throw InputError(fmt::format("{}: {}-bit codes ({} levels), but the response {} has {} levels", file, bits,
                                   levels, curve.name, curve.table[size_t(c)].size()));
    for (size_t z = 0; z < levels; ++z) {
      const double v = double(z) / top;
      double linear = v;
      if (curve.kind == CodeCurve::Kind::Srgb)
        linear = srgb_to_linear(v);
      else if (curve.kind == CodeCurve::Kind::Table)
        linear = curve.table[size_t(c)][z];
      lut[size_t(c)][z] = float(linear);
    }
  }
  size_t clipped = 0;
  const size_t pixels = size_t(image.width) * size_t(image.height);
  for (size_t i = 0; i < pixels; ++i) {
    bool at_top = false;
    for (size_t c = 0; c < 3; ++c) {
      float& s = image.rgb[3 * i + c];
      const auto level = size_t(std::lround(double(s) * top));  // read_camera_image's code / (2^bits - 1)
      at_top = at_top || level == levels - 1;
      s = lut[c][level < levels ? level : levels - 1];
    }
    clipped += at_top;
  }
  image.code_bits = 0;
  report.linearised = true;
  report.clipped_fraction = pixels ? double(clipped) / double(pixels) : 0.0;
  return report;
}

}  // namespace lp
