#include "core/picture_io.h"

#include <fmt/format.h>

#include <algorithm>
#include <cmath>
#include <opencv2/core.hpp>
#include <opencv2/imgcodecs.hpp>  // the IMWRITE_ numbers; the codecs are in core/lazy_libs.h
#include <stdexcept>

#include "core/error.h"
#include "core/file_io.h"
#include "core/image_io.h"
#include "core/lazy_libs.h"
#include "core/tonemap.h"

namespace lp {

std::string encode_rgb_codes(const std::string& path, int width, int height, int bit_depth,
                             const std::vector<uint16_t>& rgb) {
  if (bit_depth != 8 && bit_depth != 16) throw InputError(fmt::format("{}: bit depth must be 8 or 16", path));
  if (width <= 0 || height <= 0 || rgb.size() != 3 * size_t(width) * size_t(height))
    throw InputError(fmt::format("{}: image buffer does not match its size", path));
  std::string ext = lower_extension(path);
  if (ext.empty()) ext = ".png";
  cv::Mat m(height, width, bit_depth == 8 ? CV_8UC3 : CV_16UC3);
  for (int y = 0; y < height; ++y) {
    const uint16_t* p = &rgb[3 * size_t(y) * size_t(width)];
    if (bit_depth == 8) {
      uint8_t* row = m.ptr<uint8_t>(y);
      for (int i = 0; i < 3 * width; i += 3)  // OpenCV is BGR
        row[i] = uint8_t(p[i + 2]), row[i + 1] = uint8_t(p[i + 1]), row[i + 2] = uint8_t(p[i]);
    } else {
      uint16_t* row = m.ptr<uint16_t>(y);
      for (int i = 0; i < 3 * width; i += 3) row[i] = p[i + 2], row[i + 1] = p[i + 1], row[i + 2] = p[i];
    }
  }
  std::vector<uint8_t> buf;
  std::vector<int> params;
  if (ext == ".jpg" || ext == ".jpeg") params = {cv::IMWRITE_JPEG_QUALITY, 95};
  if (!lazy::encode_image(ext, m, params, buf)) throw InputError(fmt::format("{}: cannot encode as {}", path, ext));
  return std::string(buf.begin(), buf.end());
}

std::string encode_display_image(const std::string& path, int width, int height, const std::vector<float>& rgb) {
  if (width <= 0 || height <= 0 || rgb.size() != 3 * size_t(width) * size_t(height))
    throw std::invalid_argument("write_display_image: rgb does not hold width x height pixels");
  const std::string ext = lower_extension(path);
  if (ext != ".png" && ext != ".jpg" && ext != ".jpeg")
    throw InputError(fmt::format("{}: unsupported display image format '{}' (expected .png or .jpg)", path,
                                 ext.empty() ? "(none)" : ext));
  std::vector<uint16_t> codes(rgb.size());
  std::transform(rgb.begin(), rgb.end(), codes.begin(), [](float v) { return uint16_t(srgb_code(v)); });
  return encode_rgb_codes(path, width, height, 8, codes);
}

std::string encode_display_png(int width, int height, const std::vector<float>& rgb) {
  return encode_display_image(".png", width, height, rgb);
}

void write_code_image(const std::string& path, const RgbImage& image, int bit_depth) {
  const double max = bit_depth == 8 ? 255.0 : 65535.0;
  std::vector<uint16_t> codes(image.rgb.size());
  std::transform(image.rgb.begin(), image.rgb.end(), codes.begin(),
                 [&](float v) { return uint16_t(std::lround(std::clamp(double(v), 0.0, 1.0) * max)); });
  write_file_atomically(path, encode_rgb_codes(path, image.width, image.height, bit_depth, codes));
}

void write_display_image(const std::string& path, int width, int height, const std::vector<float>& rgb) {
  write_file_atomically(path, encode_display_image(path, width, height, rgb));
}

}  // namespace lp
