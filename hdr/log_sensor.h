// Logarithmic-response sensors (Havran et al. 2005, §5.1: an HDRC camera whose code is
// linear in the logarithm of luminance): value = a + b · ln(L), with the NATURAL
// logarithm, value a code in [0, 1] as read_camera_image gives it, L in the units of the
// luminances the model was fitted to (cd·m⁻² after photometric calibration).
//
// The robust fit of (a, b) from measured patches lives in calib/ (photometric
// calibration); this header holds the model type, its decoder and the plain closed-form
// least-squares fit that the robust one can start from.
#pragma once

#include <vector>

#include "calib/photometric.h"
#include "core/image_io.h"

namespace lp {

struct LogSensorModel {
  double a = 0.0;  // code value at L = 1
  double b = 0.0;  // code value per unit of ln(L); must be non-zero
};

// L = exp((value − a) / b) per channel; the valid mask is kept and the units are those of
// `codes` (callers decoding with a calibrated model set Units::Radiance). Throws
// InputError when b is zero or a/b are not finite.
RgbImage decode_log_sensor(const RgbImage& codes, const LogSensorModel& model);

// A log sensor's frame under its photometric calibration (calib/photometric.h with a log
// curve), in the one unit every calibrated map has: Units::Radiance, per channel
// "photopically weighted" W sr^-1 m^-2, so that 683 Y = cd m^-2. The curve decodes each
// channel to cd m^-2; that is then scaled by scale_rgb (1/683), exactly as a linear
// camera's relative values are scaled by k/683: the curve replaces the division by
// exposure, the scale to watts is the same. (Decoding alone and calling it radiance made
// a log-sensor map 683 times brighter than a linear calibrated map of the same scene.)
// InputError when the calibration has no log curve or `codes` are radiance already.
RgbImage decode_log_sensor(const RgbImage& codes, const PhotometricCalibration& calibration);

// Ordinary least squares of values on ln(luminances): b = cov(ln L, v) / var(ln L),
// a = mean(v) − b mean(ln L). Throws InputError when the sizes differ, fewer than 2
// points are given, a luminance is not positive and finite, or all luminances are equal.
LogSensorModel fit_log_sensor_least_squares(const std::vector<double>& values, const std::vector<double>& luminances);

}  // namespace lp
