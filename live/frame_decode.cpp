#include "live/frame_decode.h"

#include <fmt/format.h>

#include "core/error.h"
#include "hdr/log_sensor.h"

namespace lp {

const char* to_string(FrameDecode decode) {
  switch (decode) {
    case FrameDecode::Relative: return "relative";
    case FrameDecode::Linear: return "linear";
    case FrameDecode::LogSensor: return "log-sensor";
  }
  return "?";
}

FrameDecode plan_frame_decode(const FrameDecodeSetup& s) {
  if (!s.photometric) return FrameDecode::Relative;
  if (!s.photometric->log_sensor) return FrameDecode::Linear;
  const std::string file = s.photometric_file.empty() ? "--photometric" : s.photometric_file;
  if (s.exposures > 1)
    throw InputError(fmt::format("{}: a log-sensor calibration decodes single frames; a bracket of {} exposures cannot be decoded",
                                 file, s.exposures));
  if (s.response) throw InputError(file + ": a log-sensor calibration is its own response curve; --response cannot go with it");
  if (s.frames_are_maps) throw InputError(file + ": a log-sensor calibration decodes raw codes; frames that are maps (--maps) have none");
  return FrameDecode::LogSensor;
}

std::optional<std::string> undecodable_frame(const CameraFrame& frame, FrameDecode decode) {
  if (decode == FrameDecode::LogSensor && (frame.pixel_format == "RGBFloat" || frame.image.units == Units::Radiance))
    return fmt::format("frame {} is float radiance, not the raw codes a log-sensor calibration decodes", frame.sequence);
  return std::nullopt;
}

void decode_single_frame(CameraFrame& frame, FrameDecode decode, const PhotometricCalibration* photometric) {
  if (decode != FrameDecode::Relative && !photometric) throw InputError("decode_single_frame: no photometric calibration");
  if (decode == FrameDecode::LogSensor) {
    if (auto why = undecodable_frame(frame, decode)) throw InputError(*why);
    frame.image = decode_log_sensor(frame.image, *photometric);
    return;
  }
  if (frame.exposure_s > 0)
    for (float& v : frame.image.rgb) v = float(v / frame.exposure_s);
  if (decode == FrameDecode::Linear) apply_photometric(frame.image, *photometric);
}

}  // namespace lp
