// Alignment of hand-held exposure brackets: every frame is warped onto the reference
// frame (the middle exposure), so a merger sees the same scene point at the same pixel.
//
// Two methods, both OpenCV's:
//   Mtb  median threshold bitmaps (Ward 2003, cv::AlignMTB::calculateShift) on 8-bit
//        greyscale: integer translation only, insensitive to exposure, robust to large
//        shifts (up to max_shift_px).
//   Ecc  enhanced correlation coefficient (Evangelidis & Psarakis 2008, cv::findTransformECC),
//        started from the Mtb shift, on exposure-normalised log luminance: sub-pixel
//        translation, or translation + rotation (euclidean) when `rotation` is set.
//        The log luminance of each frame is (code^2.2) / t, clamped per pair of frames to
//        the radiance range both frames can represent, so clipped highlights and crushed
//        shadows look the same in both and do not pull the fit.
//        When ECC does not converge (or wanders beyond max_shift_px) the frame keeps its
//        Mtb shift and AlignReport::ecc_converged says so.
//
// Pixels of the aligned frames that came from outside the original frame (or from its
// invalid pixels) are marked invalid in RgbImage::valid; every aligned frame therefore
// carries a mask when any pixel moved (the reference is returned unchanged).
#pragma once

#include <array>
#include <cstddef>
#include <cstdint>
#include <optional>
#include <vector>

#include "core/image_io.h"

namespace lp {

struct AlignOptions {
  enum class Method { Mtb, Ecc };
  Method method = Method::Mtb;
  // Largest translation searched, in pixels. Mtb searches up to 2^ceil(log2(max+1)) - 1 px,
  // but no further than its coarsest level allows (short side / 8 px, so 31 px for a
  // 320 px frame); a shift found beyond max_shift_px throws InputError. 0: 2.5 % of the
  // frames' long side, at least 32 px (default_max_shift_px): a hand's shake is an angle,
  // so its pixels grow with the frame (a fixed 32 px refused a 2048x2600 bracket that moved
  // 55 px, a shift of 27 px at 1280).
  int max_shift_px = 0;
  // Ecc only: also estimate an in-plane rotation (MOTION_EUCLIDEAN instead of
  // MOTION_TRANSLATION). Ignored by Mtb.
  bool rotation = false;
  // Pixels of exactly this 8-bit colour (registration borders: pure blue in Debevec's
  // Memorial set), like a frame's invalid pixels, take no part in the match: their edges
  // moved with each frame's border and Mtb locked onto them (Memorial 0066/0068/0070:
  // "moved by (33, 17) px" on registered frames).
  std::optional<std::array<uint8_t, 3>> ignore_colour;
};

struct AlignReport {
  // Per input frame, the motion of its content relative to the reference:
  // frame(R(angle) p + (dx, dy)) ~ reference(p), p in pixels with the origin at the top-left
  // pixel's centre (OpenCV's convention). A frame moved 3 px right has dx = +3.
  // The reference's entry is {0, 0, 0}.
  std::vector<std::array<double, 3>> shift_per_frame;
  // Per input frame: true when ECC refined it (Ecc) and always true for the reference;
  // false where Ecc fell back to the Mtb shift. All true for Mtb.
  std::vector<bool> ecc_converged;
  size_t reference = 0;  // index of the reference frame
  double seconds = 0;    // wall time of align_frames
};

// AlignOptions::max_shift_px's automatic value for frames of this size.
int default_max_shift_px(int width, int height);

// Index of the middle exposure (the median of exposure_seconds; the shorter of the two
// middle ones for an even count). The reference of alignment and ghost removal.
size_t middle_exposure_index(const std::vector<double>& exposure_seconds);

// Aligns `frames` (code values in [0, 1], as read by read_camera_image) onto the middle
// exposure. Throws InputError when the frames are empty, differ in size, or their count
// does not match exposure_seconds, or an exposure is not positive.
// `report` may be null.
std::vector<RgbImage> align_frames(const std::vector<RgbImage>& frames,
                                   const std::vector<double>& exposure_seconds,
                                   const AlignOptions& options = {}, AlignReport* report = nullptr);

}  // namespace lp
