#include "core/picture_io.h"

#include <fmt/format.h>

#include <png.h>

#include <algorithm>
#include <cmath>
#include <csetjmp>
#include <cstring>
#include <opencv2/core.hpp>
#include <opencv2/imgcodecs.hpp>  // the IMWRITE_ numbers; the codecs are in core/lazy_libs.h
#include <stdexcept>

#include "core/error.h"
#include "core/file_io.h"
#include "core/image_io.h"
#include "core/lazy_libs.h"
#include "core/tonemap.h"

namespace lp {
namespace {

// PNG with libpng, in memory. A PNG written through OpenCV loaded the codecs plugin and its
// 265 libraries (~0.35 s: `sample --overlay` took 0.37 s for a 50 ms job). libpng reports
// errors by longjmp, so nothing here owns a destructor across png_ calls: the output goes to
// a buffer sized beforehand for zlib's worst case, and the callback refuses to grow it.
struct PngSink {
  uint8_t* data;
  size_t capacity, size;
};

void png_sink_write(png_structp png, png_bytep bytes, png_size_t n) {
  auto* sink = static_cast<PngSink*>(png_get_io_ptr(png));
  if (n > sink->capacity - sink->size) png_error(png, "output buffer too small");
  std::memcpy(sink->data + sink->size, bytes, n);
  sink->size += n;
}

void png_sink_flush(png_structp) {}

// Returns the encoded size, 0 on failure. `rows` are big-endian for 16-bit (PNG's order);
// `texts` (n of them) are written as tEXt chunks before the pixels.
size_t write_png_rows(PngSink* sink, int width, int height, int bit_depth, bool alpha, png_bytep* rows, png_text* texts,
                      int n) {
  png_structp png = png_create_write_struct(PNG_LIBPNG_VER_STRING, nullptr, nullptr, nullptr);
  if (!png) return 0;
  png_infop info = png_create_info_struct(png);
  if (!info || setjmp(png_jmpbuf(png))) {
    png_destroy_write_struct(&png, info ? &info : nullptr);
    return 0;
  }
  png_set_write_fn(png, sink, png_sink_write, png_sink_flush);
  png_set_compression_level(png, 1);  // fast, as OpenCV's default
  png_set_IHDR(png, info, png_uint_32(width), png_uint_32(height), bit_depth,
               alpha ? PNG_COLOR_TYPE_RGB_ALPHA : PNG_COLOR_TYPE_RGB, PNG_INTERLACE_NONE,
               PNG_COMPRESSION_TYPE_DEFAULT, PNG_FILTER_TYPE_DEFAULT);
  if (n > 0) png_set_text(png, info, texts, n);
  png_set_rows(png, info, rows);
  png_write_png(png, info, PNG_TRANSFORM_IDENTITY, nullptr);
  png_destroy_write_struct(&png, &info);
  return sink->size;
}

// `valid` (empty, or one 0/1 per pixel): an alpha channel, 0 where a pixel holds no data
// (core/image_io.h reads alpha below half as unseen).
std::string encode_png(const std::string& path, int width, int height, int bit_depth, const std::vector<uint16_t>& rgb,
                       const std::vector<std::pair<std::string, std::string>>& png_texts,
                       const std::vector<uint8_t>& valid = {}) {
  const bool alpha = !valid.empty();
  const size_t channels = alpha ? 4 : 3, bytes = size_t(bit_depth / 8);
  const size_t row_bytes = channels * size_t(width) * bytes;
  std::vector<uint8_t> pixels(row_bytes * size_t(height));
  const uint16_t opaque = bit_depth == 8 ? 0xff : 0xffff;
  const auto put = [&](size_t at, uint16_t v) {  // PNG's order: big-endian for 16-bit
    if (bytes == 1) pixels[at] = uint8_t(v);
    else pixels[2 * at] = uint8_t(v >> 8), pixels[2 * at + 1] = uint8_t(v & 0xff);
  };
  for (size_t p = 0; p < rgb.size() / 3; ++p) {
    for (size_t c = 0; c < 3; ++c) put(channels * p + c, rgb[3 * p + c]);
    if (alpha) put(channels * p + 3, valid[p] ? opaque : 0);
  }
  std::vector<png_bytep> rows(static_cast<size_t>(height));
  for (int y = 0; y < height; ++y) rows[size_t(y)] = pixels.data() + size_t(y) * row_bytes;
  // zlib's bound for stored blocks (5 bytes a 16 KB block) over the filtered rows, the chunks
  // every 8 KB (12 bytes each) and the headers.
  const size_t raw = (row_bytes + 1) * size_t(height);
  size_t text_bytes = 0;  // a tEXt chunk: keyword, NUL, text, and 12 bytes of length, type and CRC
  for (const auto& [key, text] : png_texts) text_bytes += key.size() + 1 + text.size() + 12;
  std::vector<uint8_t> out(raw + raw / 1000 + 5 * (raw / 16384 + 1) + 12 * (raw / 8192 + 1) + 4096 + text_bytes);
  // libpng takes mutable C strings, and nothing with a destructor may cross its longjmp:
  // copies made here, before the write.
  std::vector<std::vector<char>> strings;
  for (const auto& [key, text] : png_texts) {
    if (key.empty() || key.size() > 79) throw std::invalid_argument("encode_png: a tEXt keyword is 1-79 bytes");
    for (const std::string* s : {&key, &text}) strings.emplace_back(s->begin(), s->end()), strings.back().push_back('\0');
  }
  std::vector<png_text> texts(png_texts.size());
  for (size_t i = 0; i < texts.size(); ++i) {
    texts[i].compression = PNG_TEXT_COMPRESSION_NONE;
    texts[i].key = strings[2 * i].data();
    texts[i].text = strings[2 * i + 1].data();
    texts[i].text_length = strings[2 * i + 1].size() - 1;
  }
  PngSink sink{out.data(), out.size(), 0};
  const size_t n = write_png_rows(&sink, width, height, bit_depth, alpha, rows.data(), texts.data(), int(texts.size()));
  if (n == 0) throw InputError(fmt::format("{}: cannot encode as PNG", path));
  return std::string(reinterpret_cast<const char*>(out.data()), n);
}

}  // namespace

std::string encode_rgb_codes(const std::string& path, int width, int height, int bit_depth,
                             const std::vector<uint16_t>& rgb,
                             const std::vector<std::pair<std::string, std::string>>& png_texts) {
  if (bit_depth != 8 && bit_depth != 16) throw InputError(fmt::format("{}: bit depth must be 8 or 16", path));
  if (width <= 0 || height <= 0 || rgb.size() != 3 * size_t(width) * size_t(height))
    throw InputError(fmt::format("{}: image buffer does not match its size", path));
  std::string ext = lower_extension(path);
  if (ext.empty()) ext = ".png";
  if (ext == ".png") return encode_png(path, width, height, bit_depth, rgb, png_texts);
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
  std::vector<std::pair<std::string, std::string>> texts;
  if (image.mirror_ball) texts.emplace_back(kMirrorBallKey, mirror_ball_text(*image.mirror_ball));
  // Pixels without data (a registered photo beyond the original's edge) are transparent in a
  // PNG, which read_camera_image reads as unseen; other formats would make them black.
  const bool unseen = std::find(image.valid.begin(), image.valid.end(), uint8_t(0)) != image.valid.end();
  if (unseen) {
    // encode_rgb_codes' checks, for the PNG written here without it.
    if (bit_depth != 8 && bit_depth != 16) throw InputError(fmt::format("{}: bit depth must be 8 or 16", path));
    if (image.width <= 0 || image.height <= 0 || codes.size() != 3 * size_t(image.width) * size_t(image.height) ||
        image.valid.size() != size_t(image.width) * size_t(image.height))
      throw InputError(fmt::format("{}: image buffer does not match its size", path));
    std::string ext = lower_extension(path);
    if (!ext.empty() && ext != ".png")
      throw InputError(fmt::format("{}: {} holds pixels without data, which only a PNG (its alpha) can mark; write .png",
                                   path, ext));
    write_file_atomically(path, encode_png(path, image.width, image.height, bit_depth, codes, texts, image.valid));
    return;
  }
  write_file_atomically(path, encode_rgb_codes(path, image.width, image.height, bit_depth, codes, texts));
}

void write_display_image(const std::string& path, int width, int height, const std::vector<float>& rgb) {
  write_file_atomically(path, encode_display_image(path, width, height, rgb));
}

}  // namespace lp
