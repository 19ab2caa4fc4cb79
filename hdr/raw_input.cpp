#include "hdr/raw_input.h"

#include <algorithm>
#include <cstring>
#include <memory>
#include <string>

#include <opencv2/core.hpp>
#include <opencv2/imgproc.hpp>

#include "core/error.h"
#include "core/limits.h"
#include "hdr/camera_files_plugin.h"

namespace lp {
namespace {

void check_buffer(const char* what, const std::vector<uint16_t>& data, int width, int height, int bit_depth) {
  const std::string w = what;
  if (bit_depth < 8 || bit_depth > 16)
    throw InputError(w + ": bit depth " + std::to_string(bit_depth) + " is not in [8, 16]");
  if (width <= 0 || height <= 0)
    throw InputError(w + ": size " + std::to_string(width) + "x" + std::to_string(height) + " is empty");
  if (data.size() != size_t(width) * size_t(height))
    throw InputError(w + ": " + std::to_string(data.size()) + " samples for " + std::to_string(width) + "x" +
                     std::to_string(height) + " pixels");
  const uint32_t max_code = (1u << bit_depth) - 1;
  const auto it = std::find_if(data.begin(), data.end(), [&](uint16_t v) { return v > max_code; });
  if (it != data.end()) {
    const size_t i = size_t(it - data.begin());
    throw InputError(w + ": sample " + std::to_string(*it) + " at (" + std::to_string(i % size_t(width)) + ", " +
                     std::to_string(i / size_t(width)) + ") exceeds the " + std::to_string(bit_depth) +
                     "-bit maximum " + std::to_string(max_code));
  }
}

int opencv_code(BayerPattern p) {
  // OpenCV names the pattern by the second row's second and third pixels.
  switch (p) {
    case BayerPattern::RGGB: return cv::COLOR_BayerBG2BGR_EA;
    case BayerPattern::BGGR: return cv::COLOR_BayerRG2BGR_EA;
    case BayerPattern::GRBG: return cv::COLOR_BayerGB2BGR_EA;
    case BayerPattern::GBRG: return cv::COLOR_BayerGR2BGR_EA;
  }
  return cv::COLOR_BayerBG2BGR_EA;
}

}  // namespace

RgbImage demosaic_bayer(const std::vector<uint16_t>& data, int width, int height, int bit_depth,
                        BayerPattern pattern) {
  check_buffer("bayer frame", data, width, height, bit_depth);
  if (width % 2 || height % 2 || width < 2 || height < 2)
    throw InputError("bayer frame: size " + std::to_string(width) + "x" + std::to_string(height) +
                     " is not a whole number of 2x2 cells");
  const cv::Mat mosaic(height, width, CV_16UC1, const_cast<uint16_t*>(data.data()));
  cv::Mat bgr;
  cv::demosaicing(mosaic, bgr, opencv_code(pattern));
  RgbImage out;
  out.width = width;
  out.height = height;
  out.rgb.resize(size_t(width) * height * 3);
  const float scale = 1.0f / float((1u << bit_depth) - 1);
  for (int y = 0; y < height; ++y) {
    const auto* row = bgr.ptr<cv::Vec3w>(y);
    float* dst = &out.rgb[size_t(y) * width * 3];
    for (int x = 0; x < width; ++x) {
      dst[3 * x + 0] = std::min(1.0f, row[x][2] * scale);
      dst[3 * x + 1] = std::min(1.0f, row[x][1] * scale);
      dst[3 * x + 2] = std::min(1.0f, row[x][0] * scale);
    }
  }
  return out;
}

RgbImage mono_to_rgb(const std::vector<uint16_t>& data, int width, int height, int bit_depth) {
  check_buffer("mono frame", data, width, height, bit_depth);
  RgbImage out;
  out.width = width;
  out.height = height;
  out.rgb.resize(data.size() * 3);
  const float scale = 1.0f / float((1u << bit_depth) - 1);
  for (size_t i = 0; i < data.size(); ++i) std::fill_n(&out.rgb[3 * i], 3, data[i] * scale);
  return out;
}

bool is_camera_raw_file(const std::string& path) {
  const size_t dot = path.find_last_of('.');
  std::string e = dot == std::string::npos ? std::string() : path.substr(dot);
  std::transform(e.begin(), e.end(), e.begin(), [](unsigned char c) { return char(std::tolower(c)); });
  for (const char* r : {".cr2", ".cr3", ".nef", ".arw", ".dng", ".raf", ".orf", ".rw2", ".pef", ".srw"})
    if (e == r) return true;
  return false;
}

RgbImage read_camera_raw(const std::string& path, RawExposure* exposure_out) {
  // LibRaw is loaded by the first RAW file (hdr/camera_files_plugin.h).
  const detail::DevelopedRaw img = detail::camera_files_plugin().develop_raw(path, [](int width, int height) {
    try {
      check_image_size("", width, height);
      return true;
    } catch (const InputError&) {
      return false;
    }
  });
  if (img.status == detail::DevelopedRaw::Status::SensorTooLarge) {
    check_image_size(path, img.sensor_width, img.sensor_height, "sensor");  // throws the limit's own message
    throw InputError(path + ": sensor too large");
  }
  if (img.status != detail::DevelopedRaw::Status::Ok) throw InputError(path + ": " + img.message);

  RgbImage out;
  out.width = img.width;
  out.height = img.height;
  const size_t n = size_t(out.width) * out.height;
  out.rgb.resize(n * 3);
  const int colors = img.colors;
  for (size_t i = 0; i < n; ++i)
    for (int c = 0; c < 3; ++c) out.rgb[3 * i + c] = img.samples[i * colors + (colors == 3 ? c : 0)] / 65535.0f;
  out.orientation = img.orientation;
  if (exposure_out) *exposure_out = {img.shutter_seconds, img.iso, img.f_number, img.orientation};
  return out;
}

}  // namespace lp
