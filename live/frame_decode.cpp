#include "live/frame_decode.h"

#include <fmt/format.h>

#include <algorithm>
#include <array>
#include <cctype>
#include <cmath>
#include <vector>

#include "core/error.h"
#include "hdr/log_sensor.h"
#include "probe/camera_codes.h"

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

int pixel_format_bits(const std::string& pixel_format) {
  size_t i = pixel_format.size();
  while (i > 0 && std::isdigit(static_cast<unsigned char>(pixel_format[i - 1]))) --i;
  if (i == pixel_format.size() || pixel_format.size() - i > 2) return 0;
  const int bits = std::stoi(pixel_format.substr(i));
  return bits >= 1 && bits <= 16 ? bits : 0;
}

double frame_exposure(const CameraFrame& frame) {
  const double gain = std::isfinite(frame.gain_db) ? std::pow(10.0, frame.gain_db / 20.0) : 1.0;
  return (frame.exposure_s > 0 ? frame.exposure_s : 1.0) * gain;
}

void decode_single_frame(CameraFrame& frame, FrameDecode decode, const PhotometricCalibration* photometric,
                         const CameraResponse* response, CodeTable* table) {
  if (decode != FrameDecode::Relative && !photometric) throw InputError("decode_single_frame: no photometric calibration");
  if (decode == FrameDecode::LogSensor) {
    if (auto why = undecodable_frame(frame, decode)) throw InputError(*why);
    frame.image = decode_log_sensor(frame.image, *photometric);
    return;
  }
  const int bits = pixel_format_bits(frame.pixel_format);
  if (response && bits > 0) {
    const size_t levels = size_t(1) << bits;
    if (size_t(response->levels) != levels)
      throw InputError(fmt::format("--response: its {} levels do not fit frame {}'s {}-bit codes ({}, {} levels)",
                                   response->levels, frame.sequence, bits, frame.pixel_format, levels));
    CodeTable own;
    if (!table || table->bits != bits)
      (table ? *table : own) =
          make_code_table(response_code_curve(response->log_exposure, "--response"), bits, "--response");
    const CodeTable& levels_table = table ? *table : own;
    if (const double exposure = frame_exposure(frame); exposure != 1.0) {
      // The division by the exposure folded into this frame's copy of the table: one pass
      // over the frame instead of two, the same floats (each entry divided as a code's
      // value would be).
      CodeTable scaled = levels_table;
      for (auto& channel : scaled.linear)
        for (float& v : channel) v = float(v / exposure);
      apply_code_table(frame.image.rgb.data(), frame.image.rgb.size() / 3, scaled);
    } else {
      apply_code_table(frame.image.rgb.data(), frame.image.rgb.size() / 3, levels_table);
    }
    if (decode == FrameDecode::Linear) apply_photometric(frame.image, *photometric);
    return;
  }
  if (const double exposure = frame_exposure(frame); exposure != 1.0)
    for (float& v : frame.image.rgb) v = float(v / exposure);
  if (decode == FrameDecode::Linear) apply_photometric(frame.image, *photometric);
}

}  // namespace lp
