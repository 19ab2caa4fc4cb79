#include "core/sensor_white_level.h"

#include <fmt/format.h>

#include <algorithm>
#include <cmath>

#include "core/error.h"
#include "core/warnings.h"

namespace lp {
namespace {

long code_of(float v) { return std::lround(double(v) * 65535.0); }

}  // namespace

SensorWhiteLevel find_sensor_white_level(const std::vector<const std::vector<float>*>& images) {
  long top = 0;
  size_t values = 0;
  for (const auto* image : images) {
    values = std::max(values, image->size());
    for (float v : *image) top = std::max(top, code_of(v));
  }
  if (top <= 0 || top >= 32768) return {};  // the top bit is used: the container's own range
  // A sensor's white level is 2^N - 1 (Mono10 1023, Mono12 4095, Mono14 16383). Any other
  // top code piles up without a clip: a flat synthetic frame, an 8-bit image scaled to 16
  // bits (k x 257) that stays dark.
  if (top < 255 || ((top + 1) & top) != 0) return {};
  size_t at_top = 0;
  for (const auto* image : images)
    for (float v : *image) at_top += code_of(v) == top;
  if (at_top < std::max<size_t>(16, values / 10000)) return {};
  return {top, at_top};
}

void read_at_white_level(std::vector<float>& values, long code) {
  for (float& v : values) v = code_of(v) >= code ? 1.0f : float(double(code_of(v)) / double(code));
}

int white_level_bits(long code) { return int(std::ceil(std::log2(double(code) + 1.0))); }

int SequenceWhiteLevel::read(std::vector<float>& values, const std::string& file) {
  if (code_ < 0) {
    const SensorWhiteLevel level = find_sensor_white_level({&values});
    code_ = level.code;
    if (code_)
      warn(fmt::format("{}: its 16-bit codes stop at {}, {} values clipped there: read as a {}-bit sensor's codes, "
                       "white level {} (for every frame)",
                       file, code_, level.at_top, white_level_bits(code_), code_));
  }
  if (code_ == 0) return 16;
  long top = 0;
  for (float v : values) top = std::max(top, code_of(v));
  if (top > code_)
    throw InputError(fmt::format("{}: 16-bit codes up to {} above the white level {} the first frame showed", file, top, code_));
  read_at_white_level(values, code_);
  return white_level_bits(code_);
}

}  // namespace lp
