// Environment maps: float32 linear RGB radiance over directions, in the world frame,
// with a validity mask and one of the layouts of CONVENTIONS.md:
//   latlong     W = 2H, pixel (u, v) centre: phi = 2 pi (u + 1/2) / W, theta = pi (v + 1/2) / H
//   hemisphere  W x H (default 360 x 90): phi = 2 pi (u + 1/2) / W, theta = (pi/2) (v + 1/2) / H
//   healpix     12 nside^2 pixels in NESTED order (nside a power of two), HEALPix pix2ang
// Pixel order in `rgb`: row-major for latlong/hemisphere (index = v * width + u);
// NESTED index for healpix (width = 12 nside^2, height = 1).
// Solid angles are exact, from pixel corners: for latlong/hemisphere
// dphi * (cos theta0 - cos theta1); for healpix 4 pi / (12 nside^2) (equal area).
#pragma once

#include <array>
#include <cstddef>
#include <cstdint>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include "core/vec3.h"

namespace lp {

enum class Layout { LatLong, Hemisphere, Healpix };
std::string_view to_string(Layout layout);
std::optional<Layout> layout_from_string(std::string_view name);

// Relative units, or absolute radiance (W sr^-1 m^-2 per channel; cd m^-2 for luminance)
// after photometric calibration. Files record which.
enum class Units { Relative, Radiance };
// Radiance units are photopically weighted W sr^-1 m^-2: 683 Y is cd/m2 (CONVENTIONS.md).
inline constexpr double kLuminousEfficacy = 683.0;
std::string_view to_string(Units units);
std::optional<Units> units_from_string(std::string_view name);

// Luminance of linear Rec. 709 RGB.
inline float luminance(float r, float g, float b) { return 0.2126f * r + 0.7152f * g + 0.0722f * b; }
inline double luminance(const double* rgb) { return 0.2126 * rgb[0] + 0.7152 * rgb[1] + 0.0722 * rgb[2]; }

struct EnvMap {
  Layout layout = Layout::LatLong;
  int width = 0;   // healpix: 12 nside^2
  int height = 0;  // healpix: 1
  int nside = 0;   // healpix only
  std::vector<float> rgb;      // 3 floats per pixel, radiance
  std::vector<uint8_t> valid;  // empty: every pixel valid; else one 0/1 per pixel
  Units units = Units::Relative;
  // The probe's camera-to-world rotation it was unwrapped with (CONVENTIONS.md: part of the
  // probe's metadata), recorded in the file. Metadata only: the pixels are in the world frame
  // whatever it holds, and maps made otherwise have none.
  std::optional<Mat3> world_from_probe;
  // The camera image it came from had its lens vignetting divided out (calib/vignetting.h),
  // recorded in the file so that no one divides it out twice.
  bool vignetting_corrected = false;
  // A fused photo (not a map): the EXIF Orientation (1-8) its frames were shown by, turned
  // from the sensor's frame (hdr fuse), recorded so that a fisheye, unwrapped in its sensor's
  // frame, can be turned back. 1: as the sensor stored it.
  int exif_orientation = 1;
  // A mirror-ball photo (not a map): the ball's centre and radius in its pixels (cx, cy, r;
  // the top-left pixel's centre at 0.5, 0.5, as BallInImage), where `probe register` placed
  // it, recorded so that `probe unwrap` takes it instead of searching for the rim of a ball
  // pasted on a canvas. Kept only by the photo's writers (write_rgb_image, write_code_image).
  std::optional<std::array<double, 3>> mirror_ball;

  size_t pixel_count() const { return size_t(width) * size_t(height); }
  bool is_valid(size_t i) const { return valid.empty() || valid[i] != 0; }
  const float* pixel(size_t i) const { return &rgb[3 * i]; }
  float* pixel(size_t i) { return &rgb[3 * i]; }
};

// Empty (black, all valid) maps. Throw InputError on sizes the layout does not allow
// (latlong W != 2H, healpix nside not a power of two, non-positive sizes).
EnvMap make_latlong(int width, int height);
EnvMap make_hemisphere(int width, int height);
EnvMap make_healpix(int nside);
// Dispatch by layout; for healpix `width` is nside and `height` is ignored.
EnvMap make_envmap(Layout layout, int width, int height);

// Unit direction of a pixel centre (healpix: the HEALPix pixel centre).
Vec3 pixel_direction(const EnvMap& map, size_t pixel);
// Exact solid angle of a pixel in steradians.
double pixel_solid_angle(const EnvMap& map, size_t pixel);
// Pixel containing a direction; nullopt where the layout has no pixel (the lower half
// of a hemisphere map). Does not look at the validity mask.
std::optional<size_t> pixel_at(const EnvMap& map, Vec3 direction);
// Sum of all pixel solid angles: 4 pi, or 2 pi for hemisphere.
double layout_solid_angle(Layout layout);

// Per-pixel geometry as float arrays (structure of arrays, for vectorised loops):
// direction and solid angle of every pixel. Depends only on layout and size, so one
// table serves every frame of a video.
struct PixelTable {
  std::vector<float> x, y, z, solid_angle;
};
PixelTable make_pixel_table(const EnvMap& map);

// Integral of radiance over the valid region, per channel: sum L * solid angle.
std::array<double, 3> total_power(const EnvMap& map);
double total_luminance_power(const EnvMap& map);

// First pixel with NaN, Inf or a negative value, as an InputError message prefixed by
// `source` ("file.exr: pixel (u, v) is NaN"); empty when the map is clean.
std::string find_bad_pixel(const EnvMap& map, std::string_view source);

// The negative values of a map (NaN and Inf aside, which find_bad_pixel names): how many
// pixels have one, the lowest, and the largest share over the three channels of a channel's negative power
// (sum |v| dw over valid pixels) in its positive power (infinite when that is zero).
struct NegativeValues {
  size_t count = 0;  // pixels
  float lowest = 0;
  double share = 0;
};
NegativeValues find_negative_values(const EnvMap& map);
// Sets every negative value to +0 (valid pixels or not; NaN and Inf stay).
void clamp_negative_values(EnvMap& map);

// Human-readable "latlong 1024x512" / "healpix nside 64".
std::string describe_size(const EnvMap& map);

}  // namespace lp
