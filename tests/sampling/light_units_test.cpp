// Units end to end: what each exporter writes for a calibrated list (glTF lux = 683 W m^-2),
// how a relative list is scaled (--exposure, --scale, --normalize-illuminance) or warned
// about, the GLB container, and unknown extensions refused.
#include "sampling/light_units.h"

#include <gtest/gtest.h>

#include <cmath>
#include <cstring>
#include <nlohmann/json.hpp>

#include "core/error.h"
#include "sampling/exporters.h"

namespace lp {
namespace {

Light light(Vec3 d, std::array<double, 3> rgb) {
  Light l;
  l.direction = normalize(d);
  l.rgb = rgb;
  return l;
}

// A sun straight up of 2 W m^-2 (grey) and a light on the horizon that lights nothing up.
LightList calibrated_list() {
  LightList list;
  list.units = Units::Radiance;
  list.lights = {light({0, 0, 1}, {2, 2, 2}), light({1, 0, 0}, {5, 1, 1})};
  return list;
}

uint32_t u32_at(const std::string& s, size_t at) {
  uint32_t v = 0;
  for (int b = 3; b >= 0; --b) v = (v << 8) | uint8_t(s[at + size_t(b)]);
  return v;
}

TEST(LightUnits, CalibratedGltfIntensityIsLuxAndBlendersStrengthIsTheIrradiance) {
  const auto doc = nlohmann::json::parse(export_lights(calibrated_list(), ExportFormat::Gltf));
  const auto& lights = doc["extensions"]["KHR_lights_punctual"]["lights"];
  // Sun: color (1, 1, 1), intensity 683 * 2 = 1366 lux; Blender: 1366 / 683 = 2 W m^-2.
  EXPECT_DOUBLE_EQ(lights[0]["intensity"].get<double>(), 1366.0);
  EXPECT_DOUBLE_EQ(lights[0]["intensity"].get<double>() / 683.0, 2.0);
  // Coloured light: color (1, 0.2, 0.2), intensity 683 * 5; color x intensity / 683 = rgb.
  EXPECT_DOUBLE_EQ(lights[1]["intensity"].get<double>(), 683.0 * 5);
  EXPECT_DOUBLE_EQ(lights[1]["color"][1].get<double>() * lights[1]["intensity"].get<double>() / 683, 1.0);
  // pbrt and Mitsuba take W m^-2 as they are: the same rgb numbers.
  EXPECT_NE(export_lights(calibrated_list(), ExportFormat::Mitsuba).find("value=\"5, 1, 1\""), std::string::npos);
  EXPECT_NE(export_lights(calibrated_list(), ExportFormat::Pbrt).find("\"float scale\" [5]"), std::string::npos);
  // A relative list keeps its numbers (and gets a warning when exported unscaled).
  LightList rel = calibrated_list();
  rel.units = Units::Relative;
  const auto rdoc = nlohmann::json::parse(export_lights(rel, ExportFormat::Gltf));
  EXPECT_DOUBLE_EQ(rdoc["extensions"]["KHR_lights_punctual"]["lights"][0]["intensity"].get<double>(), 2.0);
  const LightUnitsResult r = apply_light_units(rel, {}, "lights.gltf");
  EXPECT_NE(r.warning.find("lights.gltf: relative units"), std::string::npos) << r.warning;
  EXPECT_EQ(r.list.units, Units::Relative);
  EXPECT_TRUE(apply_light_units(calibrated_list(), {}, "x").warning.empty());
}

TEST(LightUnits, ExposureScaleAndIlluminanceTargetsGiveTheNumbersAsked) {
  LightList rel = calibrated_list();
  rel.units = Units::Relative;
  LightUnitsOptions o;
  o.exposure_ev = 3;
  LightUnitsResult r = apply_light_units(rel, o, "x");
  EXPECT_DOUBLE_EQ(r.list.lights[0].rgb[0], 16.0);
  EXPECT_EQ(r.list.units, Units::Radiance);
  o = {};
  o.scale = 0.25;
  EXPECT_DOUBLE_EQ(apply_light_units(rel, o, "x").list.lights[1].rgb[0], 1.25);
  // Upward illuminance: only the sun counts (the other is on the horizon): after scaling,
  // 683 Y(2 k) = 10000 lux, so k = 10000 / 1366; the glTF intensity is then 10000 lux.
  o = {};
  o.normalize_illuminance_lux = 10000;
  r = apply_light_units(rel, o, "x");
  EXPECT_NEAR(r.factor, 10000.0 / 1366.0, 1e-12);
  EXPECT_NEAR(upward_illuminance(r.list), 10000.0, 1e-9);
  const auto doc = nlohmann::json::parse(export_lights(r.list, ExportFormat::Gltf));
  EXPECT_NEAR(doc["extensions"]["KHR_lights_punctual"]["lights"][0]["intensity"].get<double>(), 10000.0, 1e-9);
  // An ambient SH9 counts too: a constant residual of radiance L adds pi L upwards.
  LightList amb = rel;
  amb.lights.clear();
  amb.sh9 = Sh9{};
  amb.sh9->coefficients[0] = {std::sqrt(4 * M_PI), std::sqrt(4 * M_PI), std::sqrt(4 * M_PI)};  // L = 1
  amb.sh9_content = Sh9Content::Residual;
  EXPECT_NEAR(upward_illuminance(amb), M_PI, 1e-12);
  r = apply_light_units(amb, o, "x");
  EXPECT_NEAR(upward_illuminance(r.list), 10000.0, 1e-6);
}

TEST(LightUnits, BadTargetsAreOneLineErrorsNamingTheFlag) {
  LightList rel = calibrated_list();
  rel.units = Units::Relative;
  auto message = [&](const LightUnitsOptions& o, const LightList& list) {
    try {
      apply_light_units(list, o, "x");
    } catch (const InputError& e) {
      return std::string(e.what());
    }
    return std::string("(accepted)");
  };
  LightUnitsOptions o;
  o.normalize_illuminance_lux = 0;
  EXPECT_NE(message(o, rel).find("--normalize-illuminance must be a positive"), std::string::npos);
  o.normalize_illuminance_lux = -5;
  EXPECT_NE(message(o, rel).find("--normalize-illuminance must be a positive"), std::string::npos);
  o = {};
  o.scale = 0;
  EXPECT_NE(message(o, rel).find("--scale must be positive"), std::string::npos);
  o.scale = 2;
  o.exposure_ev = 1;
  EXPECT_NE(message(o, rel).find("give at most one"), std::string::npos);
  // A factor that is not finite and positive: 2^1100 is inf, 2^-1100 is 0.
  o = {};
  o.exposure_ev = 1100;
  EXPECT_NE(message(o, rel).find("not a finite positive factor"), std::string::npos);
  o.exposure_ev = -1100;
  EXPECT_NE(message(o, rel).find("not a finite positive factor"), std::string::npos);
  // A calibrated list has its unit: --scale 3 tripled it without a word.
  o = {};
  o.scale = 3;
  EXPECT_NE(message(o, calibrated_list()).find("in radiance units already"), std::string::npos);
  o.scale = 1e308;  // overflows a light (5 x 1e308)
  EXPECT_EQ(message(o, rel).find("(accepted)"), std::string::npos);
  LightList down;
  down.lights = {light({0, 0, -1}, {1, 1, 1})};
  o = {};
  o.normalize_illuminance_lux = 100;
  try {
    apply_light_units(down, o, "x");
    FAIL();
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("--normalize-illuminance"), std::string::npos);
  }
}

TEST(ExportGlb, IsAHeaderAndOneSpacePaddedJsonChunkHoldingTheGltfDocument) {
  LightList list = calibrated_list();
  list.sh9 = Sh9{};
  list.sh9->coefficients[2] = {1, 0, 0};
  const std::string glb = export_lights(list, ExportFormat::Glb);
  ASSERT_GE(glb.size(), 20u);
  EXPECT_EQ(glb.substr(0, 4), "glTF");
  EXPECT_EQ(u32_at(glb, 4), 2u);
  EXPECT_EQ(u32_at(glb, 8), glb.size());
  const uint32_t chunk = u32_at(glb, 12);
  EXPECT_EQ(chunk % 4, 0u);
  EXPECT_EQ(glb.substr(16, 4), "JSON");
  EXPECT_EQ(20 + size_t(chunk), glb.size());  // no BIN chunk
  const std::string json = glb.substr(20);
  const size_t end = json.find_last_of('}') + 1;  // after it only the padding
  EXPECT_LT(json.size() - end, 4u);
  EXPECT_EQ(json.find_first_not_of(' ', end), std::string::npos);
  EXPECT_EQ(nlohmann::json::parse(json), nlohmann::json::parse(export_lights(list, ExportFormat::Gltf)));
}

TEST(ExportGltf, CarriesTheSh9InItsYupFrameScaledLikeTheIntensities) {
  LightList list = calibrated_list();
  list.sh9 = Sh9{};
  list.sh9->coefficients[1] = {1, 2, 3};  // Y1-1 ~ y of our frame is -z in glTF's: row 2, negated
  const auto doc = nlohmann::json::parse(export_lights(list, ExportFormat::Gltf));
  const auto& sh = doc["asset"]["extras"]["sh9"];
  EXPECT_EQ(sh["content"], "residual");
  EXPECT_DOUBLE_EQ(sh["coefficients"][2][2].get<double>(), -3 * 683.0);
  EXPECT_DOUBLE_EQ(sh["coefficients"][1][0].get<double>(), 0.0);
}

TEST(ExportFormatFor, UnknownExtensionsAreRefusedNamingTheFormatsThatExist) {
  EXPECT_EQ(export_format_for("", "lights.glb", false), ExportFormat::Glb);
  EXPECT_EQ(export_format_for("", "lights.json", true), ExportFormat::Ndjson);
  EXPECT_EQ(export_format_for("", "lights.jsonl", false), ExportFormat::Ndjson);
  EXPECT_EQ(export_format_for("gltf", "lights.txt", false), ExportFormat::Gltf);
  try {
    export_format_for("", "lights.txt", false);
    FAIL() << ".txt accepted";
  } catch (const InputError& e) {
    const std::string m = e.what();
    EXPECT_NE(m.find("lights.txt: unknown extension '.txt'"), std::string::npos) << m;
    for (const char* ext : {".json", ".ndjson", ".pbrt", ".xml", ".gltf", ".glb", ".csv"})
      EXPECT_NE(m.find(ext), std::string::npos) << ext;
    EXPECT_EQ(m.find('\n'), std::string::npos);
  }
}

}  // namespace
}  // namespace lp
