#include "estimate/exposure_metering.h"

#include <nlohmann/json.hpp>

#include <fmt/format.h>

#include <algorithm>
#include <cmath>

#include "core/error.h"
#include "estimate/white_balance_cct.h"

namespace lp {

namespace {

constexpr double kEfficacy = 683.0;  // lm/W, as calib/photometric.h

bool positive(double v) { return std::isfinite(v) && v > 0; }

void require_positive(const std::optional<double>& v, const char* name, const std::string& source) {
  if (v && !positive(*v)) throw InputError(fmt::format("{}: {} must be finite and positive, got {}", source, name, *v));
}

// Camera RGB -> Rec. 709 (when a matrix is given), normalised to luminance 1.
std::array<double, 3> to_rec709_unit(std::array<double, 3> c, const MeteringOptions& o, const std::string& source,
                                     const char* what) {
  if (o.colour_matrix) {
    const auto& m = *o.colour_matrix;
    c = {m[0] * c[0] + m[1] * c[1] + m[2] * c[2], m[3] * c[0] + m[4] * c[1] + m[5] * c[2],
         m[6] * c[0] + m[7] * c[1] + m[8] * c[2]};
  }
  const double y = 0.2126 * c[0] + 0.7152 * c[1] + 0.0722 * c[2];
  if (!(y > 0) || !std::isfinite(y))
    throw InputError(fmt::format("{}: {} has no positive luminance after the colour matrix", source, what));
  return {c[0] / y, c[1] / y, c[2] / y};
}

}  // namespace

std::array<double, 3> LightReading::radiance() const {
  const double s = luminance / kEfficacy;
  return {colour[0] * s, colour[1] * s, colour[2] * s};
}

void validate_metering(const MeteringOptions& o) {
  if (o.photometric_scale && !positive(*o.photometric_scale))
    throw InputError(fmt::format("photometric scale must be positive, got {}", *o.photometric_scale));
  if (!(o.calibration_f_number >= 0) || !std::isfinite(o.calibration_f_number))
    throw InputError(fmt::format("--calibration-f-number must be >= 0, got {}", o.calibration_f_number));
  if (!positive(o.f_number)) throw InputError(fmt::format("--f-number must be positive, got {}", o.f_number));
  if (!positive(o.ae_target) || o.ae_target > 1)
    throw InputError(fmt::format("--ae-target must be in (0, 1], got {}", o.ae_target));
  if (!positive(o.iso_base)) throw InputError(fmt::format("--iso-base must be positive, got {}", o.iso_base));
  if (!positive(o.meter_constant))
    throw InputError(fmt::format("--meter-constant must be positive, got {}", o.meter_constant));
  if (o.colour_matrix)
    for (double v : *o.colour_matrix)
      if (!std::isfinite(v)) throw InputError("--colour-matrix must hold 9 finite numbers");
}

LightReading meter_frame(const FrameMetadata& f, const MeteringOptions& o, const std::string& source) {
  if (!positive(f.exposure_s))
    throw InputError(fmt::format("{}: exposure_s must be finite and positive, got {}", source, f.exposure_s));
  require_positive(f.analog_gain, "analog_gain", source);
  require_positive(f.digital_gain, "digital_gain", source);
  require_positive(f.iso, "iso", source);
  require_positive(f.f_number, "f_number", source);
  require_positive(f.cct_k, "cct_k", source);
  if (f.gain_db && !std::isfinite(*f.gain_db))
    throw InputError(fmt::format("{}: gain_db must be finite, got {}", source, *f.gain_db));
  if (f.mean_code && !(positive(*f.mean_code) && *f.mean_code <= 1))
    throw InputError(fmt::format("{}: mean_code must be in (0, 1], got {}", source, *f.mean_code));

  LightReading r;
  // Gain: an explicit sensor gain wins over an ISO (the ISO is derived from it anyway).
  if (f.gain_db)
    r.gain = std::pow(10.0, *f.gain_db / 20.0);
  else if (f.analog_gain)
    r.gain = *f.analog_gain;
  else if (f.iso)
    r.gain = *f.iso / o.iso_base;
  else
    throw InputError(fmt::format("{}: no gain (give gain_db, analog_gain or iso; a missing gain is not 1)", source));
  // An ISO already includes every gain stage; digital gain multiplies sensor gains only.
  if (f.digital_gain && (f.gain_db || f.analog_gain)) r.gain *= *f.digital_gain;

  const double n = f.f_number.value_or(o.f_number);
  const double code = f.mean_code.value_or(o.ae_target);
  if (o.photometric_scale) {
    const double n_cal = o.calibration_f_number > 0 ? o.calibration_f_number : n;
    r.luminance = *o.photometric_scale * code / (f.exposure_s * r.gain) * (n / n_cal) * (n / n_cal);
    r.route = "calibration";
  } else {
    const double s = o.iso_base * r.gain;
    r.luminance = o.meter_constant * n * n / (f.exposure_s * s) * (code / o.ae_target);
    r.route = "meter";
  }
  r.illuminance = M_PI * r.luminance;

  if (f.bright_rgb) {
    for (double c : *f.bright_rgb)
      if (!positive(c))
        throw InputError(fmt::format("{}: bright_rgb must be finite and positive, got [{}, {}, {}]", source,
                                     (*f.bright_rgb)[0], (*f.bright_rgb)[1], (*f.bright_rgb)[2]));
    r.colour = to_rec709_unit(*f.bright_rgb, o, source, "bright_rgb");
    r.colour_from = "bright_rgb";
  } else if (f.wb_gains) {
    r.colour = to_rec709_unit(illuminant_from_wb_gains(*f.wb_gains, source), o, source, "the white-balance illuminant");
    r.colour_from = "wb_gains";
  } else if (f.cct_k) {
    r.colour = planckian_rgb(*f.cct_k);
    r.colour_from = "cct";
  } else {
    r.colour_from = "none";
  }
  if (f.cct_k && !f.bright_rgb && !f.wb_gains) {
    r.cct_k = *f.cct_k;
  } else if (r.colour_from != "none") {
    const CctEstimate c = cct_robertson(chromaticity_of_rgb(r.colour, source.c_str()));
    r.cct_k = c.kelvin;
    r.duv = c.duv;
  }
  return r;
}

nlohmann::json metering_json(const MeteringOptions& m) {
  nlohmann::json j{{"route", m.photometric_scale ? "calibration" : "meter"},
                   {"f_number", m.f_number},
                   {"calibration_f_number", m.calibration_f_number},
                   {"ae_target", m.ae_target},
                   {"iso_base", m.iso_base},
                   {"meter_constant", m.meter_constant}};
  if (m.photometric_scale) j["photometric_scale"] = *m.photometric_scale;
  return j;
}

namespace {

Spread spread_of(std::vector<double> v) {
  if (v.empty()) return {};
  std::sort(v.begin(), v.end());
  auto at = [&](double p) { return v[std::min(v.size() - 1, size_t(p * double(v.size() - 1) + 0.5))]; };
  return {at(0.05), at(0.5), at(0.95)};
}

}  // namespace

nlohmann::json Spread::to_json() const { return {{"median", median}, {"p05", p05}, {"p95", p95}}; }

ReadingsSpread readings_spread(const std::vector<LightReading>& readings) {
  std::vector<double> lum, lux, cct;
  for (const LightReading& r : readings) {
    lum.push_back(r.luminance);
    lux.push_back(r.illuminance);
    if (r.cct_k > 0 && std::isfinite(r.cct_k)) cct.push_back(r.cct_k);
  }
  return {spread_of(lum), spread_of(lux), spread_of(cct), cct.size()};
}

}  // namespace lp
