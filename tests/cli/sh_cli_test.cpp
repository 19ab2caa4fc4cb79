// `lightprobe sh` and the SH, units and GLB options of `lightprobe sample` as a user runs
// them: files that read back, warnings where units are relative, and bad input refused
// with one line and exit 2, leaving nothing written.
#include <gtest/gtest.h>

#include <nlohmann/json.hpp>

#include <algorithm>
#include <cmath>

#include "cli_run.h"
#include "core/envmap.h"
#include "core/image_io.h"

namespace lp::cli_test {
namespace {

const std::string kGrace = "probes-probulator-latlong256/grace.hdr";

TEST(ShCli, WritesNineCoefficientsThatReadBack) {
  const fs::path out = scratch() / "sh.json";
  const CliRun r = lightprobe("sh --json " + shared(kGrace) + " -o " + out.string());
  ASSERT_EQ(r.code, 0) << r.err;
  const auto doc = nlohmann::json::parse(slurp(out));
  EXPECT_EQ(doc["format"], "lightprobe.sh/1");
  EXPECT_EQ(doc["order"], 2);
  EXPECT_EQ(doc["frame_convention"], "z-up");
  ASSERT_EQ(doc["coefficients"].size(), 9u);
  const auto report = nlohmann::json::parse(r.out);
  EXPECT_EQ(report["coefficients"], doc["coefficients"]);
  EXPECT_GT(report["irradiance_up"].get<double>(), 0);
}

// A relative map's SH9 is written as it is with a warning, or scaled as `sample` scales
// lights: --normalize-illuminance LUX makes the SH's own irradiance facing up (luminance,
// x 683 lm/W, recomputed here from the written coefficients) exactly LUX.
TEST(ShCli, RelativeUnitsWarnOrAreScaledToTheAskedIlluminance) {
  const fs::path out = scratch() / "sh_units.json";
  CliRun r = lightprobe("sh " + shared(kGrace) + " -o " + out.string());
  ASSERT_EQ(r.code, 0) << r.err;
  EXPECT_NE(r.err.find("relative units"), std::string::npos) << r.err;
  const auto plain = nlohmann::json::parse(slurp(out));
  EXPECT_EQ(plain["units"], "relative");

  r = lightprobe("sh --json " + shared(kGrace) + " --normalize-illuminance 5000 -o " + out.string());
  ASSERT_EQ(r.code, 0) << r.err;
  EXPECT_EQ(r.err.find("warning"), std::string::npos) << r.err;
  const auto doc = nlohmann::json::parse(slurp(out));
  EXPECT_EQ(doc["units"], "radiance");
  // E(+z) = sum_i A_i L_i Y_i(+z): A = pi, 2pi/3, pi/4 per band; at +z only Y00, Y10, Y20 are non-zero.
  const double y00 = 0.282095, y10 = 0.488603, y20 = 0.315392 * 2;  // Y20(+z) = 0.315392 (3 z^2 - 1)
  double e[3];
  for (int c = 0; c < 3; ++c)
    e[c] = M_PI * y00 * doc["coefficients"][0][c].get<double>() + 2 * M_PI / 3 * y10 * doc["coefficients"][2][c].get<double>() +
           M_PI / 4 * y20 * doc["coefficients"][6][c].get<double>();
  const double lux = 683 * (0.2126 * e[0] + 0.7152 * e[1] + 0.0722 * e[2]);
  EXPECT_NEAR(lux, 5000, 5000 * 1e-4);
  // The factor is the ratio of the two files' coefficients.
  const double factor = nlohmann::json::parse(r.out)["scale_factor"].get<double>();
  EXPECT_NEAR(doc["coefficients"][0][1].get<double>(), factor * plain["coefficients"][0][1].get<double>(),
              1e-9 * std::abs(doc["coefficients"][0][1].get<double>()));
  expect_one_line_error(lightprobe("sh " + shared(kGrace) + " --scale 2 --exposure 1 -o " + out.string()), "at most one");
}

// SH9 has no "unknown": a hemisphere map's lower half reaches the engine as black light.
// Said in one warning with the share of the sphere the map holds; a whole map says nothing.
TEST(ShCli, AMapThatHoldsPartOfTheSphereSaysSo) {
  EnvMap sky = make_envmap(Layout::Hemisphere, 360, 90);
  std::fill(sky.rgb.begin(), sky.rgb.end(), 1.0f);
  const fs::path in = scratch() / "sky_hemisphere.exr", out = scratch() / "sky_sh.json";
  write_envmap(in.string(), sky);
  CliRun r = lightprobe("sh --json " + in.string() + " --normalize-illuminance 1000 -o " + out.string());
  ASSERT_EQ(r.code, 0) << r.err;
  EXPECT_NE(r.err.find(out.string() + ": the map holds 50 % of the sphere (a hemisphere map): SH9 takes the rest as black"),
            std::string::npos)
      << r.err;
  EXPECT_NEAR(nlohmann::json::parse(r.out)["sphere_covered"].get<double>(), 0.5, 1e-9);
  r = lightprobe("sh --json " + shared(kGrace) + " --normalize-illuminance 1000 -o " + out.string());
  ASSERT_EQ(r.code, 0) << r.err;
  EXPECT_EQ(r.err, "");
  EXPECT_NEAR(nlohmann::json::parse(r.out)["sphere_covered"].get<double>(), 1.0, 1e-9);
}

// A map black above the horizon sends no light upwards; its SH9's irradiance facing up is the
// projection's ringing (0.2 % of the downward one), and --normalize-illuminance scaled the
// coefficients x636 by it with exit 0 (an audit's), where `sample` refuses the same map.
TEST(ShCli, NoLightFromAboveCannotBeNormalisedToAnIlluminance) {
  EnvMap ground = make_envmap(Layout::LatLong, 128, 64);
  for (size_t i = 0; i < ground.pixel_count(); ++i)
    for (int c = 0; c < 3; ++c) ground.pixel(i)[c] = i / 128 < 32 ? 0.0f : 1.0f + float(i % 7);
  const fs::path in = scratch() / "ground_only.exr", out = scratch() / "ground_sh.json";
  write_envmap(in.string(), ground);
  expect_one_line_error(lightprobe("sh " + in.string() + " --normalize-illuminance 1000 -o " + out.string()),
                        "gives no illuminance on an upward-facing surface");
  EXPECT_FALSE(fs::exists(out));
  ASSERT_EQ(lightprobe("sh " + in.string() + " --scale 2 -o " + out.string()).code, 0);
}

TEST(ShCli, BadInputIsOneLineAndWritesNothing) {
  const fs::path out = scratch() / "never.json";
  fs::remove(out);
  expect_one_line_error(lightprobe("sh " + shared(kGrace) + " --order 3 -o " + out.string()), "--order");
  EXPECT_FALSE(fs::exists(out));
  // NaN radiance (PFM: no checks on write), and a map whose every pixel is masked out.
  EnvMap map = make_latlong(8, 4);
  const fs::path nan = scratch() / "nan.pfm";
  {
    std::string pfm = "PF\n8 4\n-1.0\n";
    std::vector<float> px(8 * 4 * 3, 1.0f);
    px[5] = NAN;
    pfm.append(reinterpret_cast<const char*>(px.data()), px.size() * sizeof(float));
    std::ofstream(nan, std::ios::binary) << pfm;
  }
  expect_one_line_error(lightprobe("sh " + nan.string() + " -o " + out.string()), "nan.pfm");
  map.valid.assign(map.pixel_count(), 0);
  const fs::path masked = scratch() / "masked.exr";
  write_envmap(masked.string(), map);
  expect_one_line_error(lightprobe("sh " + masked.string() + " -o " + out.string()), "masked.exr");
  EXPECT_FALSE(fs::exists(out));
}

// The prefiltered cube: the file holds the chain (levels, roughness), the DFG table is
// written when asked, and what the chain cannot hold is refused in one line naming it.
TEST(PrefilterCli, WritesTheCubeChainAndTheDfgTableAndRefusesWhatItCannotHold) {
  const fs::path cube = scratch() / "specular.exr", lut = scratch() / "dfg.exr";
  const CliRun r = lightprobe("prefilter --json " + shared(kGrace) + " --size 32 --lut-size 16 --lut " + lut.string() +
                              " -o " + cube.string());
  ASSERT_EQ(r.code, 0) << r.err;
  const auto report = nlohmann::json::parse(r.out);
  ASSERT_EQ(report["roughness"].size(), 2u);  // faces 32 and 16: roughness 0 and 1
  EXPECT_EQ(report["roughness"][1].get<double>(), 1.0);
  EXPECT_GT(fs::file_size(cube), 1000u);
  const RgbImage table = read_rgb_image(lut.string());
  EXPECT_EQ(table.width, 16);
  EXPECT_GT(table.rgb[3 * (16 * 0 + 15)], 0.9f);  // smooth, head-on: A near 1
  expect_one_line_error(lightprobe("prefilter " + shared(kGrace) + " -o " + (scratch() / "cube.png").string()), "cube.png");
  expect_one_line_error(lightprobe("prefilter " + shared(kGrace) + " --size 100 -o " + cube.string()), "--size");
}

// The chain's file is an OpenEXR cube map (envmap = cube), which every command reads as the
// latlong it holds (core/openexr_cube.h): `info` on it finds the map's power and its brightest
// direction (Grace Cathedral's window), as on the map itself. It was refused by its shape.
TEST(PrefilterCli, ItsCubeReadsBackAsTheMap) {
  const fs::path cube = scratch() / "specular.exr";
  ASSERT_EQ(lightprobe("prefilter " + shared(kGrace) + " --size 128 -o " + cube.string()).code, 0);
  const CliRun map = lightprobe("info --json " + shared(kGrace)), back = lightprobe("info --json " + cube.string());
  ASSERT_EQ(back.code, 0) << back.err;
  const auto a = nlohmann::json::parse(map.out), b = nlohmann::json::parse(back.out);
  EXPECT_EQ(b["layout"], "latlong");
  EXPECT_EQ(b["width"], 512);
  EXPECT_EQ(b["height"], 256);
  EXPECT_NEAR(b["power_luminance"].get<double>() / a["power_luminance"].get<double>(), 1.0, 0.03);
  double cos_angle = 0;
  for (int i = 0; i < 3; ++i)
    cos_angle += a["brightest_direction"][i].get<double>() * b["brightest_direction"][i].get<double>();
  EXPECT_GT(cos_angle, std::cos(2.0 * 3.14159265358979 / 180)) << "brightest directions more than 2 deg apart";
}

TEST(SampleCli, GlbIsBinaryGltfAndUnknownExtensionsAreRefused) {
  const fs::path glb = scratch() / "lights.glb";
  ASSERT_EQ(lightprobe("sample " + shared(kGrace) + " --method q2tree --n 16 -o " + glb.string()).code, 0);
  EXPECT_EQ(slurp(glb).substr(0, 4), "glTF");
  const fs::path txt = scratch() / "lights.txt";
  const CliRun r = lightprobe("sample " + shared(kGrace) + " --n 16 -o " + txt.string());
  expect_one_line_error(r, "lights.txt");
  EXPECT_NE(r.err.find(".glb"), std::string::npos) << r.err;
  EXPECT_FALSE(fs::exists(txt));
}

TEST(SampleCli, RelativeUnitsWarnOrScaleToTheIlluminanceAsked) {
  const fs::path gltf = scratch() / "lights.gltf";
  CliRun r = lightprobe("sample " + shared(kGrace) + " --n 16 -o " + gltf.string());
  ASSERT_EQ(r.code, 0) << r.err;
  EXPECT_NE(r.err.find("relative units"), std::string::npos) << r.err;
  r = lightprobe("sample " + shared(kGrace) + " --n 16 --normalize-illuminance 5000 -o " + gltf.string());
  ASSERT_EQ(r.code, 0) << r.err;
  EXPECT_EQ(r.err.find("relative units"), std::string::npos) << r.err;
  // Upward illuminance of the exported lights: sum over lights above the horizon of
  // Y(color) intensity cos(zenith); in glTF's Y-up frame the light shines along the node's
  // -Z, so that is where the rotation sends -Z, and "up" is +Y.
  const auto doc = nlohmann::json::parse(slurp(gltf));
  EXPECT_EQ(doc["asset"]["extras"]["units"], "radiance");
  double lux = 0;
  const auto& lights = doc["extensions"]["KHR_lights_punctual"]["lights"];
  for (size_t i = 0; i < lights.size(); ++i) {
    const auto& q = doc["nodes"][i]["rotation"];
    const double x = q[0], y = q[1], z = q[2], w = q[3];
    // Y component of (0, 0, -1) rotated by q: v + 2w (u x v) + 2 u x (u x v) gives 2 (w x - y z).
    const double travel_y = 2 * (w * x - y * z);
    const auto& c = lights[i]["color"];
    const double lum = 0.2126 * c[0].get<double>() + 0.7152 * c[1].get<double>() + 0.0722 * c[2].get<double>();
    lux += lum * lights[i]["intensity"].get<double>() * std::max(0.0, -travel_y);
  }
  EXPECT_NEAR(lux, 5000, 5000 * 1e-9);
  const fs::path out = scratch() / "zero.gltf";
  expect_one_line_error(lightprobe("sample " + shared(kGrace) + " --n 16 --normalize-illuminance 0 -o " + out.string()),
                        "--normalize-illuminance");
  EXPECT_FALSE(fs::exists(out));
  // Refused before any work: the sampling report ("16 pharr lights ... diffuse error") was
  // printed first and read as a success.
  const CliRun both = lightprobe("sample " + shared(kGrace) + " --n 16 --exposure 1 --scale 2 -o " + out.string());
  expect_one_line_error(both, "give at most one");
  EXPECT_EQ(both.out, "");
  EXPECT_FALSE(fs::exists(out));
}

TEST(SampleCli, ResidualSh9CarriesLightsAndAmbientAndScoresThem) {
  const fs::path out = scratch() / "residual.json";
  const CliRun r = lightprobe("sample --json " + shared(kGrace) + " --method pharr --n 4 --residual sh9 -o " + out.string());
  ASSERT_EQ(r.code, 0) << r.err;
  const auto doc = nlohmann::json::parse(slurp(out));
  EXPECT_EQ(doc["lights"].size(), 4u);
  EXPECT_EQ(doc["sh9"]["content"], "residual");
  const auto report = nlohmann::json::parse(r.out);
  EXPECT_LT(report["error"]["diffuse"].get<double>(), report["error_lights_only"]["diffuse"].get<double>());
  EXPECT_GT(report["milliseconds"].get<double>(), 0);  // the time of the lights + SH9, reported beside their error
  EXPECT_LT(report["milliseconds"].get<double>(), 60e3);
  expect_one_line_error(lightprobe("sample " + shared(kGrace) + " --n 4 --residual sh12 -o " + out.string()), "--residual");
}

}  // namespace
}  // namespace lp::cli_test
