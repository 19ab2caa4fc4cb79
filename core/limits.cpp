#include "core/limits.h"

#include <fmt/format.h>

#include "core/error.h"

namespace lp {

namespace {
Limits& current() {
  static Limits limits;
  return limits;
}
}  // namespace

const Limits& limits() { return current(); }

void set_limits(const Limits& limits) {
  if (limits.max_pixels == 0) throw InputError("--max-pixels must be positive");
  if (limits.max_lights <= 0) throw InputError("--max-lights must be positive");
  if (limits.max_side <= 0 || limits.max_lut <= 0 || limits.max_frames <= 0 || limits.max_text_file_bytes == 0)
    throw std::invalid_argument("set_limits: every limit must be positive");
  current() = limits;
}

int max_nside() {
  int nside = 1;
  while (nside < (1 << 29) && 12 * uint64_t(2 * nside) * uint64_t(2 * nside) <= limits().max_pixels) nside *= 2;
  return nside;
}

uint64_t max_image_file_bytes() { return 32 * limits().max_pixels + (uint64_t(16) << 20); }

void check_image_size(std::string_view who, long long width, long long height, std::string_view what) {
  if (width <= 0 || height <= 0) throw InputError(fmt::format("{}: bad {} size {}x{}", who, what, width, height));
  const Limits& l = limits();
  if (width > l.max_side || height > l.max_side)
    throw InputError(fmt::format("{}: {} {}x{} is over the limit of {} pixels a side", who, what, width, height,
                                 l.max_side));
  const uint64_t pixels = uint64_t(width) * uint64_t(height);
  if (pixels > l.max_pixels)
    throw InputError(fmt::format("{}: {} {}x{} has {} pixels, over the limit of {} (raise it with --max-pixels)", who,
                                 what, width, height, pixels, l.max_pixels));
}

void check_nside(std::string_view who, long long nside) {
  if (nside > max_nside())
    throw InputError(fmt::format("{}: healpix nside {} ({} pixels) is over the limit of nside {} (raise it with "
                                 "--max-pixels, now {})",
                                 who, nside, 12 * uint64_t(nside) * uint64_t(nside), max_nside(), limits().max_pixels));
}

void check_light_count(std::string_view who, long long count) {
  if (count > limits().max_lights)
    throw InputError(fmt::format("{}: {} lights is over the limit of {} (raise it with --max-lights)", who, count,
                                 limits().max_lights));
}

void check_count(std::string_view who, long long count, long long max, std::string_view what, std::string_view why) {
  if (count > max) throw InputError(fmt::format("{}: {} {} is over the limit of {} ({})", who, count, what, max, why));
}

void check_file_size(const std::string& path, uint64_t bytes, uint64_t max_bytes, std::string_view kind) {
  if (bytes > max_bytes)
    throw InputError(fmt::format("{}: {} bytes is over the limit of {} bytes for {}", path, bytes, max_bytes, kind));
}

}  // namespace lp
