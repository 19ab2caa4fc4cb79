#include "probe/camera_codes.h"

#include <cmath>
#include <cstdint>

#include <fmt/format.h>

#include "core/error.h"
#include "core/tonemap.h"

namespace lp {

CodeCurve response_code_curve(const std::array<std::vector<float>, 3>& log_exposure, const std::string& name) {
  CodeCurve c;
  c.kind = CodeCurve::Kind::Table;
  c.name = name;
  for (size_t ch = 0; ch < 3; ++ch)
    for (float g : log_exposure[ch]) c.table[ch].push_back(std::exp(double(g)));
  return c;
}

CodeTable make_code_table(const CodeCurve& curve, int bits, const std::string& file) {
  if (bits < 1 || bits > 16) throw InputError(fmt::format("{}: {}-bit codes are not supported", file, bits));
  CodeTable t;
  t.bits = bits;
  const size_t levels = size_t(1) << bits;
  const double top = double(levels - 1);
  for (size_t c = 0; c < 3; ++c) {
    if (curve.kind == CodeCurve::Kind::Table && curve.table[c].size() != levels)
      throw InputError(fmt::format("{}: {}-bit codes ({} levels), but the response {} has {} levels", file, bits,
                                   levels, curve.name, curve.table[c].size()));
    t.linear[c].resize(levels);
    for (size_t z = 0; z < levels; ++z) {
      const double v = double(z) / top;
      double linear = v;
      if (curve.kind == CodeCurve::Kind::Srgb)
        linear = srgb_to_linear(v);
      else if (curve.kind == CodeCurve::Kind::Table)
        linear = curve.table[c][z];
      t.linear[c][z] = float(linear);
    }
  }
  return t;
}

size_t apply_code_table(float* rgb, size_t pixels, const CodeTable& table) {
  const size_t levels = size_t(1) << table.bits;
  const double top = double(levels - 1);
  const float* lut[3] = {table.linear[0].data(), table.linear[1].data(), table.linear[2].data()};
  // The level, rounded half away from zero as std::lround (x + 0.5 truncated, x >= 0),
  // without its call; NaN and negatives fail the comparison and take level 0.
  const auto level_of = [&](float s) -> size_t {
    const double x = double(s) * top;
    return x > 0 ? (x < top ? size_t(x + 0.5) : levels - 1) : 0;
  };
  size_t clipped = 0;
  for (size_t i = 0; i < pixels; ++i) {
    float* p = rgb + 3 * i;
    const size_t r = level_of(p[0]), g = level_of(p[1]), b = level_of(p[2]);
    clipped += (r == levels - 1) | (g == levels - 1) | (b == levels - 1);
    p[0] = lut[0][r], p[1] = lut[1][g], p[2] = lut[2][b];
  }
  return clipped;
}

CodesReport linearise_codes(RgbImage& image, const CodeTable& table, const std::string& file) {
  CodesReport report;
  if (image.code_bits <= 0) return report;
  if (image.code_bits != table.bits)
    throw InputError(fmt::format("{}: {}-bit codes, but its code table is for {}-bit ones", file, image.code_bits,
                                 table.bits));
  const size_t pixels = size_t(image.width) * size_t(image.height);
  const size_t clipped = apply_code_table(image.rgb.data(), pixels, table);
  image.code_bits = 0;
  report.linearised = true;
  report.clipped_fraction = pixels ? double(clipped) / double(pixels) : 0.0;
  return report;
}

CodesReport linearise_codes(RgbImage& image, const CodeCurve& curve, const std::string& file) {
  if (image.code_bits <= 0) return {};
  return linearise_codes(image, make_code_table(curve, image.code_bits, file), file);
}

void require_curve_for_deep_codes(const RgbImage& image, bool curve_given, const std::string& file) {
  if (image.code_bits > 8 && !curve_given)
    throw InputError(fmt::format("{}: {}-bit camera codes may be linear (a raw developer's) or gamma-encoded (an "
                                 "editor's): say which with --codes linear, --codes srgb or --codes RESPONSE.json",
                                 file, image.code_bits));
}

}  // namespace lp
