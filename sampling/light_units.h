// Light lists in the units renderers expect (docs/exporters.md has the table). A list
// from a calibrated map ("radiance") is already absolute: a light's rgb is photopically
// weighted W m^-2 (calib/photometric.h), which pbrt and Mitsuba take as is and the glTF
// exporter turns into lux (x 683). A relative list has no scale; this module gives it one
// the user chooses, or says that it is exported as it is.
#pragma once

#include <optional>
#include <string>

#include "core/light_list.h"

namespace lp {

// At most one of them; none leaves the list as it is.
struct LightUnitsOptions {
  // Multiply by 2^EV (a camera's exposure compensation, as in Blender's and three.js' exposure).
  std::optional<double> exposure_ev;
  // Multiply by K: relative units -> W sr^-1 m^-2 per channel (what calib photometric finds).
  std::optional<double> scale;
  // Scale so that a surface facing straight up (+Z) receives this illuminance in lux from
  // the lights and the ambient SH9 (when the list has one), as a renderer would light it.
  std::optional<double> normalize_illuminance_lux;
};

// Illuminance in lux on an upward-facing surface that a "radiance" list gives a renderer:
// 683 Y(sum rgb_i max(0, d_i.z) + SH9 irradiance at +Z for a residual). For a relative
// list the same number in relative units.
double upward_illuminance(const LightList& list);

struct LightUnitsResult {
  LightList list;        // scaled; units "radiance" once a scale is given
  double factor = 1;     // what rgb (and SH9) were multiplied by
  std::string warning;   // non-empty: a relative list exported unscaled (one line)
};
// The checks of the options alone (two at once, a non-finite exposure, a scale or illuminance
// of 0 or below), as apply_light_units makes them: for a command to refuse before it works.
void check_light_units_options(const LightUnitsOptions& options);
// Throws InputError naming the flag: check_light_units_options, or an illuminance target for
// a list that lights nothing from above. `output` names the file in the warning.
LightUnitsResult apply_light_units(LightList list, const LightUnitsOptions& options, const std::string& output);

}  // namespace lp
