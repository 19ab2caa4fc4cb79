#include "core/exr_header.h"

#include <fmt/format.h>

#include <cstdint>
#include <vector>

#include "core/error.h"
#include "core/limits.h"

namespace lp {

namespace {

[[noreturn]] void fail(const std::string& path, const std::string& problem) { throw InputError(path + ": " + problem); }

int32_t le32(std::string_view b, size_t i) {
  uint32_t v = 0;
  for (int k = 3; k >= 0; --k) v = v << 8 | static_cast<uint8_t>(b[i + size_t(k)]);
  return static_cast<int32_t>(v);
}

// Scan lines per chunk of each compression (ImfCompression.h order); unknown codes get the
// largest, which gives the smallest (safe) offset table.
int lines_per_chunk(int compression) {
  static constexpr int kLines[] = {1, 1, 1, 16, 32, 16, 32, 32, 32, 256};
  return compression >= 0 && compression < 10 ? kLines[compression] : 256;
}

// What the pre-scan keeps of one part's header.
struct Part {
  bool has_window = false;
  long long width = 0, height = 0;
  int compression = 0;
  bool tiled = false;
  long long tile_x = 0, tile_y = 0;
  long long chunk_count = -1;  // multi-part files record it
};

// Chunks the part's offset table holds at least (a tiled part: its level-0 tiles).
uint64_t min_chunks(const Part& p) {
  if (p.chunk_count >= 0) return uint64_t(p.chunk_count);
  if (!p.has_window) return 0;
  if (p.tiled) {
    if (p.tile_x <= 0 || p.tile_y <= 0) return 0;  // OpenEXR refuses it itself
    return uint64_t((p.width + p.tile_x - 1) / p.tile_x) * uint64_t((p.height + p.tile_y - 1) / p.tile_y);
  }
  const int lines = lines_per_chunk(p.compression);
  return uint64_t((p.height + lines - 1) / lines);
}

// One null-terminated name of at most `max_len` bytes starting at `pos`; advances `pos`.
std::string_view read_name(const std::string& path, std::string_view b, size_t& pos, size_t max_len) {
  const size_t end = b.find('\0', pos);
  if (end == std::string_view::npos) fail(path, "truncated file (header ends inside an attribute name)");
  if (end - pos > max_len)
    fail(path, fmt::format("damaged header (a name of {} bytes at byte {}, at most {})", end - pos, pos, max_len));
  const std::string_view name = b.substr(pos, end - pos);
  pos = end + 1;
  return name;
}

// The attributes of one header up to its terminating null byte; advances `pos` past it.
Part scan_header(const std::string& path, std::string_view b, size_t& pos, size_t max_name) {
  Part part;
  for (;;) {
    if (pos >= b.size()) fail(path, "truncated file (header not terminated)");
    if (b[pos] == '\0') {
      ++pos;
      return part;
    }
    const std::string_view name = read_name(path, b, pos, max_name);
    const std::string_view type = read_name(path, b, pos, max_name);
    if (pos + 4 > b.size()) fail(path, "truncated file (header ends inside an attribute)");
    const int32_t size = le32(b, pos);
    pos += 4;
    if (size < 0 || uint64_t(size) > b.size() - pos)
      fail(path, fmt::format("truncated file (attribute '{}' claims {} bytes, but the file has {} left)", name, size,
                             b.size() - pos));
    const std::string_view value = b.substr(pos, size_t(size));
    if (name == "dataWindow" && type == "box2i" && size == 16) {
      const long long x0 = le32(value, 0), y0 = le32(value, 4), x1 = le32(value, 8), y1 = le32(value, 12);
      part.has_window = true;
      part.width = x1 - x0 + 1;
      part.height = y1 - y0 + 1;
    } else if (name == "compression" && size == 1) {
      part.compression = static_cast<uint8_t>(value[0]);
    } else if (name == "tiles" && type == "tiledesc" && size == 9) {
      part.tiled = true;
      part.tile_x = uint32_t(le32(value, 0));
      part.tile_y = uint32_t(le32(value, 4));
    } else if (name == "chunkCount" && type == "int" && size == 4) {
      part.chunk_count = le32(value, 0);
      if (part.chunk_count < 0) fail(path, fmt::format("damaged header (chunkCount {})", part.chunk_count));
    }
    pos += size_t(size);
  }
}

}  // namespace

int check_exr_header(const std::string& path, std::string_view b) {
  if (b.size() < 8) fail(path, "truncated file (no version field)");
  const int32_t version = le32(b, 4);
  const bool long_names = version & 0x400, multipart = version & 0x1000;
  size_t pos = 8;
  std::vector<Part> parts;
  do {
    if (multipart && pos < b.size() && b[pos] == '\0') {  // the empty header ends the list
      ++pos;
      break;
    }
    parts.push_back(scan_header(path, b, pos, long_names ? 255 : 31));
  } while (multipart);
  uint64_t chunks = 0;
  for (const Part& p : parts) {
    if (p.has_window) check_image_size(path, p.width, p.height, "data window");
    chunks += min_chunks(p);
  }
  // Every chunk has an 8-byte entry in the offset table that follows the headers.
  if (chunks > (b.size() - pos) / 8)
    fail(path, fmt::format("truncated file ({} bytes after the header cannot hold the offset table of {} chunks its "
                           "data window needs)",
                           b.size() - pos, chunks));
  return int(parts.size());
}

}  // namespace lp
