#include "core/image_io.h"

#include <png.h>
// libjpeg needs FILE and size_t declared first
#include <cstdio>
#include <jpeglib.h>

#include <ImfChannelList.h>
#include <ImfCompression.h>
#include <ImfFrameBuffer.h>
#include <ImfHeader.h>
#include <ImfIO.h>
#include <ImfInputFile.h>
#include <ImfIntAttribute.h>
#include <ImfOutputFile.h>
#include <ImfRgbaFile.h>
#include <ImfStandardAttributes.h>
#include <ImfStdIO.h>
#include <ImfStringAttribute.h>
#include <ImfThreading.h>
#include <ImfVersion.h>
#include <half.h>
#include <fcntl.h>
#include <fmt/format.h>
#include <unistd.h>

#include <Iex.h>
#include <algorithm>
#include <csetjmp>
#include <bit>
#include <filesystem>
#include <optional>
#include <cerrno>
#include <cmath>
#include <cstring>
#include <fstream>
#include <limits>
#include <opencv2/core.hpp>
#include <mutex>
#include <random>
#include <thread>
#include <sstream>

#include "core/chromaticities.h"
#include "core/error.h"
#include "core/openexr_cube.h"
#include "core/file_io.h"
#include "core/exr_header.h"
#include "core/image_header.h"
#include "core/limits.h"
#include "core/interrupt.h"
#include "core/lazy_libs.h"
#include "core/warnings.h"

namespace lp {

namespace {

// The EXR attribute of EnvMap::world_from_probe, a string of 9 numbers, row-major as Mat3
// and as the .hdr header line. Not OpenEXR's m33d: three.js' EXRLoader warns on every map
// with a type it does not know (the live /probe.exr), and it knows strings.
constexpr const char* kExrRotationKey = "lightprobe.world_from_probe";

[[noreturn]] void fail(const std::string& path, const std::string& problem) {
  throw InputError(path + ": " + problem);
}

std::string rotation_text(const Mat3& r) {
  std::string out;
  for (size_t k = 0; k < 9; ++k) out += fmt::format("{}{:.17g}", k ? " " : "", r.m[k]);
  return out;
}

// Keeps a foreign message to one printable line.
std::string one_line(std::string_view text, size_t max_len = 200) {
  std::string out;
  for (char c : text) {
    if (out.size() >= max_len) {
      out += "...";
      break;
    }
    const unsigned char u = static_cast<unsigned char>(c);
    out += (u < 0x20 || u == 0x7f) ? ' ' : c;
  }
  while (!out.empty() && out.back() == ' ') out.pop_back();
  return out;
}

// 9 finite numbers and nothing else (rotation_text's format); whether they are a rotation
// is finish_map's question.
Mat3 parse_rotation_text(const std::string& path, const std::string& key, const std::string& text) {
  std::istringstream in(text);
  Mat3 r;
  std::string extra;
  for (double& x : r.m)
    if (!(in >> x) || !std::isfinite(x)) fail(path, fmt::format("bad {} value '{}' (expected 9 numbers)", key, one_line(text, 60)));
  if (in >> extra) fail(path, fmt::format("bad {} value '{}' (expected 9 numbers)", key, one_line(text, 60)));
  return r;
}

// A recorded mirror ball's "cx cy r" (EnvMap::mirror_ball): three finite numbers, a positive
// radius, a disc that overlaps the width x height image. Else the file is refused, naming
// `key`: probe unwrap would take the ball as given.
std::array<double, 3> parse_mirror_ball_text(const std::string& path, const std::string& key, const std::string& text,
                                             int width, int height) {
  const auto bad = [&](const std::string& why) {
    fail(path, fmt::format("bad {} value '{}' ({})", key, one_line(text, 60), why));
  };
  std::istringstream in(text);
  std::array<double, 3> b{};
  std::string extra;
  for (double& x : b)
    if (!(in >> x) || !std::isfinite(x)) bad("expected 3 numbers: cx cy r");
  if (in >> extra) bad("expected 3 numbers: cx cy r");
  if (!(b[2] > 0)) bad("the radius must be positive");
  if (!(b[0] + b[2] > 0 && b[0] - b[2] < width && b[1] + b[2] > 0 && b[1] - b[2] < height))
    bad(fmt::format("the ball lies outside the {}x{} image", width, height));
  return b;
}

// The ball of an image turned as EXIF `orientation` shows it (stored_width x stored_height
// as stored); pixel centres at .5 here, at integers in shown_from_stored.
std::array<double, 3> mirror_ball_as_shown(const std::array<double, 3>& b, int orientation, int stored_width,
                                           int stored_height) {
  const auto p = shown_from_stored(orientation, stored_width, stored_height, {b[0] - 0.5, b[1] - 0.5});
  return {p[0] + 0.5, p[1] + 0.5, b[2]};
}

// A JPEG that stops before its End Of Image marker: libjpeg decodes what is there, fills the
// rest with grey and only warns, so OpenCV returns a plausible image. Walk the marker
// segments and the entropy-coded scans (where 0xFF is followed by 0x00, a restart marker or
// fill bytes) until EOI; data appended after EOI (some cameras add some) is ignored.
bool jpeg_is_truncated(const std::string& b) {
  const size_t n = b.size();
  auto u8 = [&](size_t i) { return static_cast<unsigned char>(b[i]); };
  if (n < 4 || u8(0) != 0xFF || u8(1) != 0xD8) return false;  // not a JPEG
  size_t i = 2;
  bool in_scan = false;
  while (i + 1 < n) {
    if (u8(i) != 0xFF) {
      if (!in_scan) return false;  // not a marker where one must be: let the decoder judge
      ++i;
      continue;
    }
    const unsigned char m = u8(i + 1);
    if (m == 0xFF) {  // fill byte
      ++i;
      continue;
    }
    if (m == 0x00 || (m >= 0xD0 && m <= 0xD7) || m == 0x01) {  // stuffed byte, restart, TEM
      i += 2;
      continue;
    }
    if (m == 0xD9) return false;  // End Of Image
    if (i + 3 >= n) return true;
    const size_t length = size_t(u8(i + 2)) << 8 | u8(i + 3);
    if (length < 2) return false;
    i += 2 + length;
    in_scan = m == 0xDA;  // entropy-coded data follows a Start Of Scan header
  }
  return true;
}

// Every image reader reads the whole file first: its size is checked before it is read.
std::string read_whole_file(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  if (!in) fail(path, fmt::format("cannot open: {}", std::strerror(errno ? errno : ENOENT)));
  std::error_code ec;
  const auto size = std::filesystem::file_size(path, ec);  // fails on pipes: they are read as they come
  if (!ec) check_file_size(path, size, max_image_file_bytes(), "an image (32 bytes per pixel of --max-pixels)");
  std::ostringstream ss;
  ss << in.rdbuf();
  if (in.bad()) fail(path, "cannot read: I/O error");
  return std::move(ss).str();
}

bool is_power_of_two(int n) { return n > 0 && (n & (n - 1)) == 0; }

// ---------------------------------------------------------------------------------------
// A decoded file before layout handling: top-to-bottom rows, 3 floats per pixel.
struct RawImage {
  int width = 0, height = 0;
  std::vector<float> rgb;
  std::vector<uint8_t> valid;         // empty: no mask in the file
  std::optional<std::string> layout;  // as recorded in the file
  std::optional<std::string> units;
  std::optional<int> nside;
  std::optional<Mat3> world_from_probe;
  bool vignetting_corrected = false;
  int exif_orientation = 1;
  std::optional<std::string> mirror_ball;  // its text, checked against the size in finish_map
  std::string mirror_ball_key;
  std::string layout_key = "layout";  // how the file names the field, for messages
  bool openexr_cube = false;          // an EXR whose standard envmap attribute says cube
  // Said once the file is accepted (finish_map), so that a file refused after all says one line.
  std::vector<std::string> warnings;
};

// The nside of an image that can hold a healpix map: nside wide and 12 nside tall, or one
// row or column of 12 nside^2 pixels; 0 for any other shape.
int healpix_nside_of_shape(int w, int h) {
  if (h == 12 * w && is_power_of_two(w) && w <= 8192) return w;
  const int64_t n = int64_t(w) * h;
  if ((w == 1 || h == 1) && n % 12 == 0) {
    const auto nside = int64_t(std::llround(std::sqrt(double(n / 12))));
    if (12 * nside * nside == n && is_power_of_two(int(nside)) && nside <= 8192) return int(nside);
  }
  return 0;
}

// The layout a file without a recorded one is read as, from its shape alone.
std::optional<Layout> layout_from_shape(int w, int h) {
  if (w == 2 * h) return Layout::LatLong;
  if (healpix_nside_of_shape(w, h) > 0) return Layout::Healpix;
  if (w == 4 * h) return Layout::Hemisphere;  // the shape of the default hemisphere map, 360x90
  return std::nullopt;
}

Layout resolve_layout(const std::string& path, const RawImage& raw, const ReadMapOptions& options) {
  const int w = raw.width, h = raw.height;
  Layout layout;
  if (options.layout) {
    layout = *options.layout;
  } else if (raw.layout) {
    const auto parsed = layout_from_string(*raw.layout);
    if (!parsed)
      fail(path, fmt::format("unknown {} '{}' (expected latlong, hemisphere or healpix)", raw.layout_key,
                             one_line(*raw.layout, 40)));
    layout = *parsed;
  } else if (const std::optional<Layout> by_shape = layout_from_shape(w, h)) {
    layout = *by_shape;
  } else {
    // A photo or a fused bracket is not a map: sampling it as a hemisphere would be silently wrong.
    // A square one is most likely a probe photo: a mirror ball, or an angular map (Debevec's
    // light probe format, the equidistant 360-degree fisheye).
    fail(path, fmt::format("no layout recorded and {}x{} is not the shape of one (latlong 2:1, hemisphere 4:1, "
                           "healpix 1:12); give the layout with --layout{}",
                           w, h,
                           w == h ? ", or unwrap the probe first: `lightprobe probe unwrap` with --type mirrorball for a "
                                    "mirror ball, --type fisheye --fov 360 for an angular map"
                                  : ""));
  }
  switch (layout) {
    case Layout::LatLong:
      if (w != 2 * h) fail(path, fmt::format("layout latlong needs width = 2 x height, but the image is {}x{}", w, h));
      break;
    case Layout::Healpix:
      if (healpix_nside_of_shape(w, h) == 0)
        fail(path, fmt::format("layout healpix needs an image nside wide and 12 nside tall, or 12 nside^2 pixels in "
                               "one row or column (nside a power of two), but the image is {}x{}",
                               w, h));
      if (raw.nside && *raw.nside != healpix_nside_of_shape(w, h))
        fail(path, fmt::format("healpix nside {} recorded in the file does not match the {}x{} image", *raw.nside, w, h));
      break;
    case Layout::Hemisphere: break;
  }
  return layout;
}

// Slight negative values are read as 0 with a warning: out-of-gamut colours of a wide-gamut
// capture converted to Rec. 709, a raw converter's noise below black, a lossless copy of a
// lossy codec's ringing (Blender's DWA studio lights rewritten as ZIP). Refusing them refused
// real probes whole. More negative power than kSlightNegativeShare of a channel's positive
// power is not radiance (a difference of images, a signed texture) and is refused, and so is
// every negative value where no warning sink can tell anyone (core/warnings.h).
constexpr double kSlightNegativeShare = 0.01;

void accept_slight_negatives(const std::string& path, EnvMap& map, const std::string& bad) {
  const NegativeValues negative = find_negative_values(map);
  if (negative.count == 0 || !has_warning_sink()) throw InputError(bad);
  if (!(negative.share <= kSlightNegativeShare))
    fail(path, fmt::format("{} pixels with negative values (lowest {:.3g}) hold {:.3g} % of a channel's power: not "
                           "radiance",
                           negative.count, negative.lowest, 100 * negative.share));
  clamp_negative_values(map);
  if (const std::string still = find_bad_pixel(map, path); !still.empty()) throw InputError(still);
  warn(fmt::format("{}: {} pixels with negative values (lowest {:.3g}, {:.2g} % of a channel's power) read as 0", path,
                   negative.count, negative.lowest, 100 * negative.share));
}

// An OpenEXR cube map (envmap = cube: exrenvmap's, Nuke's, `lightprobe prefilter`'s level 0)
// is read as the latlong map it holds (core/openexr_cube.h), in place of its pixels. The
// attribute says how the pixels are laid out and wins over a lightprobe.layout beside it
// (exrenvmap copies the attributes of the latlong map it turned into a cube).
void read_openexr_cube_as_latlong(const std::string& path, RawImage& raw) {
  const int n = raw.width;
  if (int64_t(raw.height) != 6 * int64_t(n))
    fail(path, fmt::format("its envmap attribute says cube map, which is N x 6N (faces +X -X +Y -Y +Z -Z stacked), "
                           "but the image is {}x{}",
                           raw.width, raw.height));
  if (std::find(raw.valid.begin(), raw.valid.end(), 0) != raw.valid.end())
    fail(path, "cube map with invalid pixels (alpha): a cube covers the whole sphere, a mask in it is not supported");
  for (size_t i = 0; i < raw.rgb.size(); ++i)
    if (!std::isfinite(raw.rgb[i]))
      fail(path, fmt::format("pixel ({}, {}) of the cube image is {}", i / 3 % size_t(n), i / 3 / size_t(n),
                             std::isnan(raw.rgb[i]) ? "NaN" : "infinite"));
  check_image_size(path, 4LL * n, 2LL * n);
  EnvMap latlong = openexr_cube_to_latlong(raw.rgb, n);
  raw.width = latlong.width;
  raw.height = latlong.height;
  raw.rgb = std::move(latlong.rgb);
  raw.valid.clear();
  raw.layout = std::string(to_string(Layout::LatLong));
  raw.nside.reset();
}

EnvMap finish_map(const std::string& path, RawImage&& raw, const ReadMapOptions& options) {
  if (raw.openexr_cube && !options.layout) read_openexr_cube_as_latlong(path, raw);
  const Layout layout = resolve_layout(path, raw, options);
  EnvMap map;
  map.layout = layout;
  if (raw.units) {
    const auto units = units_from_string(*raw.units);
    if (!units) fail(path, fmt::format("unknown units '{}' (expected relative or radiance)", one_line(*raw.units, 40)));
    map.units = *units;
  }
  if (raw.world_from_probe) {
    if (!is_rotation(*raw.world_from_probe))
      fail(path, "the recorded probe rotation (world_from_probe) is not a rotation matrix");
    map.world_from_probe = raw.world_from_probe;
  }
  map.vignetting_corrected = raw.vignetting_corrected;
  map.exif_orientation = raw.exif_orientation;
  if (raw.mirror_ball)
    map.mirror_ball = parse_mirror_ball_text(path, raw.mirror_ball_key, *raw.mirror_ball, raw.width, raw.height);
  if (layout == Layout::Healpix) {
    // The file's pixels, row by row from the top, are the NESTED pixels in order.
    const int nside = healpix_nside_of_shape(raw.width, raw.height);
    map.nside = nside;
    map.width = 12 * nside * nside;
    map.height = 1;
    map.rgb = std::move(raw.rgb);
    map.valid = std::move(raw.valid);
  } else {
    map.width = raw.width;
    map.height = raw.height;
    map.rgb = std::move(raw.rgb);
    map.valid = std::move(raw.valid);
  }
  if (options.reject_bad_pixels) {
    const std::string bad = find_bad_pixel(map, path);
    if (!bad.empty()) accept_slight_negatives(path, map, bad);
  }
  for (const std::string& line : raw.warnings) warn(line);
  return map;
}

// The map as a file image: top-to-bottom rows (healpix: nside wide, 12 nside tall).
struct FileImage {
  int width = 0, height = 0;
  std::vector<float> rgb;
  std::vector<uint8_t> valid;
};

FileImage to_file_image(const EnvMap& map) {
  if (map.rgb.size() != 3 * map.pixel_count() || (!map.valid.empty() && map.valid.size() != map.pixel_count()))
    throw std::invalid_argument("write_envmap: map buffers do not match its size");
  FileImage img;
  if (map.layout == Layout::Healpix) {
    const int nside = map.nside;
    if (!is_power_of_two(nside) || size_t(map.width) != 12 * size_t(nside) * size_t(nside) || map.height != 1)
      throw std::invalid_argument("write_envmap: healpix map with inconsistent nside");
    img.width = nside;  // NESTED order row by row: face f fills rows [f nside, (f + 1) nside)
    img.height = 12 * nside;
    img.rgb = map.rgb;
    img.valid = map.valid;
  } else {
    img.width = map.width;
    img.height = map.height;
    img.rgb = map.rgb;
    img.valid = map.valid;
  }
  return img;
}

bool has_invalid_pixels(const EnvMap& map) {
  return std::any_of(map.valid.begin(), map.valid.end(), [](uint8_t v) { return v == 0; });
}

// ---------------------------------------------------------------------------------------
// OpenEXR

// Reads from a byte buffer, so that a short file is an exception, never a crash.
class MemoryIStream : public Imf::IStream {
 public:
  MemoryIStream(const std::string& bytes, const std::string& name) : Imf::IStream(name.c_str()), bytes_(bytes) {}
  bool read(char c[], int n) override {
    if (n < 0 || pos_ + uint64_t(n) > bytes_.size()) {
      hit_end_ = true;
      throw Iex::InputExc("unexpected end of file");
    }
    std::memcpy(c, bytes_.data() + pos_, size_t(n));
    pos_ += uint64_t(n);
    return pos_ < bytes_.size();
  }
  uint64_t tellg() override { return pos_; }
  void seekg(uint64_t pos) override { pos_ = pos; }
  // True once a read ran past the end: the file is truncated.
  bool hit_end() const { return hit_end_; }

 private:
  const std::string& bytes_;
  uint64_t pos_ = 0;
  bool hit_end_ = false;
};

RawImage decode_exr(const std::string& path, const std::string& bytes, MemoryIStream& stream);

// OpenEXR's own thread pool, one thread a core, for reading and writing: it (de)compresses
// blocks of lines in parallel (an 8192x4096 ZIP map read in 1.1 s instead of 1.9 s on two cores).
void use_exr_threads() {
  static std::once_flag once;
  std::call_once(once, [] { Imf::setGlobalThreadCount(int(std::max(1u, std::thread::hardware_concurrency()))); });
}

RawImage read_exr(const std::string& path) {
  const std::string bytes = read_whole_file(path);
  if (bytes.size() < 4 || !Imf::isImfMagic(bytes.data())) fail(path, "not an OpenEXR file (bad magic number)");
  // OpenEXR allocates what attribute sizes and data windows claim.
  const int parts = check_exr_header(path, bytes);
  MemoryIStream stream(bytes, path);
  use_exr_threads();
  try {
    RawImage raw = decode_exr(path, bytes, stream);
    if (parts > 1)  // a stereo pair's views, a render's subimages: Imf::InputFile reads the first
      raw.warnings.push_back(fmt::format("{}: {} parts (images); the first is read", path, parts));
    return raw;
  } catch (const InputError&) {
    throw;
  } catch (const std::exception& e) {
    if (stream.hit_end()) fail(path, "truncated file (data ends early)");
    throw;
  }
}

// A file in other primaries (an ACES2065-1 EXR, a Radiance file with a PRIMARIES line) is
// converted to Rec. 709, the maps' colour space (core/chromaticities.h). Read as Rec. 709 its
// colours were wrong without a word, and so was every luminance weighted from them.
void convert_to_rec709(const std::string& path, std::vector<float>& rgb, const Chromaticities& file) {
  if (same_chromaticities(file, kRec709)) return;
  const std::array<double, 9> m = to_rec709_matrix(file, path.c_str());
  // Rec. 709 by another name: Blender's studio lights state its primaries adapted to D50, as an
  // ICC profile does, which adapt back to within 1e-4 of the identity. Mixing channels by
  // that much only made negatives of zeros.
  double off = 0;
  for (int i = 0; i < 9; ++i) off = std::max(off, std::fabs(m[size_t(i)] - (i % 4 == 0 ? 1.0 : 0.0)));
  if (off <= 1e-3) return;
  apply_colour_matrix(rgb, m);
}

// A pixel whose alpha is below 0.5 holds no data: masked as invalid, never read as black
// (CONVENTIONS.md). lightprobe writes its maps' masks so. Other tools' files were read with
// alpha ignored, which made a render's transparent background (Blender's "film transparent":
// alpha and RGB 0) a black part of the scene; now it is masked too, said in one warning. An
// alpha that is 0 everywhere (some writers' placeholder) means nothing: ignored, with a warning.
// lightprobe's own files (every one records its units) are read silently, photos too: a fused
// bracket's pixels that no frame saw said "read as no data" on every read of it.
void alpha_to_mask(const std::string& path, RawImage& raw, const std::vector<float>& alpha) {
  const size_t transparent = size_t(std::count_if(alpha.begin(), alpha.end(), [](float a) { return !(a > 0.5f); }));
  if (raw.layout || raw.units) {
    raw.valid.resize(alpha.size());
    for (size_t i = 0; i < alpha.size(); ++i) raw.valid[i] = alpha[i] > 0.5f ? 1 : 0;
    return;
  }
  if (transparent == 0) return;
  if (transparent == alpha.size()) {
    raw.warnings.push_back(fmt::format("{}: its alpha channel is 0 everywhere: ignored", path));
    return;
  }
  raw.valid.resize(alpha.size());
  for (size_t i = 0; i < alpha.size(); ++i) raw.valid[i] = alpha[i] > 0.5f ? 1 : 0;
  raw.warnings.push_back(fmt::format("{}: {} pixels ({:.3g} %) have alpha below 0.5: read as no data (masked), not as black", path,
                   transparent, 100.0 * double(transparent) / double(alpha.size())));
}

// An OpenEXR image is its display window. The data window holds the pixels stored: the same,
// or smaller (a compositor's crop to the box that is not empty), offset, or larger (overscan).
// Taking the data window as the image shifted or cropped a map silently; now the display
// window is the image, its pixels outside the data window have no data and are masked as
// invalid (never read as black: CONVENTIONS.md), and data outside it is dropped.
void fit_to_display_window(const std::string& path, RawImage& raw, const Imath::Box2i& data,
                           const Imath::Box2i& display) {
  if (data == display) return;
  const long long W = (long long)display.max.x - display.min.x + 1, H = (long long)display.max.y - display.min.y + 1;
  check_image_size(path, W, H);
  // The data window's size is bounded by the file's (core/exr_header.h); the display window's
  // is not, so a few bytes could claim a 2^27-pixel image. Room for any crop of a map up to
  // 4096x4096, or a quarter of the display window stored.
  const long long stored = (long long)raw.width * raw.height, kFreePixels = 1ll << 24;
  if (W * H > std::max(4 * stored, kFreePixels))
    fail(path, fmt::format("the display window {}x{} is more than 4 times the {}x{} of data stored (and over {} pixels)",
                           W, H, raw.width, raw.height, kFreePixels));
  const int x0 = std::max(data.min.x, display.min.x), x1 = std::min(data.max.x, display.max.x);
  const int y0 = std::max(data.min.y, display.min.y), y1 = std::min(data.max.y, display.max.y);
  if (x0 > x1 || y0 > y1)
    fail(path, fmt::format("the data window ({}, {})-({}, {}) lies outside the display window ({}, {})-({}, {})",
                           data.min.x, data.min.y, data.max.x, data.max.y, display.min.x, display.min.y,
                           display.max.x, display.max.y));
  std::vector<float> rgb(3 * size_t(W) * size_t(H), 0.0f);
  std::vector<uint8_t> valid(size_t(W) * size_t(H), 0);
  for (int y = y0; y <= y1; ++y) {
    for (int x = x0; x <= x1; ++x) {
      const size_t src = size_t(y - data.min.y) * size_t(raw.width) + size_t(x - data.min.x);
      const size_t dst = size_t(y - display.min.y) * size_t(W) + size_t(x - display.min.x);
      std::copy_n(&raw.rgb[3 * src], 3, &rgb[3 * dst]);
      valid[dst] = raw.valid.empty() ? 1 : raw.valid[src];
    }
  }
  const bool all_valid = std::all_of(valid.begin(), valid.end(), [](uint8_t v) { return v != 0; });
  raw.width = int(W);
  raw.height = int(H);
  raw.rgb = std::move(rgb);
  if (all_valid && raw.valid.empty())
    raw.valid.clear();
  else
    raw.valid = std::move(valid);
}

// The layer prefix decode_exr reads ("" for the file's own channels, else "name."), see there.
std::string exr_rgb_layer(const std::string& path, const Imf::ChannelList& channels) {
  for (const char* name : {"R", "G", "B", "Y"})
    if (channels.findChannel(name)) return {};
  std::set<std::string> layers;
  channels.layers(layers);
  std::vector<std::string> rgb;
  for (const std::string& l : layers) {
    const std::string p = l + ".";
    if (channels.findChannel(p + "R") && channels.findChannel(p + "G") && channels.findChannel(p + "B")) rgb.push_back(p);
  }
  if (rgb.size() > 1) {
    std::string names;
    for (const std::string& l : rgb) names += (names.empty() ? "'" : ", '") + l.substr(0, l.size() - 1) + "'";
    fail(path, fmt::format("{} layers hold R, G and B ({}): which is the light is ambiguous; keep one (oiiotool "
                           "--ch) and read that",
                           rgb.size(), one_line(names, 80)));
  }
  return rgb.empty() ? std::string() : rgb[0];
}

RawImage decode_exr(const std::string& path, const std::string& bytes, MemoryIStream& stream) {
  Imf::InputFile file(stream);
  const Imf::Header& header = file.header();
  const Imath::Box2i dw = header.dataWindow();
  RawImage raw;
  const long long w = (long long)dw.max.x - dw.min.x + 1, h = (long long)dw.max.y - dw.min.y + 1;
  check_image_size(path, w, h);
  raw.width = int(w);
  raw.height = int(h);
  raw.layout_key = "lightprobe.layout";
  if (auto* a = header.findTypedAttribute<Imf::StringAttribute>("lightprobe.layout")) raw.layout = a->value();
  if (auto* a = header.findTypedAttribute<Imf::StringAttribute>("lightprobe.units")) raw.units = a->value();
  if (auto* a = header.findTypedAttribute<Imf::IntAttribute>("lightprobe.nside")) raw.nside = a->value();
  if (auto* a = header.findTypedAttribute<Imf::StringAttribute>(kExrRotationKey))
    raw.world_from_probe = parse_rotation_text(path, kExrRotationKey, a->value());
  if (auto* a = header.findTypedAttribute<Imf::StringAttribute>("lightprobe.vignetting"))
    raw.vignetting_corrected = a->value() == "corrected";
  if (auto* a = header.findTypedAttribute<Imf::IntAttribute>("lightprobe.exif_orientation")) {
    if (a->value() < 1 || a->value() > 8) fail(path, fmt::format("lightprobe.exif_orientation {} is not 1-8", a->value()));
    raw.exif_orientation = a->value();
  }
  if (auto* a = header.findTypedAttribute<Imf::StringAttribute>(kMirrorBallKey))
    raw.mirror_ball = a->value(), raw.mirror_ball_key = kMirrorBallKey;
  raw.openexr_cube = Imf::hasEnvmap(header) && Imf::envmap(header) == Imf::ENVMAP_CUBE;

  const Imf::ChannelList& channels = header.channels();
  // Channels of the layer read: the file's own R, G, B (A, Y, RY, BY), or, when it has none,
  // its one layer that has R, G and B (a render's "ViewLayer.Combined.R", ...: Blender's
  // multilayer files). More than one such layer is refused: which is the light is not ours
  // to guess.
  const std::string layer = exr_rgb_layer(path, channels);
  auto channel = [&](const char* name) { return channels.findChannel(layer + name); };
  auto has = [&](const char* name) { return channel(name) != nullptr; };
  for (const char* name : {"R", "G", "B", "A", "Y"}) {
    const Imf::Channel* c = channel(name);
    if (c && (c->xSampling != 1 || c->ySampling != 1)) fail(path, fmt::format("channel {}{} is subsampled", layer, name));
  }
  const bool rgb = has("R") && has("G") && has("B");
  const bool luma = has("Y");
  const bool luma_only = !rgb && !(has("RY") || has("BY"));  // grey: Y is Y in any primaries
  // X, Y and Z: CIE XYZ, converted to Rec. 709 (read as grey from Y alone, X and Z were dropped).
  const bool xyz = !rgb && has("X") && luma && has("Z");
  if (!rgb && !luma) {
    std::string names;
    for (auto it = channels.begin(); it != channels.end(); ++it) names += (names.empty() ? "" : ", ") + std::string(it.name());
    fail(path, fmt::format("needs R, G and B channels, or Y (channels: {})", one_line(names.empty() ? "none" : names, 80)));
  }
  if (!file.isComplete()) fail(path, "truncated file (pixel data incomplete)");

  const size_t n = size_t(w) * size_t(h);
  raw.rgb.assign(3 * n, 0.0f);
  // Alpha is the validity mask of lightprobe's own maps; in other files it is read too, see
  // alpha_to_mask.
  const bool want_mask = has("A");
  std::vector<float> alpha(want_mask ? n : 0, 1.0f);
  std::vector<float> y;
  if (!rgb && (has("RY") || has("BY"))) {
    // Luminance/chroma file: let the RGBA interface convert it.
    MemoryIStream stream2(bytes, path);
    Imf::RgbaInputFile rgba(stream2, layer.empty() ? std::string() : layer.substr(0, layer.size() - 1),
                            Imf::globalThreadCount());
    std::vector<Imf::Rgba> px(n);
    rgba.setFrameBuffer(px.data() - dw.min.x - size_t(dw.min.y) * size_t(w), 1, size_t(w));
    rgba.readPixels(dw.min.y, dw.max.y);
    for (size_t i = 0; i < n; ++i) {
      raw.rgb[3 * i] = px[i].r;
      raw.rgb[3 * i + 1] = px[i].g;
      raw.rgb[3 * i + 2] = px[i].b;
      if (want_mask) alpha[i] = px[i].a;
    }
  } else {
    Imf::FrameBuffer fb;
    const size_t xs = 3 * sizeof(float), ys = xs * size_t(w);
    if (rgb || xyz) {
      fb.insert(layer + (xyz ? "X" : "R"), Imf::Slice::Make(Imf::FLOAT, &raw.rgb[0], dw, xs, ys));
      fb.insert(layer + (xyz ? "Y" : "G"), Imf::Slice::Make(Imf::FLOAT, &raw.rgb[1], dw, xs, ys));
      fb.insert(layer + (xyz ? "Z" : "B"), Imf::Slice::Make(Imf::FLOAT, &raw.rgb[2], dw, xs, ys));
    } else {
      y.assign(n, 0.0f);
      fb.insert(layer + "Y", Imf::Slice::Make(Imf::FLOAT, y.data(), dw, sizeof(float), sizeof(float) * size_t(w)));
    }
    if (want_mask)
      fb.insert(layer + "A", Imf::Slice::Make(Imf::FLOAT, alpha.data(), dw, sizeof(float), sizeof(float) * size_t(w)));
    file.setFrameBuffer(fb);
    file.readPixels(dw.min.y, dw.max.y);
    for (size_t i = 0; i < y.size(); ++i) raw.rgb[3 * i] = raw.rgb[3 * i + 1] = raw.rgb[3 * i + 2] = y[i];
    if (xyz)  // CIE XYZ to linear Rec. 709 (D65): out-of-gamut colours come out negative, weighed below
      for (size_t i = 0; i < n; ++i) {
        float* p = &raw.rgb[3 * i];
        const double X = p[0], Y = p[1], Z = p[2];
        p[0] = float(3.2404542 * X - 1.5371385 * Y - 0.4985314 * Z);
        p[1] = float(-0.9692660 * X + 1.8760108 * Y + 0.0415560 * Z);
        p[2] = float(0.0556434 * X - 0.2040259 * Y + 1.0572252 * Z);
      }
  }
  // Lossy codecs ring around bright spots: tiny negative values that are not radiance,
  // clamped without a word. Only as much as a codec rings: a file resized with a sharp
  // filter keeps its DWA compression and rings far more (7 % of a channel's power below
  // zero around a sun), and that is left for the negative-value check to refuse, as it
  // refuses the same pixels stored losslessly.
  const Imf::Compression comp = header.compression();
  if (comp == Imf::DWAA_COMPRESSION || comp == Imf::DWAB_COMPRESSION || comp == Imf::B44_COMPRESSION ||
      comp == Imf::B44A_COMPRESSION) {
    double positive[3] = {0, 0, 0}, negative[3] = {0, 0, 0};
    for (size_t i = 0; i < raw.rgb.size(); ++i) {
      const float v = raw.rgb[i];
      if (v > 0 && std::isfinite(v)) positive[i % 3] += v;
      else if (v < 0 && std::isfinite(v)) negative[i % 3] -= v;
    }
    bool codec_ringing = true;
    for (int c = 0; c < 3; ++c) codec_ringing = codec_ringing && !(negative[c] > kSlightNegativeShare * positive[c]);
    if (codec_ringing)
      for (float& v : raw.rgb)
        if (v < 0.0f) v = 0.0f;
  }
  // After that clamp: colours outside Rec. 709's gamut come out negative, and those are the
  // scene's, for accept_slight_negatives to weigh and report.
  if (!luma_only && Imf::hasChromaticities(header)) {
    const Imf::Chromaticities& c = Imf::chromaticities(header);
    convert_to_rec709(path, raw.rgb, Chromaticities{{c.red.x, c.red.y}, {c.green.x, c.green.y}, {c.blue.x, c.blue.y},
                                                    {c.white.x, c.white.y}});
  }
  // OpenEXR's standard whiteLuminance (cd/m2 of RGB 1, 1, 1) makes a file absolute: a
  // calibrated render or capture from another tool, read as relative until now. Radiance
  // units are those where 683 Y is cd/m2 (CONVENTIONS.md), so the pixels scale by W / 683.
  // Our own units attribute, which is written with it, decides when both are there.
  if (!raw.units && Imf::hasWhiteLuminance(header)) {
    const float white = Imf::whiteLuminance(header);
    if (!(white > 0) || !std::isfinite(white))
      fail(path, fmt::format("whiteLuminance {} is not a positive luminance (cd/m2 of RGB 1, 1, 1)", white));
    for (float& v : raw.rgb) v *= white / kLuminousEfficacy;
    raw.units = std::string(to_string(Units::Radiance));
  }
  if (want_mask) alpha_to_mask(path, raw, alpha);
  fit_to_display_window(path, raw, dw, header.displayWindow());
  return raw;
}

std::string encode_exr(const std::string& path, const EnvMap& map, const WriteMapOptions& options) {
  const FileImage img = to_file_image(map);
  const bool half = options.exr_pixel_type == ExrPixelType::Half;
  if (half) {
    constexpr float kHalfMax = 65504.0f;
    for (size_t i = 0; i < img.rgb.size(); ++i) {
      if (std::fabs(img.rgb[i]) > kHalfMax && std::isfinite(img.rgb[i])) {
        const size_t p = i / 3;
        fail(path, fmt::format("cannot write as half: value {} at image pixel ({}, {}) exceeds the half range "
                               "(65504); write float",
                               img.rgb[i], p % size_t(img.width), p / size_t(img.width)));
      }
    }
  }
  const Imf::PixelType type = half ? Imf::HALF : Imf::FLOAT;
  Imf::Header header(img.width, img.height);
  // ZIP at deflate level 1, compressed by OpenEXR's own threads: on float maps it writes
  // 1.3-1.8x faster than the default level for 0-8 % more bytes, and PIZ, faster on smooth
  // maps, is slower still on the noisy float of fused brackets (docs/hdr.md has the table).
  header.compression() = Imf::ZIP_COMPRESSION;
  header.zipCompressionLevel() = 1;
  use_exr_threads();
  for (const char* c : {"R", "G", "B"}) header.channels().insert(c, Imf::Channel(type));
  const bool mask = !img.valid.empty();
  if (mask) header.channels().insert("A", Imf::Channel(type));
  if (options.record_layout)
    header.insert("lightprobe.layout", Imf::StringAttribute(std::string(to_string(map.layout))));
  header.insert("lightprobe.units", Imf::StringAttribute(std::string(to_string(map.units))));
  // The same for every OpenEXR reader (OpenImageIO, Nuke): RGB 1, 1, 1 is 683 cd/m2.
  if (map.units == Units::Radiance) Imf::addWhiteLuminance(header, float(kLuminousEfficacy));
  if (map.layout == Layout::Healpix) header.insert("lightprobe.nside", Imf::IntAttribute(map.nside));
  if (map.world_from_probe) header.insert(kExrRotationKey, Imf::StringAttribute(rotation_text(*map.world_from_probe)));
  if (map.vignetting_corrected) header.insert("lightprobe.vignetting", Imf::StringAttribute("corrected"));
  if (map.exif_orientation != 1) header.insert("lightprobe.exif_orientation", Imf::IntAttribute(map.exif_orientation));
  if (map.mirror_ball) header.insert(kMirrorBallKey, Imf::StringAttribute(mirror_ball_text(*map.mirror_ball)));

  // The frame buffer must hold the file's pixel type: convert to half here when needed.
  std::vector<float> alpha;
  std::vector<Imath::half> rgb_h, alpha_h;
  if (mask) {
    alpha.resize(img.valid.size());
    for (size_t i = 0; i < alpha.size(); ++i) alpha[i] = img.valid[i] ? 1.0f : 0.0f;
  }
  if (half) {
    rgb_h.assign(img.rgb.begin(), img.rgb.end());
    alpha_h.assign(alpha.begin(), alpha.end());
  }
  const size_t size = half ? sizeof(Imath::half) : sizeof(float);
  char* base = half ? reinterpret_cast<char*>(rgb_h.data()) : reinterpret_cast<char*>(const_cast<float*>(img.rgb.data()));
  char* abase = half ? reinterpret_cast<char*>(alpha_h.data()) : reinterpret_cast<char*>(alpha.data());
  Imf::FrameBuffer fb;
  const size_t xs = 3 * size, ys = xs * size_t(img.width);
  fb.insert("R", Imf::Slice(type, base + 0 * size, xs, ys));
  fb.insert("G", Imf::Slice(type, base + 1 * size, xs, ys));
  fb.insert("B", Imf::Slice(type, base + 2 * size, xs, ys));
  if (mask) fb.insert("A", Imf::Slice(type, abase, size, size * size_t(img.width)));
  Imf::StdOSStream os;
  {
    Imf::OutputFile out(os, header);
    out.setFrameBuffer(fb);
    out.writePixels(img.height);
  }
  return os.str();
}

// ---------------------------------------------------------------------------------------
// Radiance RGBE


double parse_positive(const std::string& path, const std::string& what, const std::string& text) {
  char* end = nullptr;
  const double v = std::strtod(text.c_str(), &end);
  if (end == text.c_str() || !std::isfinite(v) || v <= 0)
    fail(path, fmt::format("bad {} value '{}'", what, one_line(text, 40)));
  return v;
}

// A Radiance file's header: the metadata, the size, and where the scanlines start.
struct HdrHeader {
  RawImage raw;  // width, height, layout, units, nside; no pixels yet
  double scale[3] = {1.0, 1.0, 1.0};  // 1 / (EXPOSURE x COLORCORR) per channel
  Chromaticities primaries;           // Rec. 709 unless a PRIMARIES line says otherwise
  size_t data_start = 0;
};

HdrHeader read_hdr_header(const std::string& path, const std::string& bytes) {
  size_t pos = 0;
  constexpr size_t kMaxHeader = 1 << 16;
  // Returns the next line without its '\n'; nullopt at end of file.
  auto next_line = [&]() -> std::optional<std::string_view> {
    if (pos >= bytes.size()) return std::nullopt;
    const size_t nl = bytes.find('\n', pos);
    if (nl == std::string::npos || nl - pos > kMaxHeader) return std::nullopt;
    std::string_view line(bytes.data() + pos, nl - pos);
    pos = nl + 1;
    return line;
  };
  auto check_crlf = [&](std::string_view line) {
    if (!line.empty() && line.back() == '\r')
      fail(path, "header lines end in CR LF (the file went through a text-mode conversion and its pixel data is damaged)");
  };

  const auto magic = next_line();
  if (!magic) fail(path, "not a Radiance HDR file (no header)");
  const bool crlf = !magic->empty() && magic->back() == '\r';
  if (*magic != "#?RADIANCE" && *magic != "#?RGBE")
    fail(path, fmt::format("not a Radiance HDR file (first line is '{}', expected #?RADIANCE or #?RGBE{})",
                           one_line(*magic, 60), crlf ? "; lines end in CR LF, as after a text-mode conversion" : ""));
  check_crlf(*magic);

  HdrHeader header;
  RawImage& raw = header.raw;
  raw.layout_key = "LIGHTPROBE_LAYOUT";
  double exposure = 1.0;
  double colorcorr[3] = {1.0, 1.0, 1.0};
  for (;;) {
    const auto line = next_line();
    if (!line || pos > kMaxHeader) fail(path, "truncated or damaged header (no blank line before the resolution line)");
    check_crlf(*line);
    if (line->empty()) break;
    if ((*line)[0] == '#') continue;
    const size_t eq = line->find('=');
    if (eq == std::string_view::npos) continue;  // e.g. a command line recorded by a Radiance tool
    const std::string key = trim_blanks(line->substr(0, eq));
    const std::string value = trim_blanks(line->substr(eq + 1));
    if (key == "FORMAT") {
      if (value == "32-bit_rle_xyze")
        fail(path, "XYZE pixels are not supported (convert to RGBE, e.g. with Radiance's ra_xyze -r)");
      if (value != "32-bit_rle_rgbe")
        fail(path, fmt::format("unsupported FORMAT '{}' (expected 32-bit_rle_rgbe)", one_line(value, 40)));
    } else if (key == "EXPOSURE") {
      exposure *= parse_positive(path, "EXPOSURE", value);
    } else if (key == "COLORCORR") {
      std::istringstream in(value);
      double c[3];
      if (!(in >> c[0] >> c[1] >> c[2]) || !(c[0] > 0 && c[1] > 0 && c[2] > 0))
        fail(path, fmt::format("bad COLORCORR value '{}'", one_line(value, 40)));
      for (int k = 0; k < 3; ++k) colorcorr[k] *= c[k];
    } else if (key == "PRIMARIES") {
      std::istringstream in(value);
      double v[8];
      for (double& x : v)
        if (!(in >> x)) fail(path, fmt::format("bad PRIMARIES value '{}' (expected 8 numbers)", one_line(value, 60)));
      header.primaries = Chromaticities{{v[0], v[1]}, {v[2], v[3]}, {v[4], v[5]}, {v[6], v[7]}};
    } else if (key == "LIGHTPROBE_LAYOUT") {
      raw.layout = value;
    } else if (key == "LIGHTPROBE_UNITS") {
      raw.units = value;
    } else if (key == "LIGHTPROBE_NSIDE") {
      char* end = nullptr;
      const long v = std::strtol(value.c_str(), &end, 10);
      if (end == value.c_str() || *end != '\0' || v <= 0 || v > 8192)
        fail(path, fmt::format("bad LIGHTPROBE_NSIDE value '{}'", one_line(value, 40)));
      raw.nside = int(v);
    } else if (key == "LIGHTPROBE_WORLD_FROM_PROBE") {
      raw.world_from_probe = parse_rotation_text(path, "LIGHTPROBE_WORLD_FROM_PROBE", value);
    } else if (key == "LIGHTPROBE_VIGNETTING") {
      raw.vignetting_corrected = value == "corrected";
    } else if (key == "LIGHTPROBE_EXIF_ORIENTATION") {
      if (value.size() != 1 || value[0] < '1' || value[0] > '8')
        fail(path, fmt::format("bad LIGHTPROBE_EXIF_ORIENTATION value '{}' (expected 1-8)", one_line(value, 40)));
      raw.exif_orientation = value[0] - '0';
    } else if (key == "LIGHTPROBE_MIRROR_BALL") {
      raw.mirror_ball = value, raw.mirror_ball_key = "LIGHTPROBE_MIRROR_BALL";
    }
  }
  for (int k = 0; k < 3; ++k) header.scale[k] = 1.0 / (exposure * colorcorr[k]);

  const auto res = next_line();
  if (!res) fail(path, "truncated file (no resolution line)");
  check_crlf(*res);
  std::istringstream in{std::string(*res)};
  std::string a, b, extra;
  long long h = 0, w = 0;
  const bool four = bool(in >> a >> h >> b >> w) && !(in >> extra);
  if (!four) fail(path, fmt::format("bad resolution line '{}'", one_line(*res, 60)));
  if (a != "-Y" || b != "+X") {
    const bool radiance_orientation =
        (a.size() == 2 && b.size() == 2 && (a[0] == '+' || a[0] == '-') && (b[0] == '+' || b[0] == '-'));
    if (radiance_orientation)
      fail(path, fmt::format("unsupported orientation '{}' (only -Y H +X W, top to bottom and left to right)",
                             one_line(*res, 60)));
    fail(path, fmt::format("bad resolution line '{}'", one_line(*res, 60)));
  }
  check_image_size(path, w, h);
  raw.width = int(w);
  raw.height = int(h);
  header.data_start = pos;
  return header;
}

// Decodes scanline `row` starting at bytes[pos] into `line` (RGBE per pixel, W pixels):
// new-style run-length, or flat pixels with old-style runs. Advances `pos`.
void decode_hdr_scanline(const std::string& path, const std::string& bytes, size_t& pos, int W, int H, int row,
                         std::vector<uint8_t>& line) {
  const size_t end = bytes.size();
  auto byte = [&](size_t i) { return static_cast<uint8_t>(bytes[i]); };
  auto truncated = [&] { fail(path, fmt::format("truncated file (expected {} scanlines, read {})", H, row)); };
  auto corrupt = [&] { fail(path, fmt::format("corrupt run-length data in scanline {}", row)); };
  const bool new_rle =
      W >= 8 && W <= 0x7fff && pos + 4 <= end && byte(pos) == 2 && byte(pos + 1) == 2 && (byte(pos + 2) & 0x80) == 0;
  if (new_rle) {
    const int len = (byte(pos + 2) << 8) | byte(pos + 3);
    if (len != W) fail(path, fmt::format("corrupt scanline {} (length {}, expected {})", row, len, W));
    pos += 4;
    for (int c = 0; c < 4; ++c) {
      int x = 0;
      while (x < W) {
        if (pos >= end) truncated();
        int count = byte(pos++);
        if (count > 128) {
          count -= 128;
          if (x + count > W) corrupt();
          if (pos >= end) truncated();
          const uint8_t v = byte(pos++);
          for (int k = 0; k < count; ++k) line[4 * size_t(x++) + c] = v;
        } else {
          if (count == 0 || x + count > W) corrupt();
          if (pos + size_t(count) > end) truncated();
          for (int k = 0; k < count; ++k) line[4 * size_t(x++) + c] = byte(pos++);
        }
      }
    }
    return;
  }
  // Flat pixels, possibly with old-style runs: (1, 1, 1, n) repeats the previous pixel
  // n << shift times, the shift growing by 8 for consecutive run codes.
  int x = 0, shift = 0;
  while (x < W) {
    if (pos + 4 > end) truncated();
    const uint8_t r = byte(pos), g = byte(pos + 1), b = byte(pos + 2), e = byte(pos + 3);
    pos += 4;
    if (r == 1 && g == 1 && b == 1) {
      if (x == 0 || shift > 16) corrupt();
      const long long count = (long long)e << shift;
      if (x + count > W) corrupt();
      for (long long k = 0; k < count; ++k, ++x) std::copy_n(&line[4 * size_t(x - 1)], 4, &line[4 * size_t(x)]);
      shift += 8;
    } else {
      line[4 * size_t(x)] = r;
      line[4 * size_t(x) + 1] = g;
      line[4 * size_t(x) + 2] = b;
      line[4 * size_t(x) + 3] = e;
      ++x;
      shift = 0;
    }
  }
}

RawImage read_hdr(const std::string& path) {
  const std::string bytes = read_whole_file(path);
  HdrHeader header = read_hdr_header(path, bytes);
  RawImage raw = std::move(header.raw);
  const int W = raw.width, H = raw.height;
  // Every encoding spends at least 4 bytes a scanline (an RLE header or a literal pixel):
  // refuse a header whose size the data cannot hold before allocating for it.
  const size_t available = bytes.size() - header.data_start;
  if (available / 4 < size_t(H))
    fail(path, fmt::format("truncated file ({} bytes of pixel data cannot hold {} scanlines of at least 4 bytes)",
                           available, H));
  std::vector<uint8_t> line(4 * size_t(W));  // RGBE per pixel
  raw.rgb.resize(3 * size_t(W) * size_t(H));
  size_t pos = header.data_start;
  for (int row = 0; row < H; ++row) {
    decode_hdr_scanline(path, bytes, pos, W, H, row, line);
    float* out = &raw.rgb[3 * size_t(row) * size_t(W)];
    for (int x = 0; x < W; ++x) {
      const uint8_t* p = &line[4 * size_t(x)];
      if (p[3] == 0) {
        out[3 * x] = out[3 * x + 1] = out[3 * x + 2] = 0.0f;
        continue;
      }
      // Same decoding as Greg Ward's / Bruce Walter's rgbe.c (and OpenCV, stb_image, three.js).
      const double f = std::ldexp(1.0, int(p[3]) - (128 + 8));
      for (int c = 0; c < 3; ++c) out[3 * x + c] = float(p[c] * f * header.scale[c]);
    }
  }
  convert_to_rec709(path, raw.rgb, header.primaries);
  return raw;
}

// RGBE of one pixel, mantissas rounded to nearest (decoded as m * 2^(e-136)).
void float_to_rgbe(const float* rgb, uint8_t* out) {
  const float v = std::max({rgb[0], rgb[1], rgb[2]});
  if (!(v > 1e-38f)) {
    out[0] = out[1] = out[2] = out[3] = 0;
    return;
  }
  int e;
  std::frexp(v, &e);  // v = m 2^e, m in [0.5, 1): the largest mantissa is in [128, 256)
  double f = std::ldexp(1.0, 8 - e);
  if (std::lround(v * f) > 255) {
    ++e;
    f = std::ldexp(1.0, 8 - e);
  }
  if (e + 128 > 255) {  // beyond RGBE range: saturate
    out[0] = out[1] = out[2] = 255;
    out[3] = 255;
    return;
  }
  if (e + 128 < 1) {
    out[0] = out[1] = out[2] = out[3] = 0;
    return;
  }
  for (int c = 0; c < 3; ++c) out[c] = uint8_t(std::clamp<long>(std::lround(rgb[c] * f), 0, 255));
  out[3] = uint8_t(e + 128);
}

// Run-length encodes one channel of a scanline (new-style RLE): runs of 4 or more equal
// bytes become (128 + n, value), the rest literal dumps (n, bytes...), n <= 127 / 128.
void rle_channel(const uint8_t* data, int n, std::string& out) {
  constexpr int kMinRun = 4;
  int cur = 0;
  while (cur < n) {
    int beg_run = cur, run_count = 0, old_run_count = 0;
    while (run_count < kMinRun && beg_run < n) {
      beg_run += run_count;
      old_run_count = run_count;
      run_count = 1;
      while (beg_run + run_count < n && run_count < 127 && data[beg_run] == data[beg_run + run_count]) ++run_count;
    }
    // A short run just before the long one: emit it as a run too.
    if (old_run_count > 1 && old_run_count == beg_run - cur) {
      out += char(128 + old_run_count);
      out += char(data[cur]);
      cur = beg_run;
    }
    while (cur < beg_run) {
      const int count = std::min(128, beg_run - cur);
      out += char(count);
      out.append(reinterpret_cast<const char*>(data + cur), size_t(count));
      cur += count;
    }
    if (run_count >= kMinRun) {
      out += char(128 + run_count);
      out += char(data[beg_run]);
      cur += run_count;
    }
  }
}

std::string encode_hdr(const std::string& path, const EnvMap& map, const WriteMapOptions& options) {
  if (has_invalid_pixels(map))
    fail(path, "cannot write: the map has invalid pixels (a validity mask), which .hdr cannot store; write .exr");
  const std::string bad = find_bad_pixel(map, path);
  if (!bad.empty()) throw InputError(bad + "; RGBE cannot store it");
  const FileImage img = to_file_image(map);
  std::string out = "#?RADIANCE\n# Written by lightprobe\nFORMAT=32-bit_rle_rgbe\n";
  if (options.record_layout) out += fmt::format("LIGHTPROBE_LAYOUT={}\n", to_string(map.layout));
  out += fmt::format("LIGHTPROBE_UNITS={}\n", to_string(map.units));
  if (map.layout == Layout::Healpix) out += fmt::format("LIGHTPROBE_NSIDE={}\n", map.nside);
  if (map.world_from_probe) out += "LIGHTPROBE_WORLD_FROM_PROBE=" + rotation_text(*map.world_from_probe) + "\n";
  if (map.vignetting_corrected) out += "LIGHTPROBE_VIGNETTING=corrected\n";
  if (map.exif_orientation != 1) out += fmt::format("LIGHTPROBE_EXIF_ORIENTATION={}\n", map.exif_orientation);
  if (map.mirror_ball) out += "LIGHTPROBE_MIRROR_BALL=" + mirror_ball_text(*map.mirror_ball) + "\n";
  out += fmt::format("\n-Y {} +X {}\n", img.height, img.width);
  const int W = img.width;
  std::vector<uint8_t> rgbe(4 * size_t(W));
  std::vector<uint8_t> channel(static_cast<size_t>(W));
  for (int row = 0; row < img.height; ++row) {
    for (int x = 0; x < W; ++x) float_to_rgbe(&img.rgb[3 * (size_t(row) * W + x)], &rgbe[4 * size_t(x)]);
    if (W < 8 || W > 0x7fff) {
      out.append(reinterpret_cast<const char*>(rgbe.data()), rgbe.size());
      continue;
    }
    out += char(2);
    out += char(2);
    out += char(W >> 8);
    out += char(W & 0xff);
    for (int c = 0; c < 4; ++c) {
      for (int x = 0; x < W; ++x) channel[size_t(x)] = rgbe[4 * size_t(x) + c];
      rle_channel(channel.data(), W, out);
    }
  }
  return out;
}

// ---------------------------------------------------------------------------------------
// PFM

RawImage read_pfm(const std::string& path) {
  const std::string bytes = read_whole_file(path);
  size_t pos = 0;
  auto token = [&]() -> std::string {
    while (pos < bytes.size() && std::isspace(static_cast<unsigned char>(bytes[pos]))) ++pos;
    const size_t start = pos;
    while (pos < bytes.size() && !std::isspace(static_cast<unsigned char>(bytes[pos])) && pos - start < 64) ++pos;
    return bytes.substr(start, pos - start);
  };
  const std::string magic = token();
  if (magic != "PF" && magic != "Pf")
    fail(path, fmt::format("not a PFM file (starts with '{}', expected PF or Pf)", one_line(magic, 20)));
  const int channels = magic == "PF" ? 3 : 1;
  const std::string ws = token(), hs = token(), ss = token();
  char* end = nullptr;
  const long long w = std::strtoll(ws.c_str(), &end, 10);
  if (ws.empty() || *end) fail(path, fmt::format("bad PFM width '{}'", one_line(ws, 20)));
  const long long h = std::strtoll(hs.c_str(), &end, 10);
  if (hs.empty() || *end) fail(path, fmt::format("bad PFM height '{}'", one_line(hs, 20)));
  const double scale = std::strtod(ss.c_str(), &end);
  if (ss.empty() || *end || !std::isfinite(scale) || scale == 0)
    fail(path, fmt::format("bad PFM scale '{}'", one_line(ss, 20)));
  if (pos >= bytes.size() || !std::isspace(static_cast<unsigned char>(bytes[pos])))
    fail(path, "truncated file (no pixel data)");
  ++pos;  // the single whitespace after the scale
  check_image_size(path, w, h);
  const bool little = scale < 0;
  const size_t row_bytes = size_t(w) * size_t(channels) * 4;
  const size_t avail = bytes.size() - pos;
  if (avail < row_bytes * size_t(h))
    fail(path, fmt::format("truncated file (expected {} rows, read {})", h, avail / row_bytes));
  RawImage raw;
  raw.width = int(w);
  raw.height = int(h);
  raw.rgb.resize(3 * size_t(w) * size_t(h));
  const bool swap = little != (std::endian::native == std::endian::little);
  const char* data = bytes.data() + pos;
  for (long long r = 0; r < h; ++r) {
    const long long out_row = h - 1 - r;  // stored bottom to top
    for (long long x = 0; x < w; ++x) {
      float v[3];
      for (int c = 0; c < channels; ++c) {
        uint32_t u;
        std::memcpy(&u, data + (size_t(r) * size_t(w) + size_t(x)) * size_t(channels) * 4 + size_t(c) * 4, 4);
        if (swap) u = __builtin_bswap32(u);
        std::memcpy(&v[c], &u, 4);
      }
      if (channels == 1) v[1] = v[2] = v[0];
      std::copy_n(v, 3, &raw.rgb[3 * (size_t(out_row) * size_t(w) + size_t(x))]);
    }
  }
  return raw;
}

std::string encode_pfm(const std::string& path, const EnvMap& map, const WriteMapOptions& options) {
  if (has_invalid_pixels(map))
    fail(path, "cannot write: the map has invalid pixels (a validity mask), which .pfm cannot store; write .exr");
  const FileImage img = to_file_image(map);
  // A .pfm records no layout, units or rotation: one that would read back otherwise is refused
  // (a 2:1 hemisphere map came back as latlong, the sun below the horizon; radiance as relative).
  // (A shape of no layout is refused when read, so an image of another shape, a cube face,
  // is written: it cannot come back as the wrong map.)
  // An image that is no map (write_rgb_image: a fused photo, a cube face) has no layout to lose.
  const std::optional<Layout> read_back = layout_from_shape(img.width, img.height);
  if (options.record_layout && read_back && *read_back != map.layout)
    fail(path, fmt::format("cannot write: .pfm records no layout, and this {} map of {}x{} would read back as {}; "
                           "write .exr or .hdr",
                           to_string(map.layout), img.width, img.height, to_string(*read_back)));
  if (map.units == Units::Radiance)
    fail(path, "cannot write: .pfm records no units, and this map in radiance units would read back as relative; "
               "write .exr or .hdr");
  const Mat3 identity = rotation_from_yaw_pitch_roll_deg(0, 0, 0);
  if (map.world_from_probe && map.world_from_probe->m != identity.m)
    fail(path, "cannot write: .pfm records no probe rotation (world_from_probe); write .exr or .hdr");
  if (map.vignetting_corrected)
    fail(path, "cannot write: .pfm cannot record that the vignetting was corrected, and it would be corrected again; "
               "write .exr or .hdr");
  if (map.exif_orientation != 1)
    fail(path, "cannot write: .pfm cannot record the EXIF Orientation the photo was turned by, which a fisheye "
               "unwrap turns back; write .exr or .hdr");
  const bool little = std::endian::native == std::endian::little;
  std::string out = fmt::format("PF\n{} {}\n{}\n", img.width, img.height, little ? "-1.0" : "1.0");
  const size_t row_floats = 3 * size_t(img.width);
  for (int r = img.height - 1; r >= 0; --r)
    out.append(reinterpret_cast<const char*>(&img.rgb[size_t(r) * row_floats]), row_floats * sizeof(float));
  return out;
}

// ---------------------------------------------------------------------------------------

std::string unsupported_map_extension(const std::string& path) {
  const std::string ext = lower_extension(path);
  return fmt::format("unsupported map format '{}' (expected .exr, .hdr, .pfm or a floating-point .tif)",
                     ext.empty() ? "(none)" : ext);
}

bool is_tiff_extension(const std::string& path) {
  const std::string ext = lower_extension(path);
  return ext == ".tif" || ext == ".tiff";
}

// A floating-point TIFF (SampleFormat 3, or LogLuv): the HDR output of panorama stitchers (PTGui, Hugin)
// beside EXR and Radiance, decoded by OpenCV's TIFF reader (the codecs plugin), which also
// turns it as its Orientation tag says. An integer TIFF holds camera codes, not radiance, and
// is refused as a map.
RawImage read_float_tiff(const std::string& path) {
  const std::string bytes = read_whole_file(path);
  if (bytes.empty()) fail(path, "cannot read: empty file");
  const auto header = read_image_header(path, bytes);
  if (!header || header->format != ImageFormat::Tiff) fail(path, "not a TIFF file (bad magic number)");
  check_image_size(path, header->width, header->height);
  if (!header->float_samples)
    fail(path, "integer samples are camera codes, not radiance: fuse a bracket (hdr fuse) or unwrap the photo "
               "(probe unwrap) to make a map of it");
  const cv::Mat img = lazy::decode_image(bytes);
  if (img.empty()) fail(path, "cannot decode image (damaged file, or a floating-point TIFF OpenCV cannot read)");
  if (img.depth() != CV_32F)
    fail(path, "floating-point samples other than 32-bit are not supported (write 32-bit float, or EXR)");
  const int ch = img.channels();
  if (ch != 1 && ch != 3 && ch != 4) fail(path, fmt::format("unsupported channel count {}", ch));
  RawImage raw;
  raw.width = img.cols, raw.height = img.rows;
  const size_t n = size_t(img.cols) * size_t(img.rows);
  raw.rgb.resize(3 * n);
  std::vector<float> alpha(ch == 4 ? n : 0);
  for (int y = 0; y < img.rows; ++y) {
    const float* row = img.ptr<float>(y);
    for (int x = 0; x < img.cols; ++x) {
      const size_t i = size_t(y) * size_t(img.cols) + size_t(x);
      const float* p = row + size_t(x) * size_t(ch);
      for (int c = 0; c < 3; ++c) raw.rgb[3 * i + size_t(c)] = ch == 1 ? p[0] : p[2 - c];  // OpenCV's BGR(A)
      if (ch == 4) alpha[i] = p[3];
    }
  }
  if (ch == 4) alpha_to_mask(path, raw, alpha);
  return raw;
}

// Runs `body`, turning any foreign exception (Iex, OpenCV, std) into one InputError line.
template <class F>
auto guarded(const std::string& path, const char* verb, F&& body) -> decltype(body()) {
  try {
    return body();
  } catch (const InputError&) {
    throw;
  } catch (const std::invalid_argument&) {
    throw;
  } catch (const std::bad_alloc&) {
    fail(path, fmt::format("cannot {}: out of memory", verb));
  } catch (const std::exception& e) {
    fail(path, fmt::format("cannot {}: {}", verb, one_line(e.what())));
  } catch (...) {
    fail(path, fmt::format("cannot {}: unknown error", verb));
  }
}

}  // namespace

// ---------------------------------------------------------------------------------------

EnvMap read_envmap(const std::string& path, const ReadMapOptions& options) {
  return guarded(path, "read", [&] {
    const std::string ext = lower_extension(path);
    RawImage raw;
    if (ext == ".exr")
      raw = read_exr(path);
    else if (ext == ".hdr" || ext == ".pic" || ext == ".rgbe")
      raw = read_hdr(path);
    else if (ext == ".pfm")
      raw = read_pfm(path);
    else if (is_tiff_extension(path))
      raw = read_float_tiff(path);
    else
      fail(path, unsupported_map_extension(path));
    return finish_map(path, std::move(raw), options);
  });
}

void write_envmap(const std::string& path, const EnvMap& map, const WriteMapOptions& options) {
  const std::string bytes = guarded(path, "write", [&] {
    const std::string ext = lower_extension(path);
    if (ext == ".exr") return encode_exr(path, map, options);
    if (ext == ".hdr") return encode_hdr(path, map, options);
    if (ext == ".pfm") return encode_pfm(path, map, options);
    fail(path, unsupported_map_extension(path));
  });
  write_file_atomically(path, bytes);
}

std::string encode_envmap_exr(const EnvMap& map, const WriteMapOptions& options) {
  const std::string name = "EXR in memory";
  return guarded(name, "write", [&] { return encode_exr(name, map, options); });
}

static CameraImage camera_image_from_bytes(const std::string& path, const std::string& bytes, bool as_stored);

RgbImage read_rgb_image(const std::string& path, bool as_stored) {
  RgbImage img;
  // A .tif holds radiance (floating-point samples: read as a map is) or camera codes: its
  // header says which, from the bytes read once for either.
  std::string tiff;
  bool float_tiff = false;
  if (is_tiff_extension(path)) {
    tiff = guarded(path, "read", [&] { return read_whole_file(path); });
    const auto header = guarded(path, "read", [&] { return read_image_header(path, tiff); });
    float_tiff = header && header->format == ImageFormat::Tiff && header->float_samples;
  }
  if (is_radiance_file(path) || float_tiff) {
    ReadMapOptions ro;
    ro.layout = Layout::Hemisphere;  // any W x H; the layout is not used
    EnvMap m = read_envmap(path, ro);
    img.width = m.width;
    img.height = m.height;
    img.rgb = std::move(m.rgb);
    img.valid = std::move(m.valid);
    img.units = m.units;
    img.vignetting_corrected = m.vignetting_corrected;
    img.orientation = m.exif_orientation;
    img.mirror_ball = m.mirror_ball;
    return img;
  }
  CameraImage c = tiff.empty() ? read_camera_image(path, as_stored) : camera_image_from_bytes(path, tiff, as_stored);
  img.orientation = c.orientation;
  img.width = c.width;
  img.height = c.height;
  img.rgb = std::move(c.rgb);
  img.valid = std::move(c.valid);
  img.code_bits = c.bit_depth;
  img.mirror_ball = c.mirror_ball;
  return img;
}

void write_rgb_image(const std::string& path, const RgbImage& image, const WriteMapOptions& options) {
  EnvMap m;
  m.layout = Layout::Hemisphere;
  m.width = image.width;
  m.height = image.height;
  m.rgb = image.rgb;
  m.valid = image.valid;
  m.units = image.units;
  m.vignetting_corrected = image.vignetting_corrected;
  // A radiance image keeps the EXIF turn it was shown by (a bracket fused as its tags showed it).
  m.exif_orientation = image.orientation;
  m.mirror_ball = image.mirror_ball;
  WriteMapOptions o = options;
  o.record_layout = false;
  write_envmap(path, m, o);
}

namespace {

// PNG camera images are decoded by libpng in-process: through OpenCV they loaded the codecs
// plugin and its 265 libraries (~0.3 s of a 0.4 s `hdr fuse` of three PNG frames). The same
// result as OpenCV's IMREAD_UNCHANGED: palettes and 1-4 bit grey expanded to 8 bits, 16 bits
// kept, alpha (and tRNS transparency) kept for the validity mask. libpng reports errors by longjmp, so nothing between
// png_ calls owns a destructor: the pixels go to a buffer sized from the checked header.
struct PngSource {
  const uint8_t* data;
  size_t size, at;
};

void png_source_read(png_structp png, png_bytep out, png_size_t n) {
  auto* src = static_cast<PngSource*>(png_get_io_ptr(png));
  if (n > src->size - src->at) png_error(png, "truncated");
  std::memcpy(out, src->data + src->at, n);
  src->at += n;
}

// Fills the rows (each width * 8 bytes: up to 4 channels of 16 bits) and returns true, or
// false for a damaged file; `channels` (1 grey, 2 grey + alpha, 3 RGB, 4 RGBA) and `depth`
// (8 or 16) say what was stored.
// `ball_text` (kBallTextBytes) receives the tEXt "lightprobe.mirror_ball" before the pixels,
// NUL-terminated (empty without one): a buffer, as nothing owning memory may cross libpng's
// longjmp.
constexpr size_t kBallTextBytes = 256;
bool decode_png_rows(PngSource* src, uint32_t width, uint32_t height, png_bytep* rows, int* channels, int* depth,
                     char* ball_text) {
  png_structp png = png_create_read_struct(PNG_LIBPNG_VER_STRING, nullptr, nullptr, nullptr);
  if (!png) return false;
  png_infop info = png_create_info_struct(png);
  if (!info || setjmp(png_jmpbuf(png))) {
    png_destroy_read_struct(&png, info ? &info : nullptr, nullptr);
    return false;
  }
  png_set_read_fn(png, src, png_source_read);
  png_set_user_limits(png, width, height);  // what the checked header said, no more
  png_read_info(png, info);
  if (png_get_image_width(png, info) != width || png_get_image_height(png, info) != height) png_error(png, "size");
  ball_text[0] = '\0';
  png_textp texts = nullptr;
  const int n_texts = png_get_text(png, info, &texts, nullptr);
  for (int i = 0; i < n_texts; ++i)
    if (std::strcmp(texts[i].key, kMirrorBallKey) == 0 && texts[i].text) {
      // Longer than any "cx cy r": kept cut, which the parse then refuses.
      std::strncpy(ball_text, texts[i].text, kBallTextBytes - 1);
      ball_text[kBallTextBytes - 1] = '\0';
    }
  const int type = png_get_color_type(png, info);
  if (type == PNG_COLOR_TYPE_PALETTE) png_set_palette_to_rgb(png);
  if (type == PNG_COLOR_TYPE_GRAY && png_get_bit_depth(png, info) < 8) png_set_expand_gray_1_2_4_to_8(png);
  if (png_get_valid(png, info, PNG_INFO_tRNS)) png_set_tRNS_to_alpha(png);  // transparency as alpha
  if (png_get_bit_depth(png, info) == 16) png_set_swap(png);  // host (little-endian) order
  png_set_interlace_handling(png);  // png_read_image then runs every pass
  png_read_update_info(png, info);
  *channels = png_get_channels(png, info);
  *depth = png_get_bit_depth(png, info);
  if (*channels < 1 || *channels > 4 || (*depth != 8 && *depth != 16) ||
      png_get_rowbytes(png, info) > size_t(width) * 8)
    png_error(png, "layout");
  png_read_image(png, rows);
  png_destroy_read_struct(&png, &info, nullptr);
  return true;
}

// Decoded samples (8-bit, or 16-bit in host order; `channels` 1 grey, 2 grey + alpha, 3 or
// 4 in RGB(A) order or BGR(A) when `bgr`; rows `stride` bytes apart) as a CameraImage:
// codes / (2^depth - 1), grey repeated, alpha below half of its range the validity mask
// (left empty when every pixel is opaque enough). One conversion for libpng's, libjpeg's and
// OpenCV's pixels.
CameraImage camera_image_from_samples(int width, int height, int depth, int channels, bool bgr, const uint8_t* data,
                                      size_t stride) {
  CameraImage out;
  out.width = width;
  out.height = height;
  out.bit_depth = depth;
  const float s = depth == 8 ? 1.0f / 255.0f : 1.0f / 65535.0f;
  const bool grey = channels <= 2, alpha = channels == 2 || channels == 4;
  out.grey = grey;
  out.rgb.resize(3 * size_t(width) * size_t(height));
  auto sample = [&](const uint8_t* row, size_t k) {
    uint16_t v = 0;
    if (depth == 8) v = row[k];
    else std::memcpy(&v, &row[2 * k], 2);
    return v;
  };
  size_t transparent = 0;
  if (alpha) out.valid.assign(size_t(width) * size_t(height), 1);
  for (size_t y = 0; y < size_t(height); ++y) {
    const uint8_t* row = data + y * stride;
    float* o = &out.rgb[3 * y * size_t(width)];
    for (size_t x = 0; x < size_t(width); ++x) {
      for (size_t c = 0; c < 3; ++c) {
        const size_t k = size_t(channels) * x + (grey ? 0 : bgr ? 2 - c : c);
        o[3 * x + c] = float(sample(row, k)) * s;
      }
      if (alpha && !(float(sample(row, size_t(channels) * x + size_t(channels) - 1)) * s >= 0.5f))
        out.valid[y * size_t(width) + x] = 0, ++transparent;
    }
  }
  if (transparent == 0) out.valid.clear();
  return out;
}

CameraImage decode_png_image(const std::string& path, const std::string& bytes, uint32_t width, uint32_t height) {
  const size_t stride = size_t(width) * 8;
  std::vector<uint8_t> pixels(stride * size_t(height));
  std::vector<png_bytep> rows(static_cast<size_t>(height));
  for (uint32_t y = 0; y < height; ++y) rows[y] = pixels.data() + size_t(y) * stride;
  PngSource src{reinterpret_cast<const uint8_t*>(bytes.data()), bytes.size(), 0};
  int channels = 0, depth = 0;
  char ball_text[kBallTextBytes];
  if (!decode_png_rows(&src, width, height, rows.data(), &channels, &depth, ball_text))
    fail(path, "cannot decode image (damaged file)");
  CameraImage image = camera_image_from_samples(int(width), int(height), depth, channels, false, pixels.data(), stride);
  if (ball_text[0])
    image.mirror_ball = parse_mirror_ball_text(path, kMirrorBallKey, ball_text, int(width), int(height));
  return image;
}

// JPEGs likewise by libjpeg-turbo in-process, as OpenCV's decoder does with the same library
// (IMREAD_UNCHANGED: no EXIF rotation; grey stays one channel): the common ones, 8-bit grey
// or YCbCr. CMYK, YCCK and 12-bit files are left to the plugin (nullopt). libjpeg reports
// fatal errors through error_exit, here a longjmp out of the decode.
struct JpegError {
  jpeg_error_mgr mgr;
  std::jmp_buf jump;
};

void jpeg_error_exit(j_common_ptr cinfo) { std::longjmp(reinterpret_cast<JpegError*>(cinfo->err)->jump, 1); }
void jpeg_quiet(j_common_ptr, int) {}  // corrupt-data warnings: decoded on, as OpenCV does

// 0: decoded into `pixels` (width * height * 3 bytes, `channels` 1 or 3); 1: damaged;
// 2: a kind left to the plugin.
int decode_jpeg_rows(const std::string& bytes, uint32_t width, uint32_t height, uint8_t* pixels, int* channels) {
  jpeg_decompress_struct cinfo;
  JpegError err;
  cinfo.err = jpeg_std_error(&err.mgr);
  err.mgr.error_exit = jpeg_error_exit;
  err.mgr.emit_message = jpeg_quiet;
  if (setjmp(err.jump)) {
    jpeg_destroy_decompress(&cinfo);
    return 1;
  }
  jpeg_create_decompress(&cinfo);
  jpeg_mem_src(&cinfo, reinterpret_cast<const unsigned char*>(bytes.data()), static_cast<unsigned long>(bytes.size()));
  jpeg_read_header(&cinfo, TRUE);
  const bool grey = cinfo.jpeg_color_space == JCS_GRAYSCALE && cinfo.num_components == 1;
  const bool colour = cinfo.jpeg_color_space == JCS_YCbCr || cinfo.jpeg_color_space == JCS_RGB;
  if ((!grey && !colour) || cinfo.data_precision != 8 || cinfo.image_width != width || cinfo.image_height != height) {
    jpeg_destroy_decompress(&cinfo);
    return 2;
  }
  cinfo.out_color_space = grey ? JCS_GRAYSCALE : JCS_RGB;
  jpeg_start_decompress(&cinfo);
  *channels = cinfo.output_components;
  const size_t stride = size_t(width) * size_t(*channels);
  while (cinfo.output_scanline < cinfo.output_height) {
    JSAMPROW row = pixels + size_t(cinfo.output_scanline) * stride;
    jpeg_read_scanlines(&cinfo, &row, 1);
  }
  jpeg_finish_decompress(&cinfo);
  jpeg_destroy_decompress(&cinfo);
  return 0;
}

std::optional<CameraImage> decode_jpeg_image(const std::string& path, const std::string& bytes, uint32_t width,
                                             uint32_t height) {
  std::vector<uint8_t> pixels(size_t(width) * size_t(height) * 3);
  int channels = 0;
  const int result = decode_jpeg_rows(bytes, width, height, pixels.data(), &channels);
  if (result == 2) return std::nullopt;
  if (result == 1 || (channels != 1 && channels != 3)) fail(path, "cannot decode image (damaged file)");
  return camera_image_from_samples(int(width), int(height), 8, channels, false, pixels.data(),
                                   size_t(width) * size_t(channels));
}

// The stored pixels turned as EXIF `orientation` (1-8) tells viewers to show them: the
// image a user sees, and what OpenCV's imread (without IMREAD_UNCHANGED) and LibRaw (RAW
// brackets, hdr/raw_input.h) give. For displayed pixel (x, y) of the turned size, the stored
// one it shows.
CameraImage turned_for_display(CameraImage in, int orientation) {
  if (orientation <= 1 || orientation > 8) return in;
  const size_t w = size_t(in.width), h = size_t(in.height);
  const bool swap = orientation >= 5;  // 5-8 exchange rows and columns
  CameraImage out;
  out.width = int(swap ? h : w), out.height = int(swap ? w : h), out.bit_depth = in.bit_depth, out.grey = in.grey;
  if (in.mirror_ball) out.mirror_ball = mirror_ball_as_shown(*in.mirror_ball, orientation, in.width, in.height);
  out.rgb.resize(in.rgb.size());
  out.valid.resize(in.valid.size());
  const size_t ow = size_t(out.width), oh = size_t(out.height);
  for (size_t y = 0; y < oh; ++y)
    for (size_t x = 0; x < ow; ++x) {
      size_t sx = x, sy = y;
      switch (orientation) {
        case 2: sx = w - 1 - x; break;                  // mirrored left to right
        case 3: sx = w - 1 - x, sy = h - 1 - y; break;  // turned 180 degrees
        case 4: sy = h - 1 - y; break;                  // mirrored top to bottom
        case 5: sx = y, sy = x; break;                  // transposed
        case 6: sx = y, sy = h - 1 - x; break;          // turned 90 degrees clockwise
        case 7: sx = w - 1 - y, sy = h - 1 - x; break;  // transversed
        case 8: sx = w - 1 - y, sy = x; break;          // turned 90 degrees counter-clockwise
      }
      const float* p = &in.rgb[3 * (sy * w + sx)];
      float* q = &out.rgb[3 * (y * ow + x)];
      q[0] = p[0], q[1] = p[1], q[2] = p[2];
      if (!in.valid.empty()) out.valid[y * ow + x] = in.valid[sy * w + sx];
    }
  return out;
}

CameraImage decode_camera_image(const std::string& path, const std::string& bytes, const ImageHeader& header) {
  const uint32_t width = uint32_t(header.width), height = uint32_t(header.height);
  if (header.format == ImageFormat::Png) return decode_png_image(path, bytes, width, height);
  if (header.format == ImageFormat::Jpeg)
    if (auto decoded = decode_jpeg_image(path, bytes, width, height)) return std::move(*decoded);
  const cv::Mat img = lazy::decode_image(bytes);
  if (img.empty()) fail(path, "cannot decode image (damaged file)");
  const int depth = img.depth();
  if (depth != CV_8U && depth != CV_16U) fail(path, "unsupported sample type (camera images must be 8- or 16-bit)");
  const int ch = img.channels();
  if (ch != 1 && ch != 3 && ch != 4) fail(path, fmt::format("unsupported channel count {}", ch));
  return camera_image_from_samples(img.cols, img.rows, depth == CV_8U ? 8 : 16, ch, true, img.ptr<uint8_t>(0),
                                   img.step[0]);
}

}  // namespace

std::array<double, 2> stored_from_shown(int orientation, int stored_width, int stored_height, std::array<double, 2> p) {
  const double w1 = stored_width - 1, h1 = stored_height - 1, x = p[0], y = p[1];
  switch (orientation) {  // as turned_for_display maps a shown pixel to its stored one
    case 2: return {w1 - x, y};
    case 3: return {w1 - x, h1 - y};
    case 4: return {x, h1 - y};
    case 5: return {y, x};
    case 6: return {y, h1 - x};
    case 7: return {w1 - y, h1 - x};
    case 8: return {w1 - y, x};
    default: return p;
  }
}

std::array<double, 2> shown_from_stored(int orientation, int stored_width, int stored_height, std::array<double, 2> p) {
  const double w1 = stored_width - 1, h1 = stored_height - 1, sx = p[0], sy = p[1];
  switch (orientation) {  // stored_from_shown solved for the shown point
    case 2: return {w1 - sx, sy};
    case 3: return {w1 - sx, h1 - sy};
    case 4: return {sx, h1 - sy};
    case 5: return {sy, sx};
    case 6: return {h1 - sy, sx};
    case 7: return {h1 - sy, w1 - sx};
    case 8: return {sy, w1 - sx};
    default: return p;
  }
}

std::string turned_size_hint(int width, int height, int other_width, int other_height) {
  if (width == height || width != other_height || height != other_width) return {};
  return " (the same size turned 90 degrees: images are read as their EXIF Orientation shows them, and one set needs "
         "one orientation)";
}

// read_camera_image on the file's bytes, already read.
// The shown image (turned as `orientation` says) back as stored: OpenCV turns TIFFs itself.
static CameraImage stored_from_display(CameraImage in, int orientation) {
  if (orientation <= 1 || orientation > 8) return in;
  const bool swap = orientation >= 5;
  CameraImage out = in;
  out.width = swap ? in.height : in.width, out.height = swap ? in.width : in.height;
  for (int y = 0; y < out.height; ++y)
    for (int x = 0; x < out.width; ++x) {
      const auto p = shown_from_stored(orientation, out.width, out.height, {double(x), double(y)});
      const size_t from = size_t(p[1]) * size_t(in.width) + size_t(p[0]), to = size_t(y) * size_t(out.width) + size_t(x);
      for (size_t c = 0; c < 3; ++c) out.rgb[3 * to + c] = in.rgb[3 * from + c];
      if (!in.valid.empty()) out.valid[to] = in.valid[from];
    }
  return out;
}

static CameraImage camera_image_from_bytes(const std::string& path, const std::string& bytes, bool as_stored) {
  return guarded(path, "read", [&] {
    if (bytes.empty()) fail(path, "cannot read: empty file");
    // The decoder allocates what the header claims: check the claim first.
    const auto header = read_image_header(path, bytes);
    if (!header) fail(path, "unsupported camera image format (expected PNG, JPEG, TIFF, PNM or BMP)");
    check_image_size(path, header->width, header->height);
    if (jpeg_is_truncated(bytes)) fail(path, "truncated JPEG (no end-of-image marker)");
    if (bytes.size() < header->min_file_bytes)
      fail(path, fmt::format("{} bytes cannot hold a {}x{} {} (at least {}): damaged file or a forged header",
                             bytes.size(), header->width, header->height, to_string(header->format),
                             header->min_file_bytes));
    if (bytes.size() > size_t(std::numeric_limits<int>::max())) fail(path, "file over 2 GiB: not a camera image");
    // OpenCV's TIFF decoder turns TIFFs itself, even under IMREAD_UNCHANGED (8- and 16-bit,
    // grey and RGB, measured with OpenCV 4.6); JPEGs come from every decoder as stored.
    const bool tiff = header->format == ImageFormat::Tiff;
    CameraImage image = decode_camera_image(path, bytes, *header);
    if (as_stored)
      image = tiff ? stored_from_display(std::move(image), header->orientation) : std::move(image);
    else
      image = turned_for_display(std::move(image), tiff ? 1 : header->orientation);
    image.orientation = header->orientation;
    return image;
  });
}

std::string mirror_ball_text(const std::array<double, 3>& ball) {
  return fmt::format("{:.17g} {:.17g} {:.17g}", ball[0], ball[1], ball[2]);
}

CameraImage turned_as_shown(CameraImage stored, int orientation) {
  return turned_for_display(std::move(stored), orientation);
}

RgbImage turned_back_to_sensor(RgbImage shown) {
  if (shown.orientation == 1) return shown;
  // Every EXIF orientation is its own inverse but the quarter turns, 6 and 8.
  const int inverse = shown.orientation == 6 ? 8 : shown.orientation == 8 ? 6 : shown.orientation;
  CameraImage c;
  c.width = shown.width, c.height = shown.height, c.rgb = std::move(shown.rgb), c.valid = std::move(shown.valid);
  if (shown.mirror_ball) shown.mirror_ball = mirror_ball_as_shown(*shown.mirror_ball, inverse, c.width, c.height);
  c = turned_as_shown(std::move(c), inverse);
  shown.width = c.width, shown.height = c.height, shown.rgb = std::move(c.rgb), shown.valid = std::move(c.valid);
  shown.orientation = 1;
  return shown;
}

CameraImage read_camera_image(const std::string& path, bool as_stored) {
  return camera_image_from_bytes(path, guarded(path, "read", [&] { return read_whole_file(path); }), as_stored);
}

std::pair<int, int> camera_image_size(const std::string& path, int* orientation) {
  const std::string bytes = guarded(path, "read", [&] { return read_whole_file(path); });
  return guarded(path, "read", [&] {
    if (bytes.empty()) fail(path, "cannot read: empty file");
    const auto header = read_image_header(path, bytes);
    if (!header) fail(path, "unsupported camera image format (expected PNG, JPEG, TIFF, PNM or BMP)");
    check_image_size(path, header->width, header->height);
    const int w = int(header->width), h = int(header->height);
    if (orientation) *orientation = header->orientation >= 1 && header->orientation <= 8 ? header->orientation : 1;
    // Orientations 5-8 exchange rows and columns (turned_for_display; OpenCV turns TIFFs alike).
    return header->orientation >= 5 ? std::pair{h, w} : std::pair{w, h};
  });
}

void make_output_directory(const std::string& dir) {
  std::error_code ec;
  std::filesystem::create_directories(dir, ec);
  if (ec) throw InputError(fmt::format("{}: cannot create the output directory: {}", dir, ec.message()));
}

void write_file_atomically(const std::string& path, const std::string& bytes) {
  auto error = [&](int err) {
    end_if_interrupted();  // the temp file went because a signal is ending the process: no error for that
    return InputError(fmt::format("{}: cannot write: {}", path, std::strerror(err)));
  };
  std::random_device rd;
  std::string tmp;
  // Created and registered in one step, so a signal never finds it unregistered (core/interrupt.h).
  const int fd = create_registered_temp_file(
      [&] {
        static constexpr char kChars[] = "abcdefghijklmnopqrstuvwxyz0123456789";
        std::string name = path + ".tmp-";
        uint32_t r = rd();
        for (int k = 0; k < 6; ++k, r /= 36) name += kChars[r % 36];
        return name;
      },
      tmp);
  if (fd < 0) throw error(errno);
  struct Unregister {
    const std::string& path;
    ~Unregister() { unregister_temp_file(path); }
  } unregister{tmp};
  size_t done = 0;
  while (done < bytes.size()) {
    const ssize_t n = ::write(fd, bytes.data() + done, bytes.size() - done);
    if (n < 0) {
      if (errno == EINTR) continue;
      const int err = errno;
      ::close(fd);
      ::unlink(tmp.c_str());
      throw error(err);
    }
    done += size_t(n);
  }
  if (::close(fd) != 0) {
    const int err = errno;
    ::unlink(tmp.c_str());
    throw error(err);
  }
  if (std::rename(tmp.c_str(), path.c_str()) != 0) {
    const int err = errno;
    ::unlink(tmp.c_str());
    throw error(err);
  }
}

}  // namespace lp
