// Photometric calibration: the camera's absolute scale from readings of known luminance
// (grey patches measured with a luminance meter, cd m^-2) or illuminance (a lux meter
// beside an upward camera, lux), and for logarithmic sensors the curve value = a + b ln L.
//
// Model (linear cameras). The camera gives relative luminance Y_rel (Y of CONVENTIONS.md,
// 0.2126 R + 0.7152 G + 0.0722 B of the linear values). One factor k maps it to
// photometric units:  L [cd m^-2] = k * Y_rel.
// A lux reading compares with the irradiance the map gives, E_rel = integral of Y_rel cos(theta)
// over the upper hemisphere (relative_illuminance below). Since lux = lm m^-2 = cd sr m^-2,
// E [lux] = integral of L cos dw = integral of k Y_rel cos dw = k E_rel: the same k fits
// both kinds of reading, and they can be mixed in one fit.
//
// Fit: robust least squares (Ceres, Huber or Cauchy loss) on the log ratio
// r_i = ln(predicted_i / measured_i), i.e. a relative error (r = 0.05 is 5 %), on the
// parameter ln k (so its standard error is the relative standard error of k).
//   uncertainty   ceres::Covariance of the parameters, scaled by the residual variance
//                 s^2 = 2 cost / (n - p) (Ceres' covariance assumes unit-variance residuals)
//   held-out      leave-one-out: refit without reading i, predict it; RMS of the relative
//                 errors predicted/measured - 1
// A fit needs p + 1 readings (p parameters: 1 for the scale, 2 for a log sensor): p to fit,
// one more for the uncertainty and the held-out check. Fewer throw InputError.
//
// Per-channel radiance. A luminance or lux meter sees only Y, so the per-channel scale is
// the same for R, G and B (the camera's white balance is trusted):
//   scale_rgb[c] = k / 683   [W sr^-1 m^-2 per relative unit]
// using the maximum luminous efficacy 683 lm/W (monochromatic 555 nm). A map so scaled has
// units Radiance: its channels are "photopically weighted" watts, and 683 * Y of a pixel is
// its luminance in cd m^-2. (Radiance's RGBE tools use 179 lm/W, the efficacy of equal-energy
// white light, for the same purpose: divide by 179 instead of 683 to compare with them.)
//
// Log sensors (Havran et al. 2005, section 5.1: six grey patches): the camera value v is the
// raw code of a patch and v = a + b ln(L / (1 cd m^-2)); the fit gives a and b (and their
// standard errors) with the same robust loss on r_i = (v_i - a)/b - ln(measured_i), the log
// ratio of decoded to measured luminance. Decoding L = exp((v - a)/b) already yields cd m^-2,
// so such a calibration has scale_luminance = 1, and its scale_rgb = 1/683 turns the decoded
// cd m^-2 into Radiance units like any calibrated map (hdr/log_sensor.h decode_log_sensor;
// one unit everywhere: 683 Y = cd m^-2). Log-sensor fits take cd m^-2 readings only.
//
// Readings file (CSV, UTF-8; read_readings_csv):
//   # comment lines and blank lines are ignored
//   region,camera_value,measured,unit            <- this header, first non-comment line
//   patch-1,0.0213,48.2,cd/m2                    <- label, Y_rel (or raw code), meter value
//   "probe.exr:120,80,16,16",,51.0,cd/m2         <- an image region x,y,w,h (quote it: it has
//                                                   commas); camera_value empty: the mean Y_rel
//                                                   of the region, filled by resolve_regions
//   sky,2.35,18500,lux                           <- camera_value is E_rel of the upper hemisphere
// Units (case-insensitive): cd/m2, cd/m^2, cd m-2, nit, nits  |  lux, lx.
// Labels (the region text) must be unique. Values must be finite and > 0. Errors name the
// file and line: "readings.csv:4: measured value -3 is not positive".
#pragma once

#include <array>
#include <optional>
#include <string>
#include <vector>

#include "core/envmap.h"
#include "core/image_io.h"
#include "core/vec3.h"

namespace lp {

// kLuminousEfficacy (683 lm/W, core/envmap.h) turns luminance into per-channel radiance.

struct ImageRegion {
  std::string image;  // path as written in the CSV (relative to the CSV's folder)
  int x = 0, y = 0, width = 0, height = 0;
};

struct PhotometricReading {
  enum class Unit { CandelaPerSquareMetre, Lux };
  // Relative luminance Y_rel of the patch (cd/m2 readings), relative illuminance E_rel of
  // the map (lux readings), or the raw code (log sensors). NaN until a region is resolved.
  double camera_value = 0;
  double measured = 0;  // meter reading in `unit`
  Unit unit = Unit::CandelaPerSquareMetre;
  std::string label;                  // unique; the region text for image regions
  std::optional<ImageRegion> region;  // set when the label is "image:x,y,w,h"
  std::string source;                 // "file.csv:7" for messages; empty for readings built in code
  // > 0: camera_value is the mean code of an 8- or 16-bit camera image's region (what a log
  // sensor's fit reads), not relative radiance; a linear fit refuses it.
  int code_bits = 0;
};

enum class RobustLoss { None, Huber, Cauchy };

struct PhotometricOptions {
  enum class Model { Linear, LogSensor };
  Model model = Model::Linear;
  RobustLoss loss = RobustLoss::Huber;
  // Scale of the loss in the log-ratio residual: residuals beyond ~5 % count less.
  double loss_scale = 0.05;
};

struct LogSensorCurve {
  double a = 0, b = 1;              // value = a + b ln(L / cd m^-2)
  double sigma_a = 0, sigma_b = 0;  // standard errors
};

struct PhotometricResidual {
  std::string label;
  double predicted = 0;  // in the reading's unit, from the fit on all readings
  double measured = 0;
  double relative = 0;   // predicted / measured - 1
  double held_out_relative = 0;  // the same, predicted by the fit without this reading
};

struct PhotometricCalibration {
  double scale_luminance = 1;  // k: cd m^-2 per relative luminance unit (1 for log sensors)
  std::array<double, 3> scale_rgb{1 / kLuminousEfficacy, 1 / kLuminousEfficacy,
                                  1 / kLuminousEfficacy};  // k / 683 per channel
  double scale_relative_error = 0;  // relative standard error of k (0 for log sensors)
  std::optional<LogSensorCurve> log_sensor;
  std::vector<PhotometricResidual> residuals;
  double rms_relative = 0;           // RMS of residuals[].relative
  double max_abs_relative = 0;
  double held_out_rms_relative = 0;  // leave-one-out RMS of residuals[].held_out_relative
  int readings = 0;
  std::string loss;       // "huber", "cauchy", "none"
  double loss_scale = 0;
};

// Parses a readings file (format above). Region readings keep camera_value NaN.
std::vector<PhotometricReading> read_readings_csv(const std::string& path);
// Fills camera_value of region readings with mean_luminance_in_region of the image, read
// with read_rgb_image from `base_dir` (the CSV's folder when empty and the reading's
// source names a file), and code_bits from the image. Throws InputError naming the
// reading's file:line, also when a camera image's region holds clipped codes.
void resolve_regions(std::vector<PhotometricReading>& readings, const std::string& base_dir = "");

// Mean relative luminance Y over the valid pixels of a rectangle (x, y its top-left corner).
// Throws InputError when the rectangle leaves the image or holds no valid pixel.
double mean_luminance_in_region(const RgbImage& image, int x, int y, int width, int height);
// Pixels of the rectangle with a channel at the top code or all channels at code 0 (a
// camera image's codes, code_bits > 0): their true value is unknown, so a mean over them is
// biased. 0 for radiance images.
size_t clipped_codes_in_region(const RgbImage& image, int x, int y, int width, int height);
// E_rel = sum over valid pixels of Y max(0, n . d) dw: the relative illuminance on a surface
// with normal n (default straight up), to compare with a lux meter. Invalid pixels count
// as dark, so a map with holes gives a lower bound.
double relative_illuminance(const EnvMap& map, Vec3 normal = {0, 0, 1});

// Fits the calibration. Throws InputError on bad readings (non-finite or non-positive
// values, duplicate labels, lux readings for a log sensor, too few readings).
PhotometricCalibration fit_photometric(const std::vector<PhotometricReading>& readings,
                                       const PhotometricOptions& options = {});

// JSON ("format": "lightprobe.photometric/1"), written atomically.
void save_photometric(const std::string& path, const PhotometricCalibration& calibration);
PhotometricCalibration load_photometric(const std::string& path);

// Multiplies channel c by scale_rgb[c] and sets units = Radiance. The input must be linear
// relative radiance; an image already in Radiance units throws InputError (the scale would
// apply twice), and so does a log-sensor calibration (its codes are decoded, not scaled:
// hdr/log_sensor.h decode_log_sensor, which ends in the same scale_rgb).
void apply_photometric(RgbImage& image, const PhotometricCalibration& calibration);
void apply_photometric(EnvMap& map, const PhotometricCalibration& calibration);

}  // namespace lp
