#include "core/light_list.h"

#include <gtest/gtest.h>

#include <cmath>
#include <limits>
#include <nlohmann/json.hpp>

#include "core/error.h"

namespace lp {
namespace {

LightList sample_list() {
  LightList list;
  list.frame = 42;
  list.timestamp = 1700000000.123;
  list.method = "q2tree";
  list.units = Units::Radiance;
  Light a;
  a.id = 17;
  a.direction = normalize({0.1, -0.7, 0.3});
  a.rgb = {1.0 / 3.0, 2.718281828459045, 1e-300};
  a.solid_angle = 0.0123;
  Light b;
  b.id = std::numeric_limits<uint64_t>::max();
  b.direction = {0, 0, -1};
  b.rgb = {12345.678, 0, 0.1};
  b.solid_angle = 4 * M_PI;
  list.lights = {a, b};
  return list;
}

void expect_same(const LightList& a, const LightList& b) {
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
    for (int c = 0; c < 3; ++c) EXPECT_EQ(a.lights[i].rgb[c], b.lights[i].rgb[c]);
    EXPECT_EQ(a.lights[i].solid_angle, b.lights[i].solid_angle);
  }
}

TEST(LightList, RoundTripsThroughJsonExactly) {
  const LightList list = sample_list();
  expect_same(list, light_list_from_json(to_json(list)));
  expect_same(list, light_list_from_json(to_json(list, false)));
}

TEST(LightList, CompactJsonIsOneLine) {
  const std::string text = to_json(sample_list(), false);
  EXPECT_EQ(text.find('\n'), std::string::npos);
  EXPECT_NE(to_json(sample_list(), true).find('\n'), std::string::npos);
}

TEST(LightList, JsonCarriesTheFormatAndFrameConvention) {
  const auto doc = nlohmann::json::parse(to_json(sample_list()));
  EXPECT_EQ(doc.at("format"), "lightprobe.lights/1");
  EXPECT_EQ(doc.at("frame_convention"), "z-up");
  EXPECT_EQ(doc.at("units"), "radiance");
  EXPECT_EQ(doc.at("method"), "q2tree");
  EXPECT_EQ(doc.at("frame"), 42);
  ASSERT_EQ(doc.at("lights").size(), 2u);
  const auto& l = doc.at("lights")[0];
  EXPECT_EQ(l.at("id"), 17);
  EXPECT_EQ(l.at("direction").size(), 3u);
  EXPECT_EQ(l.at("rgb").size(), 3u);
  EXPECT_EQ(l.at("solid_angle"), 0.0123);
}

TEST(LightList, EmptyListRoundTrips) {
  LightList list;
  list.method = "pharr";
  const LightList back = light_list_from_json(to_json(list));
  EXPECT_TRUE(back.lights.empty());
  EXPECT_EQ(back.units, Units::Relative);
}

// Parses `text` expecting an InputError whose one-line message names the source.
void expect_rejected(const std::string& text, const std::string& why) {
  try {
    light_list_from_json(text, "frame7.json");
    ADD_FAILURE() << "accepted: " << why;
  } catch (const InputError& e) {
    const std::string msg = e.what();
    EXPECT_EQ(msg.rfind("frame7.json: ", 0), 0u) << msg;
    EXPECT_EQ(msg.find('\n'), std::string::npos) << msg;
  }
}

std::string edited(void (*edit)(nlohmann::json&)) {
  auto doc = nlohmann::json::parse(to_json(sample_list()));
  edit(doc);
  return doc.dump();
}

TEST(LightList, RejectsMalformedDocuments) {
  expect_rejected("", "empty");
  expect_rejected("{\"format\": ", "truncated");
  expect_rejected("[1, 2, 3]", "not an object");
  expect_rejected(edited([](nlohmann::json& d) { d["format"] = "lightprobe.lights/2"; }), "wrong format");
  expect_rejected(edited([](nlohmann::json& d) { d.erase("format"); }), "no format");
  expect_rejected(edited([](nlohmann::json& d) { d["frame_convention"] = "y-up"; }), "wrong frame");
  expect_rejected(edited([](nlohmann::json& d) { d["units"] = "lux"; }), "wrong units");
  expect_rejected(edited([](nlohmann::json& d) { d.erase("lights"); }), "no lights");
  expect_rejected(edited([](nlohmann::json& d) { d["lights"][0].erase("rgb"); }), "no rgb");
  expect_rejected(edited([](nlohmann::json& d) { d["lights"][1].erase("id"); }), "no id");
  expect_rejected(edited([](nlohmann::json& d) { d["lights"][0].erase("direction"); }), "no direction");
  expect_rejected(edited([](nlohmann::json& d) { d["lights"][0]["direction"] = {1, 1, 0}; }), "not unit");
  expect_rejected(edited([](nlohmann::json& d) { d["lights"][0]["direction"] = {0, 0}; }), "two numbers");
  expect_rejected(edited([](nlohmann::json& d) { d["lights"][0]["direction"] = {0, nullptr, 1}; }), "NaN");
  expect_rejected(edited([](nlohmann::json& d) { d["lights"][0]["rgb"] = {1, "x", 1}; }), "string");
  expect_rejected(edited([](nlohmann::json& d) { d["lights"][0]["id"] = -3; }), "negative id");
}

// Found by fuzz/fuzz_light_list: nlohmann throws out_of_range (not parse_error) for a
// number beyond a double, which escaped as an internal error.
TEST(LightList, ANumberBeyondADoubleIsBadInputNotAnInternalError) {
  EXPECT_THROW(light_list_from_json("{\"format\": 1e400}", "fuzz"), InputError);
  try {
    light_list_from_json("{\"frame\": 3, \"timestamp\": -2e308}", "upstream");
    ADD_FAILURE() << "accepted";
  } catch (const InputError& e) {
    EXPECT_EQ(std::string(e.what()), "upstream: not valid JSON (a number beyond the range of a double)");
  }
  expect_rejected("{\"format\": \"lightprobe.lights/1\", \"frame\": 1e999999}", "huge frame");
}

TEST(LightList, WrittenNanDirectionIsRejectedOnRead) {
  LightList list = sample_list();
  list.lights[0].direction.x = std::nan("");
  expect_rejected(to_json(list), "NaN direction");
}

TEST(LightList, TotalPowerSumsRgb) {
  const auto p = total_power(sample_list().lights);
  EXPECT_DOUBLE_EQ(p[0], 1.0 / 3.0 + 12345.678);
  EXPECT_DOUBLE_EQ(p[1], 2.718281828459045);
  EXPECT_DOUBLE_EQ(p[2], 1e-300 + 0.1);
  EXPECT_EQ(total_power(std::vector<Light>{})[0], 0.0);
}

}  // namespace
}  // namespace lp
