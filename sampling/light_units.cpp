#include "sampling/light_units.h"

#include <fmt/format.h>

#include <cmath>

#include "core/error.h"
#include "sampling/exporters.h"

namespace lp {

double upward_illuminance(const LightList& list) {
  std::array<double, 3> e{0, 0, 0};
  for (const Light& l : list.lights)
    for (int c = 0; c < 3; ++c) e[c] += l.rgb[c] * std::max(0.0, l.direction.z);
  if (list.sh9 && list.sh9_content == Sh9Content::Residual) {
    const auto a = sh9_irradiance(*list.sh9, {0, 0, 1});
    for (int c = 0; c < 3; ++c) e[c] += a[c];
  }
  return luminance(e.data()) * (list.units == Units::Radiance ? kLumensPerWatt : 1.0);
}

void check_light_units_options(const LightUnitsOptions& options) {
  const int given = int(options.exposure_ev.has_value()) + int(options.scale.has_value()) +
                    int(options.normalize_illuminance_lux.has_value());
  if (given > 1) throw InputError("--exposure, --scale and --normalize-illuminance: give at most one");
  if (options.exposure_ev && !std::isfinite(*options.exposure_ev))
    throw InputError(fmt::format("--exposure must be a finite number of stops, got {}", *options.exposure_ev));
  if (options.scale && (!(*options.scale > 0) || !std::isfinite(*options.scale)))
    throw InputError(fmt::format("--scale must be positive, got {}", *options.scale));
  if (const auto& lux = options.normalize_illuminance_lux; lux && (!(*lux > 0) || !std::isfinite(*lux)))
    throw InputError(fmt::format("--normalize-illuminance must be a positive illuminance in lux, got {}", *lux));
}

LightUnitsResult apply_light_units(LightList list, const LightUnitsOptions& options, const std::string& output) {
  check_light_units_options(options);
  const int given = int(options.exposure_ev.has_value()) + int(options.scale.has_value()) +
                    int(options.normalize_illuminance_lux.has_value());
  LightUnitsResult r;
  if (given == 0) {
    if (list.units == Units::Relative)
      r.warning = fmt::format(
          "{}: relative units written as they are (not lux or W m^-2): calibrate the map, or give --exposure, "
          "--scale or --normalize-illuminance",
          output);
    r.list = std::move(list);
    return r;
  }
  // They give a relative list its unit: on a calibrated map, --scale 3 tripled lights already
  // in W sr^-1 m^-2 without a word.
  if (list.units == Units::Radiance)
    throw InputError(fmt::format("{}: the map is in radiance units already (calibrated); --exposure, --scale and "
                                 "--normalize-illuminance give a relative map its unit",
                                 output));
  if (options.exposure_ev) {
    r.factor = std::exp2(*options.exposure_ev);
  } else if (options.scale) {
    r.factor = *options.scale;
  } else {
    const double lux = *options.normalize_illuminance_lux;
    // The target is reached in "radiance" units, where 683 Y is lux.
    LightList probe = list;
    probe.units = Units::Radiance;
    const double now = upward_illuminance(probe);
    if (!(now > 0))
      throw InputError("--normalize-illuminance: the lights give no illuminance on an upward-facing surface");
    r.factor = lux / now;
  }
  if (!(r.factor > 0) || !std::isfinite(r.factor))  // --exposure 1100 is x inf, -1100 is x 0
    throw InputError(fmt::format("{}: the unit option scales by {:g}, not a finite positive factor", output, r.factor));
  for (Light& l : list.lights)
    for (double& c : l.rgb) {
      c *= r.factor;
      if (!std::isfinite(c))
        throw InputError(fmt::format("{}: scaled by {:g}, a light's value overflows", output, r.factor));
    }
  if (list.sh9) {
    list.sh9 = scaled(*list.sh9, r.factor);
    for (const auto& coefficient : list.sh9->coefficients)
      for (double v : coefficient)
        if (!std::isfinite(v)) throw InputError(fmt::format("{}: scaled by {:g}, the SH9 overflows", output, r.factor));
  }
  // A scaled relative list is what a calibration would have given: absolute radiance.
  list.units = Units::Radiance;
  r.list = std::move(list);
  return r;
}

}  // namespace lp
