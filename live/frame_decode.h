// How the stream turns a camera frame into radiance, and what it refuses to decode.
//
// One unit everywhere: with a photometric calibration every map the stream publishes is
// in Units::Radiance (683 Y = cd m^-2), whichever sensor delivered it:
//   linear sensor   code / exposure (when the frame knows it), times the calibration's
//                   scale_rgb; brackets are fused first (hdr/merge.h), then scaled;
//   log sensor      (a calibration with a log curve, calib/photometric.h) one frame per
//                   map, each channel decoded by the curve to cd m^-2, times scale_rgb
//                   (hdr/log_sensor.h): no exposure division (the curve already maps the
//                   code to luminance) and no bracket.
// Anything else is refused with a one-line InputError, never treated as linear: at start
// for options that cannot work together, at the first frame for a frame the decode
// cannot read (see below).
#pragma once

#include <optional>
#include <string>

#include "calib/photometric.h"
#include "core/image_io.h"
#include "hdr/response.h"
#include "probe/camera_source.h"

namespace lp {

struct CodeTable;  // probe/camera_codes.h

enum class FrameDecode { Relative, Linear, LogSensor };
// "relative" (no calibration: codes / exposure, relative units), "linear", "log-sensor".
const char* to_string(FrameDecode decode);

// What a stream's options ask the decode to do, checked before anything starts.
struct FrameDecodeSetup {
  const PhotometricCalibration* photometric = nullptr;  // null: relative units
  std::string photometric_file;   // named in errors
  size_t exposures = 0;           // the bracket's exposure count (0 or 1: single frames)
  bool response = false;          // a response curve was given
  bool frames_are_maps = false;   // the source delivers environment maps (radiance)
};
// The decode for these options. InputError, naming the calibration file, for a log-sensor
// calibration with a bracket, with a response curve or with frames that are maps already
// (radiance has no codes to decode).
FrameDecode plan_frame_decode(const FrameDecodeSetup& setup);

// Why a frame cannot be decoded so, or nullopt: a log-sensor decode needs raw codes, and a
// float frame (RGBFloat: radiance replayed from .exr/.hdr/.pfm) has none.
std::optional<std::string> undecodable_frame(const CameraFrame& frame, FrameDecode decode);

// The bit depth of a frame's codes from its pixel format's name (Mono8 8, Mono12 12,
// BayerRG16 16, RGB8 8), 0 for float frames (RGBFloat) or a name without a trailing depth.
int pixel_format_bits(const std::string& pixel_format);

// What a frame's codes are divided by to give radiance: its exposure time (1 when unknown)
// times its analogue gain 10^(gain_db / 20). The gain counts: libcamera's auto-exposure
// raises it in a dim room frame by frame, and a map divided by the time alone jumped by that
// factor, as did a photometric k used at another gain than it was fitted at.
double frame_exposure(const CameraFrame& frame);

// A single frame (no bracket) to radiance, in place, as described above; `photometric` is
// required for Linear and LogSensor. With `response` (stream --response, from hdr response)
// a linear decode first maps each code through the camera's curve (exp g(z)), as the bracket
// fusion does; its levels must be the frame's 2^bits, else InputError. Without it the codes
// are taken as linear. (Until stop 36 a single-exposure stream ignored --response.)
// `table`, when given, keeps the response's per-level table between frames: built at the
// first frame (or when the bit depth changes), then reused (probe/camera_codes.h). It belongs
// to one response: a caller that changes the response starts a new table.
void decode_single_frame(CameraFrame& frame, FrameDecode decode, const PhotometricCalibration* photometric,
                         const CameraResponse* response = nullptr, CodeTable* table = nullptr);

}  // namespace lp
