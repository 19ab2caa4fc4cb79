// Scene luminance, illuminance and light colour from one frame's camera metadata: the
// exposure the camera's auto exposure (AE) chose, its gain, aperture and white balance.
//
// Two routes to luminance, both stated for an AE that brings the frame's mean code value
// (linear, 0..1 of full scale, Y of the raw RGB) to a target, i.e. an "average-grey"
// scene metered over the whole frame (average weighting):
//
//   calibration (preferred, when `photometric_scale` k is known: `calib photometric` fits
//   it; its relative unit is code / (t g) at the calibration aperture N_cal):
//       L = k * Y_code / (t * g) * (N / N_cal)^2                           [cd m^-2]
//   meter equation (ISO 2720 reflected-light meter, no calibration):
//       L = K * N^2 / (t * S) * (Y_code / Y_target),   S = S_base * g     [cd m^-2]
//       K = 12.5 cd s m^-2 (the constant of most camera makers), S_base the ISO at gain 1.
//   The two agree when k = K N^2 / (S_base Y_target): the synthetic camera is built so.
//
// Y_code is the frame's metered mean when the track records it (`mean_code`), else the AE
// target is assumed to have been met (a camera at its exposure or gain limit breaks that:
// record mean_code wherever the camera gives it).
//
// Illuminance: E = pi * L, the illuminance on a surface facing the camera if the whole
// hemisphere in front of it had the metered luminance (a uniform field). It is what the
// seed paper calls "estimated lux"; for a real scene it is an approximation whose error
// the walk-through evaluation measures.
//
// Gain g (linear): 10^(gain_db / 20) or analog_gain, times digital_gain (default 1); or
// iso / S_base when only an ISO is given. A frame without any of them is an error: a
// missing gain is not 1.
//
// Colour (luminance-1 Rec. 709 RGB of the light; through `colour_matrix` when the camera's
// raw RGB is not Rec. 709): the brightest pixels' raw RGB when given
// (handles strongly coloured sources that are no black body), else the illuminant of the
// white-balance gains, else the black body of a reported CCT, else neutral (flagged).
#pragma once

#include <nlohmann/json_fwd.hpp>

#include <array>
#include <optional>
#include <string>
#include <vector>

namespace lp {

// What one frame says about the light; everything but exposure and one gain is optional.
struct FrameMetadata {
  double exposure_s = 0;                         // > 0, seconds
  std::optional<double> gain_db;                 // analogue gain, dB
  std::optional<double> analog_gain;             // linear (instead of gain_db)
  std::optional<double> digital_gain;            // linear, multiplies the analogue gain
  std::optional<double> iso;                     // ISO speed (instead of a gain)
  std::optional<double> f_number;                // aperture; default: the camera's
  std::optional<std::array<double, 3>> wb_gains; // white-balance gains r, g, b
  std::optional<double> cct_k;                   // CCT the camera reports (K)
  std::optional<double> mean_code;               // metered mean code value, (0, 1]
  std::optional<std::array<double, 3>> bright_rgb;  // raw RGB of the brightest pixels (> 0)
};

// The camera: how its codes relate to luminance.
struct MeteringOptions {
  std::optional<double> photometric_scale;  // k, cd m^-2 per (code / (t g)); none: meter equation
  double calibration_f_number = 0;          // N_cal; 0: the frames' aperture never changes
  double f_number = 2.0;                    // the aperture of frames that do not record one
  double ae_target = 0.18;                  // Y_target, mean code the AE aims at
  double iso_base = 100;                    // S_base, ISO at gain 1
  double meter_constant = 12.5;             // K, cd s m^-2
  // Camera raw RGB -> linear Rec. 709, row-major (a sensor's colour matrix, e.g. a DNG's
  // forward matrix composed with XYZ -> Rec. 709). Applied to the WB illuminant and the
  // brightest pixels' colour before their chromaticity is taken; none: raw RGB is Rec. 709.
  std::optional<std::array<double, 9>> colour_matrix;
};

struct LightReading {
  double luminance = 0;    // L, cd m^-2
  double illuminance = 0;  // E = pi L, lux
  double gain = 1;         // linear gain used
  std::array<double, 3> colour{1, 1, 1};  // Rec. 709, luminance 1
  double cct_k = 0;        // of `colour` (Robertson); 0 when neutral by default
  double duv = 0;
  std::string colour_from;  // "bright_rgb", "wb_gains", "cct" or "none"
  std::string route;        // "calibration" or "meter"
  // Radiance per channel in W sr^-1 m^-2 (CONVENTIONS: 683 * Y = cd m^-2).
  std::array<double, 3> radiance() const;
};

// Throws InputError starting with `source` ("track.jsonl:12") on bad metadata: exposure
// missing, zero, negative or NaN; no gain; non-positive gain, ISO, f-number or WB gain;
// mean_code outside (0, 1]; bright_rgb not positive.
LightReading meter_frame(const FrameMetadata& frame, const MeteringOptions& options, const std::string& source);

// Checks the camera options themselves (InputError naming the option).
void validate_metering(const MeteringOptions& options);

// The camera as reports and truth files record it: the metering route, f-number, AE
// target, ISO base, meter constant and the photometric scale when known.
nlohmann::json metering_json(const MeteringOptions& m);

// Nearest-rank 5th, 50th and 95th percentiles of a track's readings (zeros where there are
// none), as `estimate metadata` reports them; CCT over the readings that have one.
struct Spread {
  double p05 = 0, median = 0, p95 = 0;
  nlohmann::json to_json() const;  // {median, p05, p95}
};
struct ReadingsSpread {
  Spread luminance, illuminance, cct;
  size_t with_cct = 0;  // readings with a finite, positive colour temperature
};
ReadingsSpread readings_spread(const std::vector<LightReading>& readings);

}  // namespace lp
