#include "core/light_list.h"

#include <fmt/format.h>

#include <cmath>
#include <nlohmann/json.hpp>

#include "core/error.h"
#include "core/sh9_json.h"

namespace lp {

namespace {

using nlohmann::json;

constexpr const char* kFrameConvention = "z-up";
// A direction whose length is off by more than this is not a unit vector: a writer that
// normalises in double lands within ~1e-15, one in float within ~1e-7.
constexpr double kUnitTolerance = 1e-5;

[[noreturn]] void fail(const std::string& source, const std::string& what) {
  throw InputError(fmt::format("{}: {}", source, what));
}

const json& field(const json& object, const char* key, const std::string& source, const std::string& where) {
  auto it = object.find(key);
  if (it == object.end()) fail(source, fmt::format("{}missing \"{}\"", where, key));
  return *it;
}

double number(const json& value, const std::string& source, const std::string& what) {
  if (!value.is_number()) fail(source, fmt::format("{} is not a number", what));
  const double v = value.get<double>();
  if (!std::isfinite(v)) fail(source, fmt::format("{} is not finite", what));
  return v;
}

std::array<double, 3> triple(const json& value, const std::string& source, const std::string& what) {
  if (!value.is_array() || value.size() != 3) fail(source, fmt::format("{} is not an array of 3 numbers", what));
  std::array<double, 3> out{};
  for (int c = 0; c < 3; ++c) {
    // nlohmann writes NaN/Inf as null; catch them here with a clear message.
    if (value[c].is_null()) fail(source, fmt::format("{} has a NaN or infinite component", what));
    out[c] = number(value[c], source, what);
  }
  return out;
}

}  // namespace

std::string_view to_string(Sh9Content content) { return content == Sh9Content::Map ? "map" : "residual"; }

std::string to_json(const LightList& list, bool pretty) {
  // ordered_json keeps the keys in the order CONVENTIONS.md shows them.
  using ojson = nlohmann::ordered_json;
  ojson lights = ojson::array();
  for (const Light& l : list.lights) {
    ojson o;
    o["id"] = l.id;
    o["direction"] = {l.direction.x, l.direction.y, l.direction.z};
    o["rgb"] = {l.rgb[0], l.rgb[1], l.rgb[2]};
    o["solid_angle"] = l.solid_angle;
    lights.push_back(std::move(o));
  }
  ojson doc;
  doc["format"] = kLightListFormat;
  doc["frame"] = list.frame;
  doc["timestamp"] = list.timestamp;
  doc["method"] = list.method;
  doc["units"] = std::string(to_string(list.units));
  doc["frame_convention"] = kFrameConvention;
  doc["lights"] = std::move(lights);
  if (list.sh9)
    doc["sh9"] = {{"order", kSh9Order},
                  {"content", std::string(to_string(list.sh9_content))},
                  {"coefficients", sh9_rows_json(*list.sh9)}};
  // nlohmann prints doubles with the shortest representation that round-trips.
  return pretty ? doc.dump(2) : doc.dump();
}

LightList light_list_from_json(const std::string& text, const std::string& source) {
  json doc;
  try {
    doc = json::parse(text);
  } catch (const json::parse_error& e) {
    fail(source, fmt::format("not valid JSON (byte {})", e.byte));
  } catch (const json::exception& e) {  // out_of_range.406 for a number beyond a double ("1e400")
    fail(source, e.id == 406 ? std::string("not valid JSON (a number beyond the range of a double)")
                             : fmt::format("not valid JSON (nlohmann error {})", e.id));
  }
  if (!doc.is_object()) fail(source, "light list is not a JSON object");

  const json& format = field(doc, "format", source, "");
  if (!format.is_string() || format.get<std::string>() != kLightListFormat)
    fail(source, fmt::format("format is {}, expected \"{}\"", format.dump(), kLightListFormat));
  const json& convention = field(doc, "frame_convention", source, "");
  if (!convention.is_string() || convention.get<std::string>() != kFrameConvention)
    fail(source, fmt::format("frame_convention is {}, expected \"{}\"", convention.dump(), kFrameConvention));

  LightList list;
  const json& frame = field(doc, "frame", source, "");
  if (!frame.is_number_integer()) fail(source, "frame is not an integer");
  list.frame = frame.get<int64_t>();
  list.timestamp = number(field(doc, "timestamp", source, ""), source, "timestamp");
  const json& method = field(doc, "method", source, "");
  if (!method.is_string()) fail(source, "method is not a string");
  list.method = method.get<std::string>();
  const json& units = field(doc, "units", source, "");
  const auto u = units.is_string() ? units_from_string(units.get<std::string>()) : std::nullopt;
  if (!u) fail(source, fmt::format("units is {}, expected \"relative\" or \"radiance\"", units.dump()));
  list.units = *u;

  const json& lights = field(doc, "lights", source, "");
  if (!lights.is_array()) fail(source, "lights is not an array");
  list.lights.reserve(lights.size());
  for (size_t i = 0; i < lights.size(); ++i) {
    const json& o = lights[i];
    const std::string where = fmt::format("light {}: ", i);
    if (!o.is_object()) fail(source, fmt::format("light {} is not an object", i));
    Light l;
    const json& id = field(o, "id", source, where);
    if (!id.is_number_unsigned() && !(id.is_number_integer() && id.get<int64_t>() >= 0))
      fail(source, where + "id is not a non-negative integer");
    l.id = id.get<uint64_t>();
    const auto d = triple(field(o, "direction", source, where), source, where + "direction");
    l.direction = {d[0], d[1], d[2]};
    const double len = length(l.direction);
    if (!(std::fabs(len - 1.0) <= kUnitTolerance))
      fail(source, fmt::format("{}direction has length {}, not a unit vector", where, len));
    l.rgb = triple(field(o, "rgb", source, where), source, where + "rgb");
    l.solid_angle = number(field(o, "solid_angle", source, where), source, where + "solid_angle");
    if (l.solid_angle < 0) fail(source, where + "solid_angle is negative");
    list.lights.push_back(l);
  }
  if (auto sh = doc.find("sh9"); sh != doc.end()) {
    if (!sh->is_object()) fail(source, "sh9 is not an object");
    const json& content = field(*sh, "content", source, "sh9: ");
    if (content == "map")
      list.sh9_content = Sh9Content::Map;
    else if (content == "residual")
      list.sh9_content = Sh9Content::Residual;
    else
      fail(source, fmt::format("sh9: content is {}, expected \"residual\" or \"map\"", content.dump()));
    list.sh9 = sh9_from_json_object(*sh, source, "sh9: ");
  }
  return list;
}

std::array<double, 3> total_power(const std::vector<Light>& lights) {
  std::array<double, 3> sum{0, 0, 0};
  for (const Light& l : lights)
    for (int c = 0; c < 3; ++c) sum[c] += l.rgb[c];
  return sum;
}

}  // namespace lp
