#include "sampling/exporters.h"

#include <fmt/format.h>

#include <algorithm>
#include <filesystem>
#include <cmath>
#include <nlohmann/json.hpp>
#include <unordered_set>

#include "core/error.h"
#include "core/file_io.h"
#include "core/spherical_harmonics.h"

namespace lp {

namespace {

struct FormatInfo {
  ExportFormat format;
  std::string_view name;
  std::string_view extension;
};
constexpr FormatInfo kFormats[] = {
    {ExportFormat::Json, "json", ".json"},       {ExportFormat::Ndjson, "ndjson", ".ndjson"},
    {ExportFormat::Pbrt, "pbrt", ".pbrt"},       {ExportFormat::Mitsuba, "mitsuba", ".xml"},
    {ExportFormat::Gltf, "gltf", ".gltf"},       {ExportFormat::Glb, "glb", ".glb"},
    {ExportFormat::Csv, "csv", ".csv"},
};

const FormatInfo& info(ExportFormat format) {
  for (const FormatInfo& f : kFormats)
    if (f.format == format) return f;
  return kFormats[0];
}

// Our z-up world -> the Y-up frame of Mitsuba and glTF: rotation by -90 deg about X.
Vec3 yup_from_zup(Vec3 d) { return {d.x, d.z, -d.y}; }

// Largest rgb component (0 for a black light), used to split rgb into a colour with
// maximum 1 and a scalar intensity.
double max_component(const std::array<double, 3>& rgb) { return std::max({rgb[0], rgb[1], rgb[2]}); }
std::array<double, 3> colour_of(const std::array<double, 3>& rgb) {
  const double m = max_component(rgb);
  if (!(m > 0)) return {1, 1, 1};  // black: any colour, intensity 0
  return {rgb[0] / m, rgb[1] / m, rgb[2] / m};
}

void check_lights(const LightList& list) {
  for (size_t i = 0; i < list.lights.size(); ++i) {
    const Light& l = list.lights[i];
    const Vec3 d = l.direction;
    const double len = length(d);
    if (!std::isfinite(len) || !(len > 0))
      throw InputError(fmt::format("light {} (id {}): direction ({}, {}, {}) is not a usable vector", i, l.id, d.x,
                                   d.y, d.z));
    for (double c : l.rgb)
      if (!std::isfinite(c) || c < 0)
        throw InputError(fmt::format("light {} (id {}): rgb ({}, {}, {}) has a negative or non-finite component",
                                     i, l.id, l.rgb[0], l.rgb[1], l.rgb[2]));
  }
}

std::string header_line(const LightList& list) {
  return fmt::format("lightprobe {}: {} lights, frame {}, timestamp {}, method {}, units {}", kLightListFormat,
                     list.lights.size(), list.frame, list.timestamp, list.method.empty() ? "-" : list.method,
                     to_string(list.units));
}

std::string export_pbrt(const LightList& list) {
  std::string out = fmt::format("# {}\n", header_line(list));
  out +=
      "# pbrt-v4 distant lights in a right-handed z-up world (pbrt has no fixed up axis).\n"
      "# Place after WorldBegin with the world CTM. Light arrives travelling from `from`\n"
      "# towards `to`; scale * L is the irradiance on a surface facing the light.\n";
  for (const Light& l : list.lights) {
    const auto c = colour_of(l.rgb);
    const Vec3 d = l.direction;
    out += fmt::format("# id {} solid_angle {}\n", l.id, l.solid_angle);
    out += fmt::format(
        "LightSource \"distant\" \"point3 from\" [{} {} {}] \"point3 to\" [0 0 0]\n"
        "    \"rgb L\" [{} {} {}] \"float scale\" [{}]\n",
        d.x, d.y, d.z, c[0], c[1], c[2], max_component(l.rgb));
  }
  return out;
}

// Distinct ids make readable Mitsuba object ids; duplicates would make the scene invalid.
bool ids_unique(const LightList& list) {
  std::unordered_set<uint64_t> seen;
  for (const Light& l : list.lights)
    if (!seen.insert(l.id).second) return false;
  return true;
}

std::string export_mitsuba(const LightList& list) {
  std::string out = "<?xml version=\"1.0\" encoding=\"utf-8\"?>\n";
  out += fmt::format("<!-- {} -->\n", header_line(list));
  out +=
      "<!-- Y-up: our z-up (x, y, z) is written as (x, z, -y). `direction` is where the light\n"
      "     travels (from the light into the scene); `irradiance` is on a surface facing it. -->\n";
  out += "<scene version=\"3.0.0\">\n";
  const bool unique = ids_unique(list);
  for (size_t i = 0; i < list.lights.size(); ++i) {
    const Light& l = list.lights[i];
    const Vec3 t = -yup_from_zup(l.direction);
    out += fmt::format("    <!-- id {} solid_angle {} -->\n", l.id, l.solid_angle);
    out += fmt::format("    <emitter type=\"directional\" id=\"light_{}\">\n", unique ? l.id : uint64_t(i));
    out += fmt::format("        <vector name=\"direction\" x=\"{}\" y=\"{}\" z=\"{}\"/>\n", t.x, t.y, t.z);
    out += fmt::format("        <rgb name=\"irradiance\" value=\"{}, {}, {}\"/>\n", l.rgb[0], l.rgb[1], l.rgb[2]);
    out += "    </emitter>\n";
  }
  out += "</scene>\n";
  return out;
}

// Unit quaternion [x, y, z, w] turning (0, 0, -1) into the unit vector b along the
// shortest arc. The angle comes from atan2(|a x b|, a . b), which stays accurate when b
// is nearly opposite to -Z (where 1 + a . b cancels).
std::array<double, 4> quaternion_from_minus_z(Vec3 b) {
  const Vec3 axis{b.y, -b.x, 0};  // (0, 0, -1) x b
  const double s = length(axis);
  const double angle = std::atan2(s, -b.z);
  if (s == 0) {
    // b = -Z: identity; b = +Z: half turn about X.
    return b.z < 0 ? std::array<double, 4>{0, 0, 0, 1} : std::array<double, 4>{1, 0, 0, 0};
  }
  const double k = std::sin(angle / 2) / s;
  return {axis.x * k, axis.y * k, 0, std::cos(angle / 2)};
}

// glTF's lux: a "radiance" list's rgb is photopically weighted W m^-2 (calib/photometric.h),
// and 683 lm/W makes the luminance of color x intensity its illuminance in lux (Blender's
// importer divides by the same 683 to get a sun's W m^-2). Relative lists stay as they are.
double gltf_intensity_factor(const LightList& list) { return list.units == Units::Radiance ? kLumensPerWatt : 1.0; }

nlohmann::ordered_json gltf_sh9_extras(const LightList& list) {
  using ojson = nlohmann::ordered_json;
  const Sh9 yup = scaled(sh9_yup_from_zup(*list.sh9), gltf_intensity_factor(list));
  ojson rows = ojson::array();
  for (const auto& row : yup.coefficients) rows.push_back({row[0], row[1], row[2]});
  return {{"format", kShFormat},
          {"order", kSh9Order},
          {"content", std::string(to_string(list.sh9_content))},
          {"frame_convention", "y-up (glTF, three.js): basis of lightprobe.sh/1 evaluated at (x, z, -y)"},
          {"units", "as the lights' color x intensity"},
          {"coefficients", std::move(rows)}};
}

nlohmann::ordered_json gltf_document(const LightList& list) {
  using ojson = nlohmann::ordered_json;
  ojson doc;
  doc["asset"] = {{"version", "2.0"},
                  {"generator", "lightprobe"},
                  {"extras",
                   {{"format", kLightListFormat},
                    {"frame", list.frame},
                    {"timestamp", list.timestamp},
                    {"method", list.method},
                    {"units", std::string(to_string(list.units))},
                    {"frame_convention", "y-up: (x, y, z) of lightprobe's z-up world is (x, z, -y) here"}}}};
  if (list.sh9) doc["asset"]["extras"]["sh9"] = gltf_sh9_extras(list);
  if (list.lights.empty()) {
    // glTF requires non-empty `lights` and `nodes` arrays when present: an empty scene.
    doc["scenes"] = ojson::array({ojson::object({{"name", "lightprobe lights"}})});
    doc["scene"] = 0;
    return doc;
  }
  const double lux_factor = gltf_intensity_factor(list);
  doc["extensionsUsed"] = {"KHR_lights_punctual"};
  ojson lights = ojson::array();
  ojson nodes = ojson::array();
  ojson scene_nodes = ojson::array();
  for (size_t i = 0; i < list.lights.size(); ++i) {
    const Light& l = list.lights[i];
    const auto c = colour_of(l.rgb);
    const std::string name = fmt::format("light {}", l.id);
    ojson light;
    light["name"] = name;
    light["type"] = "directional";
    light["color"] = {c[0], c[1], c[2]};
    light["intensity"] = max_component(l.rgb) * lux_factor;
    light["extras"] = {{"id", l.id}, {"solid_angle", l.solid_angle}};
    lights.push_back(std::move(light));

    const auto q = quaternion_from_minus_z(normalize(-yup_from_zup(l.direction)));
    ojson node;
    node["name"] = name;
    node["rotation"] = {q[0], q[1], q[2], q[3]};
    node["extensions"] = {{"KHR_lights_punctual", {{"light", i}}}};
    nodes.push_back(std::move(node));
    scene_nodes.push_back(i);
  }
  doc["extensions"] = {{"KHR_lights_punctual", {{"lights", std::move(lights)}}}};
  doc["nodes"] = std::move(nodes);
  doc["scenes"] = ojson::array({ojson{{"name", "lightprobe lights"}, {"nodes", std::move(scene_nodes)}}});
  doc["scene"] = 0;
  return doc;
}

std::string export_gltf(const LightList& list) { return gltf_document(list).dump(2) + "\n"; }

// Binary glTF 2.0: 12-byte header (magic "glTF", version 2, total length), then one JSON
// chunk (length, type "JSON", the text padded with spaces to 4 bytes); no BIN chunk,
// since lights need no buffers. All integers little-endian.
std::string export_glb(const LightList& list) {
  std::string json = gltf_document(list).dump();
  while (json.size() % 4) json += ' ';
  std::string out;
  auto u32 = [&](uint32_t v) {
    for (int b = 0; b < 4; ++b) out += char((v >> (8 * b)) & 0xFF);
  };
  u32(0x46546C67);  // "glTF"
  u32(2);
  u32(uint32_t(12 + 8 + json.size()));
  u32(uint32_t(json.size()));
  u32(0x4E4F534A);  // "JSON"
  return out + json;
}

std::string export_csv(const LightList& list) {
  // The units on every row: a csv had no place for them, and a relative list read the same
  // as one in W m^-2.
  std::string out = "id,x,y,z,r,g,b,solid_angle,units\n";
  const std::string_view units = to_string(list.units);
  for (const Light& l : list.lights)
    out += fmt::format("{},{},{},{},{},{},{},{},{}\n", l.id, l.direction.x, l.direction.y, l.direction.z, l.rgb[0],
                       l.rgb[1], l.rgb[2], l.solid_angle, units);
  return out;
}

}  // namespace

std::string_view to_string(ExportFormat format) { return info(format).name; }

std::optional<ExportFormat> export_format_from_string(std::string_view name) {
  for (const FormatInfo& f : kFormats)
    if (f.name == name) return f.format;
  return std::nullopt;
}

std::vector<ExportFormat> all_export_formats() {
  std::vector<ExportFormat> out;
  for (const FormatInfo& f : kFormats) out.push_back(f.format);
  return out;
}

std::string_view file_extension(ExportFormat format) { return info(format).extension; }

std::string export_lights(const LightList& list, ExportFormat format) {
  check_lights(list);
  switch (format) {
    case ExportFormat::Json:
      return to_json(list, true) + "\n";
    case ExportFormat::Ndjson:
      return to_json(list, false) + "\n";
    case ExportFormat::Pbrt:
      return export_pbrt(list);
    case ExportFormat::Mitsuba:
      return export_mitsuba(list);
    case ExportFormat::Gltf:
      return export_gltf(list);
    case ExportFormat::Glb:
      return export_glb(list);
    case ExportFormat::Csv:
      return export_csv(list);
  }
  return {};
}

std::string export_light_sequence(const std::vector<LightList>& lists, ExportFormat format) {
  std::string text;
  for (size_t f = 0; f < lists.size(); ++f) {
    const std::string body = export_lights(lists[f], format);
    text += format == ExportFormat::Csv && f > 0 ? body.substr(body.find('\n') + 1) : body;
  }
  return text;
}

ExportFormat export_format_for(const std::string& name, const std::string& path, bool sequence) {
  const std::string e = lower_extension(path);
  if (!name.empty()) {
    auto f = export_format_from_string(name);
    if (!f) throw InputError(fmt::format("--format: unknown format '{}' (json, ndjson, pbrt, mitsuba, gltf, glb, csv)", name));
    // --format names a format for a name that does not say one: against a known extension
    // that says another (csv text in a .gltf) it is refused. JSON's two shapes share .json.
    const bool json_family = (*f == ExportFormat::Json || *f == ExportFormat::Ndjson) && (e == ".json" || e == ".jsonl");
    if (!json_family)
      for (const FormatInfo& k : kFormats)
        if (k.extension == e && k.format != *f)
          throw InputError(fmt::format("{}: --format {} contradicts the extension {} ({}); give the file a matching name",
                                       path, name, e, k.name));
    return *f;
  }
  if (e == ".jsonl") return ExportFormat::Ndjson;
  if (e == ".json") return sequence ? ExportFormat::Ndjson : ExportFormat::Json;
  for (const FormatInfo& f : kFormats)
    if (f.extension == e) return f.format;
  std::string known;
  for (const FormatInfo& f : kFormats) known += fmt::format("{}{} ({})", known.empty() ? "" : ", ", f.extension, f.name);
  throw InputError(fmt::format("{}: unknown extension '{}': name one of {}, .jsonl, or give --format", path, e, known));
}

}  // namespace lp
