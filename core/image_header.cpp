#include "core/image_header.h"

#include <fmt/format.h>

#include <cctype>

#include "core/error.h"

namespace lp {

std::string_view to_string(ImageFormat format) {
  switch (format) {
    case ImageFormat::Png: return "PNG";
    case ImageFormat::Jpeg: return "JPEG";
    case ImageFormat::Tiff: return "TIFF";
    case ImageFormat::Pnm: return "PNM";
    case ImageFormat::Bmp: return "BMP";
  }
  return "?";
}

namespace {

[[noreturn]] void fail(const std::string& path, std::string_view format, const std::string& problem) {
  throw InputError(fmt::format("{}: damaged {} header ({})", path, format, problem));
}

uint8_t u8(std::string_view b, size_t i) { return static_cast<uint8_t>(b[i]); }
uint32_t be16(std::string_view b, size_t i) { return uint32_t(u8(b, i)) << 8 | u8(b, i + 1); }
uint32_t be32(std::string_view b, size_t i) { return be16(b, i) << 16 | be16(b, i + 2); }
uint32_t le16(std::string_view b, size_t i) { return uint32_t(u8(b, i + 1)) << 8 | u8(b, i); }
uint32_t le32(std::string_view b, size_t i) { return le16(b, i + 2) << 16 | le16(b, i); }

// The Orientation (tag 274, SHORT) of a TIFF structure's first IFD (a TIFF file, or the
// block after a JPEG APP1's "Exif\0\0"); 1 when absent, out of 1-8, or anything is out of
// bounds. Never throws: a damaged EXIF block does not make the pixels unreadable.
int tiff_orientation(std::string_view t) {
  if (t.size() < 8) return 1;
  const bool little = t.substr(0, 4) == std::string_view("II*\0", 4);
  if (!little && t.substr(0, 4) != std::string_view("MM\0*", 4)) return 1;
  auto r16 = [&](size_t i) { return little ? le16(t, i) : be16(t, i); };
  const size_t ifd = little ? le32(t, 4) : be32(t, 4);
  if (ifd < 8 || ifd > t.size() - 2) return 1;
  const size_t entries = r16(ifd);
  for (size_t k = 0; k < entries && ifd + 2 + 12 * (k + 1) <= t.size(); ++k) {
    const size_t e = ifd + 2 + 12 * k;
    if (r16(e) != 274) continue;
    const uint32_t v = r16(e + 2) == 3 ? r16(e + 8) : 0;  // SHORT, its value in the entry
    return v >= 1 && v <= 8 ? int(v) : 1;
  }
  return 1;
}

ImageHeader png_header(const std::string& path, std::string_view b) {
  if (b.size() < 33 || b.substr(12, 4) != "IHDR") fail(path, "PNG", "no IHDR chunk first");
  ImageHeader h{ImageFormat::Png, be32(b, 16), be32(b, 20)};
  const int depth = u8(b, 24), colour = u8(b, 25);
  // Allowed bit depths per colour type (PNG 11.2.2) and the samples per pixel.
  int channels = 0;
  bool ok = false;
  switch (colour) {
    case 0: channels = 1, ok = depth == 1 || depth == 2 || depth == 4 || depth == 8 || depth == 16; break;
    case 2: channels = 3, ok = depth == 8 || depth == 16; break;
    case 3: channels = 1, ok = depth == 1 || depth == 2 || depth == 4 || depth == 8; break;
    case 4: channels = 2, ok = depth == 8 || depth == 16; break;
    case 6: channels = 4, ok = depth == 8 || depth == 16; break;
    default: fail(path, "PNG", fmt::format("colour type {} does not exist", colour));
  }
  if (!ok) fail(path, "PNG", fmt::format("bit depth {} is not allowed for colour type {}", depth, colour));
  if (h.width == 0 || h.height == 0 || h.width > 0x7fffffff || h.height > 0x7fffffff)
    fail(path, "PNG", fmt::format("size {}x{}", h.width, h.height));
  const double pixel_bytes = double(h.width) * double(h.height) * channels * depth / 8;
  h.min_file_bytes = uint64_t(pixel_bytes / 1032);
  // An eXIf chunk before the image data (PNG 1.5's place for EXIF; browsers honour its
  // Orientation): its TIFF structure's orientation.
  for (size_t i = 8; i + 8 <= b.size();) {
    const size_t length = be32(b, i);
    const std::string_view type = b.substr(i + 4, 4);
    if (type == "IDAT" || type == "IEND" || length > b.size() - i - 8) break;
    if (type == "eXIf") {
      h.orientation = tiff_orientation(b.substr(i + 8, length));
      break;
    }
    i += 12 + length;
  }
  return h;
}

// Markers, segment lengths and the first frame header (SOF0-SOF15 but DHT, JPG, DAC); the
// orientation from the first APP1 "Exif" segment before it (where EXIF requires it).
ImageHeader jpeg_header(const std::string& path, std::string_view b) {
  size_t i = 2;
  int orientation = 0;  // 0: no Exif segment seen yet
  while (i + 3 < b.size()) {
    if (u8(b, i) != 0xFF) fail(path, "JPEG", fmt::format("no marker at byte {}", i));
    const uint8_t m = u8(b, i + 1);
    if (m == 0xFF) {  // fill byte
      ++i;
      continue;
    }
    if (m == 0x01 || (m >= 0xD0 && m <= 0xD7)) {  // TEM, restarts: no length
      i += 2;
      continue;
    }
    if (m == 0xDA || m == 0xD9) break;  // a scan or the end before any frame header
    const size_t length = be16(b, i + 2);
    if (length < 2) fail(path, "JPEG", fmt::format("segment length {} at byte {}", length, i));
    const bool frame = m >= 0xC0 && m <= 0xCF && m != 0xC4 && m != 0xC8 && m != 0xCC;
    if (m == 0xE1 && orientation == 0 && length >= 8 && b.substr(i + 4, 6) == std::string_view("Exif\0\0", 6))
      orientation = tiff_orientation(b.substr(i + 10, length - 8));  // substr stops at the file's end
    if (frame) {
      if (length < 8 || i + 8 >= b.size()) fail(path, "JPEG", "frame header cut short");
      ImageHeader h{ImageFormat::Jpeg, be16(b, i + 7), be16(b, i + 5)};
      if (h.height == 0) fail(path, "JPEG", "height 0: a DNL-defined height is not supported");
      // Huffman-coded frames (SOF0-SOF3): at least one bit per full-resolution block.
      if (m <= 0xC3) h.min_file_bytes = uint64_t((h.width + 7) / 8) * uint64_t((h.height + 7) / 8) / 8;
      h.orientation = orientation == 0 ? 1 : orientation;
      return h;
    }
    i += 2 + length;
  }
  fail(path, "JPEG", "no frame header (SOF) before the image data");
}

ImageHeader tiff_header(const std::string& path, std::string_view b) {
  const bool little = b[0] == 'I';
  auto r16 = [&](size_t i) { return little ? le16(b, i) : be16(b, i); };
  auto r32 = [&](size_t i) { return little ? le32(b, i) : be32(b, i); };
  const size_t ifd = r32(4);
  if (ifd < 8 || ifd + 2 > b.size()) fail(path, "TIFF", fmt::format("first IFD at byte {} is outside the file", ifd));
  const size_t entries = r16(ifd);
  if (ifd + 2 + 12 * entries > b.size()) fail(path, "TIFF", "first IFD runs past the end of the file");
  long long width = -1, height = -1;
  for (size_t k = 0; k < entries; ++k) {
    const size_t e = ifd + 2 + 12 * k;
    const uint32_t tag = r16(e), type = r16(e + 2);
    if (tag != 256 && tag != 257) continue;
    const long long v = type == 3 ? r16(e + 8) : type == 4 ? r32(e + 8) : -1;  // SHORT or LONG
    if (v < 0) fail(path, "TIFF", fmt::format("tag {} has type {} (expected SHORT or LONG)", tag, type));
    (tag == 256 ? width : height) = v;
  }
  if (width < 0 || height < 0) fail(path, "TIFF", "no ImageWidth or ImageLength in the first IFD");
  ImageHeader h{ImageFormat::Tiff, width, height};
  h.orientation = tiff_orientation(b);
  for (size_t k = 0; k < entries; ++k) {
    const size_t e = ifd + 2 + 12 * k;
    const uint32_t tag = r16(e);
    if (r16(e + 2) != 3) continue;  // SHORTs
    if (tag == 259 && (r16(e + 8) == 34676 || r16(e + 8) == 34677)) h.float_samples = true;  // LogLuv
    if (tag == 339) {  // SampleFormat: its first value, inline or at an offset past two SHORTs
      const size_t count = r32(e + 4), at = count <= 2 ? e + 8 : r32(e + 8);
      if (at + 2 <= b.size() && r16(at) == 3) h.float_samples = true;
    }
  }
  return h;
}

// P1-P6: magic, width, height (and maxval but for P1/P4), separated by white space and
// '#' comments.
ImageHeader pnm_header(const std::string& path, std::string_view b) {
  const char kind = b[1];
  size_t i = 2;
  auto number = [&](const char* what) -> long long {
    for (;;) {
      while (i < b.size() && std::isspace(static_cast<unsigned char>(b[i]))) ++i;
      if (i < b.size() && b[i] == '#') {
        while (i < b.size() && b[i] != '\n') ++i;
        continue;
      }
      break;
    }
    long long v = 0;
    const size_t start = i;
    for (; i < b.size() && std::isdigit(static_cast<unsigned char>(b[i])); ++i)
      if (i - start < 10) v = 10 * v + (b[i] - '0');
    if (i == start) fail(path, "PNM", fmt::format("no {}", what));
    if (i - start > 9) fail(path, "PNM", fmt::format("{} of more than 9 digits", what));
    return v;
  };
  ImageHeader h{ImageFormat::Pnm};
  h.width = number("width");
  h.height = number("height");
  const bool bitmap = kind == '1' || kind == '4';
  const long long maxval = bitmap ? 1 : number("maximum value");
  if (maxval < 1 || maxval > 65535) fail(path, "PNM", fmt::format("maximum value {}", maxval));
  const uint64_t samples = uint64_t(h.width) * uint64_t(h.height) * (kind == '3' || kind == '6' ? 3 : 1);
  if (kind == '4')
    h.min_file_bytes = uint64_t((h.width + 7) / 8) * uint64_t(h.height);
  else  // binary: every sample in 1 or 2 bytes; ASCII: at least a digit each
    h.min_file_bytes = samples * (kind >= '5' && maxval > 255 ? 2 : 1);
  return h;
}

ImageHeader bmp_header(const std::string& path, std::string_view b) {
  if (b.size() < 26) fail(path, "BMP", "file header cut short");
  const uint32_t dib = le32(b, 14);
  if (dib == 12) return ImageHeader{ImageFormat::Bmp, le16(b, 18), le16(b, 20)};  // OS/2 core header
  if (dib < 40 || b.size() < 30) fail(path, "BMP", fmt::format("info header of {} bytes", dib));
  const auto height = static_cast<int32_t>(le32(b, 22));  // negative: rows top to bottom
  return ImageHeader{ImageFormat::Bmp, static_cast<int32_t>(le32(b, 18)), height < 0 ? -(long long)height : height};
}

}  // namespace

std::optional<ImageHeader> read_image_header(const std::string& path, std::string_view b) {
  if (b.size() >= 8 && b.substr(0, 8) == std::string_view("\x89PNG\r\n\x1a\n", 8)) return png_header(path, b);
  if (b.size() >= 4 && u8(b, 0) == 0xFF && u8(b, 1) == 0xD8 && u8(b, 2) == 0xFF) return jpeg_header(path, b);
  if (b.size() >= 8 && (b.substr(0, 4) == std::string_view("II*\0", 4) || b.substr(0, 4) == std::string_view("MM\0*", 4)))
    return tiff_header(path, b);
  if (b.size() >= 3 && b[0] == 'P' && b[1] >= '1' && b[1] <= '6' && std::isspace(static_cast<unsigned char>(b[2])))
    return pnm_header(path, b);
  if (b.size() >= 2 && b.substr(0, 2) == "BM") return bmp_header(path, b);
  return std::nullopt;
}

}  // namespace lp
