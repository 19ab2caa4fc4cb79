// Reading and writing environment maps and camera images. The only module that touches
// image files; every write goes to a temporary file beside the target and is renamed
// into place, so a failed write leaves nothing behind.
//
// Map formats, chosen by file extension:
//   .exr  OpenEXR, float or half RGB(A); attributes "lightprobe.layout",
//         "lightprobe.units", "lightprobe.nside" and "lightprobe.world_from_probe" (9 numbers,
//         row-major, in a string: EnvMap::world_from_probe) carry the metadata, and
//         "lightprobe.vignetting" = "corrected" EnvMap::vignetting_corrected, and
//         "lightprobe.exif_orientation" (int) EnvMap::exif_orientation when not 1, and
//         "lightprobe.mirror_ball" = "cx cy r" EnvMap::mirror_ball (a registered ball photo).
//         Reads R,G,B or Y (grey, or Y/RY/BY luminance-chroma) channels of any pixel type,
//         or, in a file without them, its one layer that has R,G,B ("ViewLayer.Combined.R"
//         of a Blender render; two such layers are refused); a multi-part file's first part,
//         with a warning.
//         The validity mask is channel "A" (1 valid, 0 invalid): written only when the
//         map's mask is non-empty, read as the mask only when the file also carries
//         "lightprobe.layout" (a foreign RGBA file's alpha is coverage, not a mask).
//         Lossy codecs (DWAA/DWAB/B44) ring: their negative values are clamped to 0 on
//         read. Writing half refuses values above 65504 rather than turning them to Inf.
//   .hdr  Radiance RGBE, reads flat and run-length (new and old) scanlines; writes RLE.
//         Metadata as header lines "LIGHTPROBE_LAYOUT=..." / "LIGHTPROBE_UNITS=..." /
//         "LIGHTPROBE_NSIDE=..." / "LIGHTPROBE_WORLD_FROM_PROBE=" and 9 numbers, row-major /
//         "LIGHTPROBE_VIGNETTING=corrected" / "LIGHTPROBE_EXIF_ORIENTATION=n" /
//         "LIGHTPROBE_MIRROR_BALL=cx cy r".
//         Pixels decode as m 2^(e-136) (as OpenCV, stb_image), divided by the product of
//         EXPOSURE (and COLORCORR) lines. Only the "-Y H +X W" orientation and
//         FORMAT=32-bit_rle_rgbe are read; XYZE is refused.
//   .pfm  Portable float map (colour "PF" and grey "Pf", either byte order; the scale's
//         magnitude is ignored, as most readers do). PFM carries no metadata: the layout
//         is inferred from the size on read, the units read back as relative and the probe
//         rotation is not kept; a map whose vignetting was corrected, or a photo turned by
//         its EXIF Orientation, is refused.
//   .tif  Read only: floating-point TIFFs (32-bit IEEE or LogLuv, panorama stitchers' HDR
//         output) through OpenCV; alpha as an EXR's. Integer TIFFs are camera codes: refused.
// .hdr and .pfm cannot hold a mask: writing a map with invalid pixels to them throws.
// A healpix map is stored as an image nside wide and 12 nside tall whose pixels, read row
// by row from the top, are the NESTED pixels in order (CONVENTIONS.md: 12 nside^2 pixels,
// NESTED order): pixel p at row p / nside, column p % nside, so face f fills rows
// [f nside, (f+1) nside). One row or one column of 12 nside^2 pixels reads the same way.
// With no layout in the file: W = 2H latlong, 12 W = H (W a power of two) or 12 nside^2
// x 1 healpix, W = 4H hemisphere, other shapes refused. Headers are checked against core/limits.h first.
//
// All failures throw InputError naming the path and the problem.
#pragma once

#include <array>
#include <optional>
#include <string>
#include <utility>
#include <vector>

#include "core/envmap.h"
#include "core/healpix.h"  // the NESTED scheme of the healpix file layout below

namespace lp {

struct ReadMapOptions {
  // Overrides the layout recorded in (or inferred from) the file.
  std::optional<Layout> layout;
  // Reject NaN, Inf and negative pixels (the default): maps are radiance. Slight negatives
  // (at most 1 % of a channel's power: out-of-gamut colours, noise below black) are read as 0
  // instead, with a warning, where a warning sink is installed (core/warnings.h).
  bool reject_bad_pixels = true;
};
EnvMap read_envmap(const std::string& path, const ReadMapOptions& options = {});

enum class ExrPixelType { Half, Float };
struct WriteMapOptions {
  ExrPixelType exr_pixel_type = ExrPixelType::Float;
  // False for plain images that are not maps (write_rgb_image sets it).
  bool record_layout = true;
};
void write_envmap(const std::string& path, const EnvMap& map, const WriteMapOptions& options = {});
// The bytes write_envmap writes to a .exr file, in memory (OpenEXR's memory stream, no
// temporary file): for servers. InputError as write_envmap, naming "EXR in memory".
std::string encode_envmap_exr(const EnvMap& map, const WriteMapOptions& options = {});

// Camera images (8/16-bit PNG, JPEG, TIFF via OpenCV) as linear-in-code float RGB in
// [0, 1] (no response curve applied), row-major, 3 floats per pixel, turned as the file's
// EXIF Orientation says (JPEG and TIFF): the picture as viewers, OpenCV's imread and LibRaw
// show it, so that a phone held upright gives an upright mirror ball and `width` and
// `height` are the turned size.
struct CameraImage {
  int width = 0, height = 0;
  int bit_depth = 8;
  std::vector<float> rgb;
  int orientation = 1;  // the EXIF Orientation the pixels were turned by (1: read as stored)
  bool grey = false;    // stored as one channel (repeated into three here)
  // Empty: every pixel holds data. Else 0 where the file's alpha is below half (a frame
  // warped by a registration tool, Hugin's align_image_stack: no data there, not black).
  std::vector<uint8_t> valid;
  // A PNG's tEXt "lightprobe.mirror_ball" (cx cy r, as EnvMap::mirror_ball): where `probe
  // register` put the ball, turned with the pixels.
  std::optional<std::array<double, 3>> mirror_ball;
};
// `as_stored`: the pixels as stored, not turned as the file's EXIF Orientation says (what a
// sensor saw where the orientation is noise: a camera pointing up; `orientation` still says
// what the file records).
CameraImage read_camera_image(const std::string& path, bool as_stored = false);
// A camera image read as stored, turned as EXIF `orientation` tells viewers to show it (what
// read_camera_image does unless as_stored).
CameraImage turned_as_shown(CameraImage stored, int orientation);
// The width and height read_camera_image gives (as its EXIF Orientation shows the image),
// from the header alone: no decode (a 24 MP JPEG's is ~0.2 s). InputError as it would.
// `orientation`, when given, receives the EXIF Orientation it is turned by (1: as stored).
std::pair<int, int> camera_image_size(const std::string& path, int* orientation = nullptr);
// A point (pixel centres at integers) of an image shown as EXIF `orientation` (1-8) turns it,
// as read_camera_image gives it, in the stored image of stored_width x stored_height; and
// back. The same map read_camera_image turns the pixels by (tests/core/image_io_test.cpp).
std::array<double, 2> stored_from_shown(int orientation, int stored_width, int stored_height, std::array<double, 2> shown);
std::array<double, 2> shown_from_stored(int orientation, int stored_width, int stored_height, std::array<double, 2> stored);
// For a message about camera images of different sizes: when one is the other turned 90
// degrees, " (...)" saying that images are read as their EXIF Orientation says and that one
// set needs one orientation; else empty.
std::string turned_size_hint(int width, int height, int other_width, int other_height);
// Radiance images that are not maps yet (a fused bracket, a mirror-ball or fisheye photo):
// float RGB, top row first, 3 floats per pixel, optional validity mask, units.
struct RgbImage {
  int width = 0, height = 0;
  std::vector<float> rgb;
  std::vector<uint8_t> valid;  // empty: every pixel valid
  Units units = Units::Relative;
  // > 0: `rgb` holds a camera image's code values in [0, 1] at this bit depth (8 or 16),
  // not radiance; whoever makes a map of it linearises them (probe/camera_codes.h).
  int code_bits = 0;
  // A camera image's EXIF Orientation as recorded (read_camera_image; applied unless read
  // as stored); a radiance file's: the turn it was shown by from the sensor's frame, as
  // EnvMap::exif_orientation (a bracket fused as its frames' tags showed it).
  int orientation = 1;
  bool vignetting_corrected = false;  // as EnvMap's, recorded in .exr and .hdr files
  std::optional<std::array<double, 3>> mirror_ball;  // as EnvMap's: .exr, .hdr and PNG record it
};
// A radiance image shown turned by EXIF `orientation` (RgbImage::orientation, as hdr fuse
// records it) turned back to the sensor's frame; orientation 1 after.
RgbImage turned_back_to_sensor(RgbImage shown);
// .exr/.hdr/.pfm as stored (NaN/Inf/negative refused); 8/16-bit formats as code values
// in [0, 1] (read_camera_image, `as_stored` as there).
RgbImage read_rgb_image(const std::string& path, bool as_stored = false);
// .exr/.hdr/.pfm without a layout record; atomic like every writer.
void write_rgb_image(const std::string& path, const RgbImage& image, const WriteMapOptions& options = {});

// The name of a recorded mirror ball (EnvMap::mirror_ball) in EXR attributes and PNG tEXt
// chunks, and its text there: "cx cy r", 17 significant digits each.
inline constexpr const char* kMirrorBallKey = "lightprobe.mirror_ball";
std::string mirror_ball_text(const std::array<double, 3>& ball);

// Writes code values in [0, 1] as an 8- or 16-bit PNG (or TIFF by extension), exactly as a
// camera would store them (no colour encoding applied), atomically. For synthetic frames and
// registered photos: a PNG records image.mirror_ball as tEXt "lightprobe.mirror_ball".
void write_code_image(const std::string& path, const RgbImage& image, int bit_depth);

// 8-bit sRGB PNG/JPEG of already tone-mapped RGB in [0, 1] (overlays, charts).
void write_display_image(const std::string& path, int width, int height, const std::vector<float>& rgb);

// Write `bytes` to `path` through a temporary file and rename (text outputs: JSON, CSV, SVG).
void write_file_atomically(const std::string& path, const std::string& bytes);
// Creates `dir` and its parents (an output directory); InputError naming it on failure.
void make_output_directory(const std::string& dir);


}  // namespace lp
