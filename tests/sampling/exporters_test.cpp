// Each exporter's output is read back with a parser written here (string scanning for
// pbrt and Mitsuba, nlohmann for glTF and JSON) and each light must land where that
// renderer would put it, with its numbers intact.
#include "sampling/exporters.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <nlohmann/json.hpp>
#include <sstream>
#include <string>
#include <vector>

#include "core/error.h"

namespace lp {
namespace {

constexpr double kRel = 1e-9;

void expect_close(double actual, double expected, const std::string& what) {
  EXPECT_NEAR(actual, expected, kRel * std::max(1.0, std::fabs(expected))) << what;
}
void expect_close(Vec3 actual, Vec3 expected, const std::string& what) {
  expect_close(actual.x, expected.x, what + ".x");
  expect_close(actual.y, expected.y, what + ".y");
  expect_close(actual.z, expected.z, what + ".z");
}

Light make_light(uint64_t id, Vec3 d, std::array<double, 3> rgb, double solid_angle) {
  Light l;
  l.id = id;
  l.direction = normalize(d);
  l.rgb = rgb;
  l.solid_angle = solid_angle;
  return l;
}

// Two lights of the brief, one straight overhead and one on +Y, with colours whose
// maximum sits in different channels and digits that need full precision.
LightList sample_list() {
  LightList list;
  list.frame = 42;
  list.timestamp = 1700000000.123;
  list.method = "q2tree";
  list.units = Units::Relative;
  list.lights = {
      make_light(17, {0.6, 0, 0.8}, {1.25, 0.5, 0.125}, 0.0123),
      make_light(3, {0, -1, 0}, {0.3, 0.7000000000000001, 0.2}, 0.25),
      make_light(1ull << 40, {0, 0, 1}, {1.0 / 3.0, 2.0 / 7.0, 1e-7}, 1.5e-4),
      make_light(99, {0, 1, 0}, {2, 2, 2}, 0.5),
  };
  return list;
}

// Our z-up world seen from a Y-up renderer (rotation by -90 deg about X).
Vec3 yup(Vec3 d) { return {d.x, d.z, -d.y}; }

// Reads n numbers from `text` starting at `pos` (skipping '[', ',', quotes, spaces).
std::vector<double> numbers_at(const std::string& text, size_t pos, int n) {
  std::vector<double> out;
  const char* p = text.c_str() + pos;
  while (int(out.size()) < n && *p) {
    if (std::strchr("[], \"\n", *p)) {
      ++p;
      continue;
    }
    char* end = nullptr;
    const double v = std::strtod(p, &end);
    if (end == p) break;
    out.push_back(v);
    p = end;
  }
  return out;
}

// Every occurrence of `key` in `text`, followed by n numbers.
std::vector<std::vector<double>> all_after(const std::string& text, const std::string& key, int n) {
  std::vector<std::vector<double>> out;
  for (size_t pos = text.find(key); pos != std::string::npos; pos = text.find(key, pos + 1))
    out.push_back(numbers_at(text, pos + key.size(), n));
  return out;
}

// Value of attribute `name` in an XML element text.
std::string attribute(const std::string& element, const std::string& name) {
  const std::string key = " " + name + "=\"";
  const size_t pos = element.find(key);
  if (pos == std::string::npos) return {};
  const size_t begin = pos + key.size();
  return element.substr(begin, element.find('"', begin) - begin);
}

// Elements <tag .../> or <tag ...> (their opening text) in order of appearance.
std::vector<std::string> elements(const std::string& text, const std::string& tag) {
  std::vector<std::string> out;
  const std::string open = "<" + tag + " ";
  for (size_t pos = text.find(open); pos != std::string::npos; pos = text.find(open, pos + 1))
    out.push_back(text.substr(pos, text.find('>', pos) - pos + 1));
  return out;
}

// v rotated by the unit quaternion q = [x, y, z, w]: v + 2w (u x v) + 2 u x (u x v).
Vec3 rotate(const std::vector<double>& q, Vec3 v) {
  const Vec3 u{q[0], q[1], q[2]};
  const Vec3 t = 2.0 * cross(u, v);
  return v + q[3] * t + cross(u, t);
}

TEST(ExportFormats, NamesRoundTripAndUnknownNamesAreRejected) {
  for (ExportFormat f : all_export_formats()) {
    const auto back = export_format_from_string(to_string(f));
    ASSERT_TRUE(back.has_value()) << to_string(f);
    EXPECT_EQ(*back, f);
    EXPECT_EQ(file_extension(f).front(), '.');
  }
  EXPECT_EQ(all_export_formats().size(), 7u);
  EXPECT_EQ(export_format_from_string("mitsuba"), ExportFormat::Mitsuba);
  EXPECT_FALSE(export_format_from_string("obj").has_value());
  EXPECT_FALSE(export_format_from_string("JSON").has_value());
}

TEST(ExportPbrt, EachLightIsADistantLightFromItsDirectionTowardsTheOrigin) {
  const LightList list = sample_list();
  const std::string text = export_lights(list, ExportFormat::Pbrt);
  const auto from = all_after(text, "\"point3 from\"", 3);
  const auto to = all_after(text, "\"point3 to\"", 3);
  const auto L = all_after(text, "\"rgb L\"", 3);
  const auto scale = all_after(text, "\"float scale\"", 1);
  ASSERT_EQ(all_after(text, "LightSource \"distant\"", 0).size(), list.lights.size());
  ASSERT_EQ(from.size(), list.lights.size());
  ASSERT_EQ(to.size(), list.lights.size());
  ASSERT_EQ(L.size(), list.lights.size());
  ASSERT_EQ(scale.size(), list.lights.size());
  for (size_t i = 0; i < list.lights.size(); ++i) {
    const Light& l = list.lights[i];
    ASSERT_EQ(from[i].size(), 3u);
    ASSERT_EQ(to[i].size(), 3u);
    // pbrt-v4: w = normalize(from - to) is the direction towards the light.
    const Vec3 w = Vec3{from[i][0], from[i][1], from[i][2]} - Vec3{to[i][0], to[i][1], to[i][2]};
    ASSERT_GT(length(w), 0);
    EXPECT_LT(length(cross(normalize(w), l.direction)), 1e-12) << "light " << i;
    EXPECT_GT(dot(w, l.direction), 0) << "light " << i;
    expect_close(normalize(w), l.direction, "direction of light " + std::to_string(i));
    // Irradiance on a surface facing the light is scale * L.
    for (int c = 0; c < 3; ++c) expect_close(scale[i][0] * L[i][c], l.rgb[c], "rgb of light " + std::to_string(i));
  }
}

TEST(ExportMitsuba, DirectionIsWhereTheLightTravelsInAYUpFrame) {
  const LightList list = sample_list();
  const std::string text = export_lights(list, ExportFormat::Mitsuba);
  const auto scene = elements(text, "scene");
  ASSERT_EQ(scene.size(), 1u);
  EXPECT_EQ(attribute(scene[0], "version"), "3.0.0");
  const auto emitters = elements(text, "emitter");
  const auto vectors = elements(text, "vector");
  const auto rgbs = elements(text, "rgb");
  ASSERT_EQ(emitters.size(), list.lights.size());
  ASSERT_EQ(vectors.size(), list.lights.size());
  ASSERT_EQ(rgbs.size(), list.lights.size());
  for (size_t i = 0; i < list.lights.size(); ++i) {
    const Light& l = list.lights[i];
    EXPECT_EQ(attribute(emitters[i], "type"), "directional");
    EXPECT_EQ(attribute(emitters[i], "id"), "light_" + std::to_string(l.id));
    EXPECT_EQ(attribute(vectors[i], "name"), "direction");
    const Vec3 d{std::stod(attribute(vectors[i], "x")), std::stod(attribute(vectors[i], "y")),
                 std::stod(attribute(vectors[i], "z"))};
    expect_close(d, -yup(l.direction), "direction of light " + std::to_string(i));
    EXPECT_EQ(attribute(rgbs[i], "name"), "irradiance");
    const auto rgb = numbers_at(attribute(rgbs[i], "value"), 0, 3);
    ASSERT_EQ(rgb.size(), 3u);
    for (int c = 0; c < 3; ++c) expect_close(rgb[c], l.rgb[c], "irradiance of light " + std::to_string(i));
  }
  // Independent of the formula: the overhead light shines straight down Mitsuba's -Y.
  expect_close(Vec3{std::stod(attribute(vectors[2], "x")), std::stod(attribute(vectors[2], "y")),
                    std::stod(attribute(vectors[2], "z"))},
               Vec3{0, -1, 0}, "overhead light");
}

TEST(ExportMitsuba, RepeatedIdsStillGiveDistinctObjectIds) {
  LightList list = sample_list();
  list.lights[1].id = list.lights[0].id;
  const auto emitters = elements(export_lights(list, ExportFormat::Mitsuba), "emitter");
  ASSERT_EQ(emitters.size(), list.lights.size());
  for (size_t i = 0; i < emitters.size(); ++i) EXPECT_EQ(attribute(emitters[i], "id"), "light_" + std::to_string(i));
}

TEST(ExportGltf, EachNodeTurnsMinusZIntoTheLightsTravelDirection) {
  const LightList list = sample_list();
  const auto doc = nlohmann::json::parse(export_lights(list, ExportFormat::Gltf));
  EXPECT_EQ(doc["asset"]["version"], "2.0");
  ASSERT_TRUE(doc.contains("extensionsUsed"));
  EXPECT_NE(std::find(doc["extensionsUsed"].begin(), doc["extensionsUsed"].end(), "KHR_lights_punctual"),
            doc["extensionsUsed"].end());
  const auto& lights = doc["extensions"]["KHR_lights_punctual"]["lights"];
  const auto& nodes = doc["nodes"];
  ASSERT_EQ(lights.size(), list.lights.size());
  ASSERT_EQ(nodes.size(), list.lights.size());
  const auto& scene = doc["scenes"][doc["scene"].get<int>()];
  ASSERT_EQ(scene["nodes"].size(), list.lights.size());

  std::vector<bool> used(lights.size(), false);
  for (size_t n : scene["nodes"].get<std::vector<size_t>>()) {
    ASSERT_LT(n, nodes.size());
    const auto& node = nodes[n];
    const size_t li = node["extensions"]["KHR_lights_punctual"]["light"].get<size_t>();
    ASSERT_LT(li, lights.size());
    used[li] = true;
    const auto& light = lights[li];
    const Light& ours = list.lights[li];
    const std::string what = "light " + std::to_string(li);
    EXPECT_EQ(light["type"], "directional");
    EXPECT_EQ(light["extras"]["id"].get<uint64_t>(), ours.id);
    // colour x intensity = rgb, colour within [0, 1] with its maximum at 1.
    const auto colour = light["color"].get<std::vector<double>>();
    const double intensity = light["intensity"].get<double>();
    ASSERT_EQ(colour.size(), 3u);
    EXPECT_NEAR(*std::max_element(colour.begin(), colour.end()), 1.0, 1e-15) << what;
    for (int c = 0; c < 3; ++c) {
      EXPECT_GE(colour[c], 0) << what;
      expect_close(colour[c] * intensity, ours.rgb[c], what + " rgb");
    }
    // A KHR directional light shines along the node's local -Z.
    const auto q = node["rotation"].get<std::vector<double>>();
    ASSERT_EQ(q.size(), 4u);
    EXPECT_NEAR(q[0] * q[0] + q[1] * q[1] + q[2] * q[2] + q[3] * q[3], 1.0, 1e-12) << what;
    expect_close(rotate(q, {0, 0, -1}), -yup(ours.direction), what + " travel direction");
  }
  for (bool u : used) EXPECT_TRUE(u);

  // Independent of the formula, in glTF's +Y-up frame: the overhead light (index 2)
  // shines straight down, the light on our -Y (index 1) along glTF's -Z with no rotation,
  // and the light on our +Y (index 3) along +Z, a half turn.
  expect_close(rotate(nodes[2]["rotation"].get<std::vector<double>>(), {0, 0, -1}), {0, -1, 0}, "overhead");
  const auto q1 = nodes[1]["rotation"].get<std::vector<double>>();
  expect_close(Vec3{q1[0], q1[1], q1[2]}, {0, 0, 0}, "identity rotation");
  expect_close(rotate(nodes[3]["rotation"].get<std::vector<double>>(), {0, 0, -1}), {0, 0, 1}, "half turn");
}

TEST(ExportGltf, RotationsStayAccurateForDirectionsNearlyOppositeToMinusZ) {
  LightList list;
  // Travel direction in glTF is (-x, -z, y): these approach +Z there, where the
  // shortest-arc quaternion is nearly a half turn.
  for (double e : {1e-3, 1e-6, 1e-9, 1e-12}) list.lights.push_back(make_light(1, {e, 1, -e}, {1, 1, 1}, 0));
  const auto doc = nlohmann::json::parse(export_lights(list, ExportFormat::Gltf));
  for (size_t i = 0; i < list.lights.size(); ++i)
    expect_close(rotate(doc["nodes"][i]["rotation"].get<std::vector<double>>(), {0, 0, -1}),
                 -yup(list.lights[i].direction), "light " + std::to_string(i));
}

TEST(ExportGltf, AnEmptyListIsAValidSceneWithoutTheExtension) {
  LightList list;
  const auto doc = nlohmann::json::parse(export_lights(list, ExportFormat::Gltf));
  EXPECT_EQ(doc["asset"]["version"], "2.0");
  EXPECT_FALSE(doc.contains("extensionsUsed"));
  EXPECT_FALSE(doc.contains("nodes"));
  EXPECT_EQ(doc["scenes"].size(), 1u);
}

TEST(ExportCsv, RowsReadBackToTheSameLights) {
  const LightList list = sample_list();
  std::istringstream in(export_lights(list, ExportFormat::Csv));
  std::string line;
  ASSERT_TRUE(std::getline(in, line));
  EXPECT_EQ(line, "id,x,y,z,r,g,b,solid_angle,units");
  size_t i = 0;
  while (std::getline(in, line)) {
    ASSERT_LT(i, list.lights.size());
    std::vector<std::string> cells;
    std::stringstream row(line);
    for (std::string cell; std::getline(row, cell, ',');) cells.push_back(cell);
    ASSERT_EQ(cells.size(), 9u) << line;
    EXPECT_EQ(cells[8], to_string(list.units)) << line;
    const Light& l = list.lights[i];
    EXPECT_EQ(std::stoull(cells[0]), l.id);
    // Full precision: every double reads back bit for bit.
    EXPECT_EQ(std::stod(cells[1]), l.direction.x);
    EXPECT_EQ(std::stod(cells[2]), l.direction.y);
    EXPECT_EQ(std::stod(cells[3]), l.direction.z);
    for (int c = 0; c < 3; ++c) EXPECT_EQ(std::stod(cells[4 + c]), l.rgb[c]);
    EXPECT_EQ(std::stod(cells[7]), l.solid_angle);
    ++i;
  }
  EXPECT_EQ(i, list.lights.size());
}

void expect_same_list(const LightList& a, const LightList& b) {
  EXPECT_EQ(a.frame, b.frame);
  EXPECT_EQ(a.timestamp, b.timestamp);
  EXPECT_EQ(a.method, b.method);
  EXPECT_EQ(a.units, b.units);
  ASSERT_EQ(a.lights.size(), b.lights.size());
  for (size_t i = 0; i < a.lights.size(); ++i) {
    EXPECT_EQ(a.lights[i].id, b.lights[i].id);
    EXPECT_EQ(a.lights[i].direction.x, b.lights[i].direction.x);
    EXPECT_EQ(a.lights[i].direction.y, b.lights[i].direction.y);
    EXPECT_EQ(a.lights[i].direction.z, b.lights[i].direction.z);
    EXPECT_EQ(a.lights[i].rgb, b.lights[i].rgb);
    EXPECT_EQ(a.lights[i].solid_angle, b.lights[i].solid_angle);
  }
}

TEST(ExportJson, RoundTripsThroughTheLightListReader) {
  const LightList list = sample_list();
  const std::string text = export_lights(list, ExportFormat::Json);
  EXPECT_GT(std::count(text.begin(), text.end(), '\n'), 2);  // indented
  expect_same_list(light_list_from_json(text), list);
}

TEST(ExportNdjson, IsOneLineThatRoundTripsThroughTheLightListReader) {
  const LightList list = sample_list();
  const std::string text = export_lights(list, ExportFormat::Ndjson);
  ASSERT_FALSE(text.empty());
  EXPECT_EQ(std::count(text.begin(), text.end(), '\n'), 1);
  EXPECT_EQ(text.back(), '\n');
  expect_same_list(light_list_from_json(text), list);
}

TEST(ExportLights, RejectsNegativeOrNonFiniteColoursAndZeroDirections) {
  for (ExportFormat f : all_export_formats()) {
    LightList list = sample_list();
    list.lights[1].rgb[2] = -0.5;
    EXPECT_THROW(export_lights(list, f), InputError) << to_string(f);
    list = sample_list();
    list.lights[0].rgb[0] = std::nan("");
    EXPECT_THROW(export_lights(list, f), InputError) << to_string(f);
    list = sample_list();
    list.lights[3].direction = {0, 0, 0};
    EXPECT_THROW(export_lights(list, f), InputError) << to_string(f);
  }
}

TEST(ExportLights, ABlackLightIsWrittenWithZeroIntensity) {
  LightList list;
  list.lights.push_back(make_light(5, {0, 0, 1}, {0, 0, 0}, 0.1));
  const auto doc = nlohmann::json::parse(export_lights(list, ExportFormat::Gltf));
  EXPECT_EQ(doc["extensions"]["KHR_lights_punctual"]["lights"][0]["intensity"].get<double>(), 0.0);
  const std::string pbrt = export_lights(list, ExportFormat::Pbrt);
  EXPECT_EQ(all_after(pbrt, "\"float scale\"", 1).at(0).at(0), 0.0);
}

}  // namespace
}  // namespace lp
