// Light lists written for renderers. One call turns a LightList into the text of a file;
// the caller writes it (write_file_atomically). Every format carries the same lights,
// each in the frame convention of its consumer, and each exporter has a test that reads
// its output back and checks the light lands where that renderer puts it.
//
// Our frame (CONVENTIONS.md): right-handed, +Z up; a light's `direction` points from
// the scene TOWARDS the light; `rgb` = integral of radiance over the light's region, so
// the irradiance on a surface facing the light is exactly `rgb`.
//
//   json     lp::to_json, indented, one object (the native format).
//   ndjson   lp::to_json on one line, ending in '\n' (append frames to stream them).
//   pbrt     pbrt-v4 scene fragment, one per light:
//              LightSource "distant" "point3 from" [dx dy dz] "point3 to" [0 0 0]
//                "rgb L" [r/m g/m b/m] "float scale" [m]        (m = max component)
//            Frame: our z-up world, unchanged. pbrt has no fixed up axis (the camera's
//            LookAt names one), so a z-up scene is as native as any; put the fragment
//            after WorldBegin where the CTM is the world frame. Direction: pbrt-v4's
//            DistantLight::Create builds w = normalize(from - to) and its SampleLi
//            returns wi = w, the direction from the shaded point towards the light, so
//            from - to = our direction.
//            Scale: pbrt-v4 divides "scale" by SpectrumToPhotometric(L), which for an
//            "rgb L" (RGBIlluminantSpectrum) is the photometric value of the colour
//            space's illuminant alone (D65 for sRGB), not of the rgb; the spectrum is
//            then rgb x D65 normalised to 1 nit, which the default film (cie1931
//            sensor, sRGB, imaging ratio 1) records as rgb itself. A delta light adds
//            scale * L to a surface facing it, so the irradiance there is
//            m * (rgb / m) = rgb. "illuminance" is not used: it ignores the rgb
//            multiplier, measures on an upward-facing patch, and its formula changed
//            between pbrt-v4 revisions.
//   mitsuba  Mitsuba 3 XML, <scene version="3.0.0"> with one
//              <emitter type="directional"> <vector name="direction" x y z/>
//                <rgb name="irradiance" value="r, g, b"/> </emitter>
//            per light. Mitsuba's `direction` is the direction the light TRAVELS
//            (directional.cpp: look_at(0, direction) and the emitter radiates along
//            local +Z; sample_direction returns ds.d = -direction towards the light),
//            i.e. minus ours. `irradiance` is the irradiance on a surface normal to the
//            beam, our rgb as is (rgb emitters are D65-normalised in spectral variants).
//            Frame: Mitsuba has no fixed up axis for directional emitters, but its
//            `envmap` emitter is Y-up (v = acos(y) / pi), so scenes are conventionally
//            Y-up; we rotate our z-up world by -90 deg about X:
//              (x, y, z)_ours -> (x, z, -y)_mitsuba
//            written direction = -(x, z, -y) = (-x, -z, y). Caveat for anyone loading our
//            latlong map as a Mitsuba envmap beside these lights: its azimuth runs
//            u = atan2(x, -z) / 2pi, the mirror image of ours, so the map needs a
//            horizontal flip (no rotation can match it); the lights need nothing.
//   gltf     glTF 2.0 JSON with KHR_lights_punctual: one "directional" light per light
//            (color = rgb / m, intensity = m, m = max component; color x intensity = rgb)
//            and one node per light holding it, with a unit quaternion `rotation`
//            [x, y, z, w] that turns the node's local -Z (where a KHR directional light
//            shines) into the light's travel direction. Frame: glTF is +Y up,
//            right-handed, so the same (x, y, z)_ours -> (x, z, -y)_gltf rotation; the
//            travel direction is -(x, z, -y). Units: glTF specifies lux. A "radiance"
//            list's rgb is photopically weighted W m^-2 (calib/photometric.h), so
//            intensity = 683 m and the luminance of color x intensity is the light's
//            illuminance in lux (Blender's importer divides by 683 again: sun strength
//            in W m^-2 = m). A relative list is written unconverted (scale it first:
//            sampling/light_units.h). The list's frame, timestamp, method and units go in
//            asset.extras, with the list's SH9 when it has one (asset.extras.sh9: rotated
//            to glTF's Y-up frame, lightprobe.sh/1's basis and order, so that three.js'
//            SphericalHarmonics3.fromArray takes its rows flattened; scaled like the
//            intensities); each light's id and solid angle in its extras.
//   glb      the same glTF document as binary glTF 2.0: a 12-byte header and one JSON chunk
//            padded with spaces to 4 bytes (no BIN chunk: lights need no buffers).
//   csv      header `id,x,y,z,r,g,b,solid_angle,units`, one row per light in our frame, every
//            number with the shortest text that reads back to the same double; units is the
//            list's ("radiance": rgb in W m^-2, or "relative").
//
// Numbers are written in full precision (shortest round-trip form) everywhere.
// Throws InputError on a light with a non-finite or zero-length direction or a
// negative or non-finite rgb component.
#pragma once

#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include "core/light_list.h"

namespace lp {

// Maximum luminous efficacy (lm/W) that relates calibrated maps' photopically weighted
// watts to lux and cd m^-2 (calib/photometric.h), and glTF's lux to Blender's W m^-2.
inline constexpr double kLumensPerWatt = 683.0;

enum class ExportFormat { Json, Ndjson, Pbrt, Mitsuba, Gltf, Glb, Csv };

// "json", "ndjson", "pbrt", "mitsuba", "gltf", "glb", "csv" (the --format names).
std::string_view to_string(ExportFormat format);
std::optional<ExportFormat> export_format_from_string(std::string_view name);
std::vector<ExportFormat> all_export_formats();
// Conventional file extension, with the dot: ".json", ".ndjson", ".pbrt", ".xml",
// ".gltf", ".glb", ".csv".
std::string_view file_extension(ExportFormat format);

// The whole file text for one light list.
std::string export_lights(const LightList& list, ExportFormat format);
// The text of a sequence in one file: the lists one after another (NDJSON: a line each),
// and for CSV one header over every frame's rows.
std::string export_light_sequence(const std::vector<LightList>& lists, ExportFormat format);

// The format of an output: `name` (--format) when given, else from the extension of
// `path` (.json, .ndjson or .jsonl, .pbrt, .xml, .gltf, .glb, .csv; .json is NDJSON for
// a sequence). Throws InputError on an unknown `name`, and on any other extension
// (naming the ones that exist) when no `name` is given.
ExportFormat export_format_for(const std::string& name, const std::string& path, bool sequence);

}  // namespace lp
