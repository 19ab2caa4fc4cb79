// The one picture encoder: every PNG/JPEG/TIFF the library writes or serves (overlays,
// previews, calibration plots, synthetic camera frames, the live /probe.png) is encoded
// here, with OpenCV's codecs at their default settings (JPEG at quality 95). The format is
// the extension of `path` (.png when it has none); failures throw InputError naming `path`.
// write_display_image (core/image_io.h) writes a display picture to a file.
#pragma once

#include <cstdint>
#include <string>
#include <utility>
#include <vector>

namespace lp {

// Interleaved RGB code values (8- or 16-bit), top row first, encoded as they are: no
// transfer curve. `png_texts` (keyword, text) go into a PNG as tEXt chunks before its pixels
// (core/image_io.h: "lightprobe.mirror_ball"); other formats carry none.
std::string encode_rgb_codes(const std::string& path, int width, int height, int bit_depth,
                             const std::vector<uint16_t>& rgb,
                             const std::vector<std::pair<std::string, std::string>>& png_texts = {});

// Display RGB in [0, 1] (tone-mapped, linear) as 8-bit sRGB (srgb_code, core/tonemap.h)
// in the format of `path` (.png, .jpg or .jpeg): the bytes write_display_image writes.
std::string encode_display_image(const std::string& path, int width, int height, const std::vector<float>& rgb);
// The same as PNG, in memory (servers).
std::string encode_display_png(int width, int height, const std::vector<float>& rgb);

}  // namespace lp
