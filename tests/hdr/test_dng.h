// A minimal linear DNG for tests that read camera RAW files through LibRaw (bracket and
// vignetting tests), written byte by byte: no DNG writer is packaged.
#pragma once

#include <cstdint>
#include <filesystem>
#include <fstream>
#include <initializer_list>
#include <string>
#include <vector>

namespace lp {

// A minimal linear DNG (LinearRaw RGB, 16 bit, white level 65535, identity colour matrix)
// of `codes` (w x h x 3), whose Exif IFD records the exposure time 1/t_den s, the f-number
// and the ISO, and the Orientation (EXIF 1-8) in IFD0, as a camera writes them: what LibRaw
// develops back to the same codes.
inline std::string write_test_dng(const std::filesystem::path& dir, const std::string& name, int w, int h,
                                  const std::vector<uint16_t>& codes, uint32_t t_den, uint32_t f_num10, uint32_t iso,
                                  uint32_t orientation = 1) {
  struct Entry {
    uint16_t tag, type;
    uint32_t count;
    std::string data;  // little endian; inline when 4 bytes or fewer
  };
  auto le = [](std::initializer_list<uint32_t> v, int bytes) {
    std::string out;
    for (uint32_t x : v)
      for (int i = 0; i < bytes; ++i) out += char((x >> (8 * i)) & 0xff);
    return out;
  };
  const uint32_t pixels_bytes = uint32_t(codes.size() * 2);
  std::vector<Entry> ifd0 = {
      {254, 4, 1, le({0}, 4)},                         // NewSubFileType: the main image
      {256, 4, 1, le({uint32_t(w)}, 4)},
      {257, 4, 1, le({uint32_t(h)}, 4)},
      {258, 3, 3, le({16, 16, 16}, 2)},                // BitsPerSample
      {259, 3, 1, le({1}, 2)},                         // no compression
      {262, 3, 1, le({34892}, 2)},                     // LinearRaw
      {271, 2, 5, std::string("Test", 5)},             // Make
      {272, 2, 5, std::string("Test", 5)},             // Model
      {273, 4, 1, le({8}, 4)},                         // StripOffsets: the pixels right after the header
      {274, 3, 1, le({orientation}, 2)},               // Orientation (EXIF's 1-8)
      {277, 3, 1, le({3}, 2)},                         // SamplesPerPixel
      {278, 4, 1, le({uint32_t(h)}, 4)},               // RowsPerStrip
      {279, 4, 1, le({pixels_bytes}, 4)},              // StripByteCounts
      {284, 3, 1, le({1}, 2)},                         // chunky
      {34665, 4, 1, ""},                               // Exif IFD, filled in below
      {50706, 1, 4, le({1, 4, 0, 0}, 1)},              // DNGVersion 1.4
      {50708, 2, 5, std::string("Test", 5)},           // UniqueCameraModel
      {50717, 4, 1, le({65535}, 4)},                   // WhiteLevel
      {50721, 10, 9, le({1, 1, 0, 1, 0, 1, 0, 1, 1, 1, 0, 1, 0, 1, 0, 1, 1, 1}, 4)},  // ColorMatrix1 = I
      {50728, 5, 3, le({1, 1, 1, 1, 1, 1}, 4)},        // AsShotNeutral
      {50778, 3, 1, le({21}, 2)},                      // CalibrationIlluminant1 D65
  };
  const std::vector<Entry> exif = {
      {33434, 5, 1, le({1, t_den}, 4)},     // ExposureTime
      {33437, 5, 1, le({f_num10, 10}, 4)},  // FNumber
      {34855, 3, 1, le({iso}, 2)},          // ISOSpeedRatings
  };
  // Layout: header (8), pixels, IFD0, its out-of-line values, the Exif IFD, its values.
  auto ifd_size = [](const std::vector<Entry>& e) { return 2 + 12 * uint32_t(e.size()) + 4; };
  auto values_size = [](const std::vector<Entry>& e) {
    uint32_t n = 0;
    for (const Entry& x : e) n += x.data.size() > 4 ? uint32_t((x.data.size() + 1) & ~size_t(1)) : 0;
    return n;
  };
  const uint32_t ifd0_at = 8 + pixels_bytes, exif_at = ifd0_at + ifd_size(ifd0) + values_size(ifd0);
  for (Entry& e : ifd0)
    if (e.tag == 34665) e.data = le({exif_at}, 4);
  auto write_ifd = [&](std::string& out, const std::vector<Entry>& entries, uint32_t at) {
    std::string values;
    uint32_t value_at = at + ifd_size(entries);
    out += le({uint32_t(entries.size())}, 2);
    for (const Entry& e : entries) {
      out += le({e.tag, e.type}, 2) + le({e.count}, 4);
      if (e.data.size() <= 4) {
        out += e.data + std::string(4 - e.data.size(), '\0');
      } else {
        out += le({value_at + uint32_t(values.size())}, 4);
        values += e.data;
        if (values.size() % 2) values += '\0';
      }
    }
    out += le({0}, 4) + values;
  };
  std::string file = "II" + le({42}, 2) + le({ifd0_at}, 4);
  for (uint16_t c : codes) file += le({c}, 2);
  write_ifd(file, ifd0, ifd0_at);
  write_ifd(file, exif, exif_at);
  const std::string path = (dir / name).string();
  std::ofstream(path, std::ios::binary) << file;
  return path;
}

}  // namespace lp
