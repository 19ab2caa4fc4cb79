// The largest inputs lightprobe accepts, in one place (docs/limits.md is the user's table).
// A reader checks a file's header against them before it allocates anything of the size
// the header claims; a command checks its size flags when it parses them. A refusal is an
// InputError naming the file or flag, what it asked for and the limit, and the flag that
// raises the limit where there is one.
//
// The defaults keep the heaviest command well inside a 24 GiB machine and each pass over
// the data to seconds; the CLI's global --max-pixels and --max-lights raise them for a run.
#pragma once

#include <cstdint>
#include <string>
#include <string_view>

namespace lp {

struct Limits {
  // Pixels of any image or map read, made or written (--max-pixels). 2^27 = 134 M: a
  // 16384x8192 latlong (the largest published HDRIs) or a 100 MP camera frame. One float
  // RGB copy is 1.5 GiB; the heaviest command (convert: file bytes, decoded map, resampled
  // map, encoded output) holds about five, under 8 GiB.
  uint64_t max_pixels = uint64_t(1) << 27;
  // Width or height of any image or map (no flag): JPEG's largest side; beyond it only
  // degenerate strips fit under max_pixels, and row buffers stay small.
  int max_side = 65535;
  // Lights one list may hold (--max-lights): sample's --n, stream's --n, tables' |H|.
  // A million lights take pharr about 10 s and 1.2 GB and are a 300 MB JSON file; no
  // renderer wants more directional lights than that.
  int max_lights = 1000000;
  // Cube-map LUT texels per face edge (tables and eval shading --lut, no flag): 1024 is
  // 6 M texels (0.09 deg, 25 MB of region ids), far finer than any culling region; each
  // texel searches every region centre, so the build time grows with its square.
  int max_lut = 1024;
  // Frames, views or images one command makes or reads in a run (--frames, --views; no
  // flag): 10,000 is seven minutes of video at 25 fps, and each is a file or a map held.
  int max_frames = 10000;
  // Bytes of a text input (light lists, response and camera files, CSV; no flag): 1 GiB
  // holds a million-light list three times. Checked by core/file_io.h's read_text_file,
  // through which every text reader goes.
  uint64_t max_text_file_bytes = uint64_t(1) << 30;
};

// The limits in force: the defaults above unless the CLI set others for this run.
const Limits& limits();
// Called once by the CLI after parsing, before any work; throws InputError on a zero.
void set_limits(const Limits& limits);

// Derived limits. HEALPix nside: the largest power of two with 12 nside^2 <= max_pixels
// (2048 by default, 50 M pixels). Image files: 32 bytes per allowed pixel (float RGBA
// uncompressed is 16) plus 16 MiB of headers and offset tables, 4 GiB by default.
int max_nside();
uint64_t max_image_file_bytes();

// Throw InputError "<who>: <what> WxH ... over the limit ..." when a size is beyond the
// limits; `who` is the file or the flag, `what` says what the size is ("image", "map").
void check_image_size(std::string_view who, long long width, long long height, std::string_view what = "image");
void check_nside(std::string_view who, long long nside);
void check_light_count(std::string_view who, long long count);
// A count with its own ceiling (frames, views, LUT texels): "<who>: <count> <what>, at
// most <max> (<why>)".
void check_count(std::string_view who, long long count, long long max, std::string_view what, std::string_view why);
// A file's size against a limit before reading it whole; `kind` names the limit, e.g.
// "an image (32 bytes per pixel of --max-pixels)".
void check_file_size(const std::string& path, uint64_t bytes, uint64_t max_bytes, std::string_view kind);

}  // namespace lp
