// The `lightprobe` command as a user and a script see it: exit codes, one-line errors
// naming the file, --json reports, nothing half-written, every real map readable.
#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include <algorithm>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>
#include <vector>

#include <sys/wait.h>
#include <unistd.h>

#include <cmath>

#include "core/accuracy.h"
#include "core/chromaticities.h"
#include "core/image_io.h"
#include "core/light_list.h"
#include "tests/cli/cli_run.h"
#include "tests/core/icc_blob.h"

namespace fs = std::filesystem;

using namespace lp::cli_test;

namespace {

std::string fmt_frame(const std::string& dir, int i) { return " " + dir + "/memorial00" + std::to_string(i) + ".png"; }

}  // namespace

TEST(Cli, VersionAndHelpSucceed) {
  CliRun v = lightprobe("--version");
  EXPECT_EQ(v.code, 0);
  EXPECT_NE(v.out.find("lightprobe 0."), std::string::npos) << v.out;
  for (const char* sub : {"--help", "info --help", "convert --help", "sample --help", "eval sampling --help",
                          "synth scene --help", "eval estimators --help"}) {
    CliRun h = lightprobe(sub);
    EXPECT_EQ(h.code, 0) << sub;
    EXPECT_NE(h.out.find("Usage"), std::string::npos) << sub;
    // A negated flag is shown as typed: "--no-progress", not CLI11's "--no-progress{false}".
    EXPECT_EQ(h.out.find("{false}"), std::string::npos) << sub << ": " << h.out;
  }
}

// A usage error is one line that names the command it is about (CLI11 printed two lines,
// and took a misspelt command for a missing one).
TEST(Cli, UnknownSubcommandAndMissingArgumentsExitTwoWithOneLineNamingTheCommand) {
  const CliRun unknown = lightprobe("frobnicate");
  expect_one_line_error(unknown, "'frobnicate' is not a command of lightprobe (commands: info,");
  expect_one_line_error(lightprobe("calib geometrc"), "'geometrc' is not a command of lightprobe calib (commands: geometric,");
  expect_one_line_error(lightprobe("info"), "info: FILE is required; see lightprobe info --help");
  expect_one_line_error(lightprobe("sample x.exr"), "sample: --output");  // -o missing
  expect_one_line_error(lightprobe("sample x.exr -o l.json --n 5 --n 6"), "sample: --n");
  expect_one_line_error(lightprobe("calib"), "calib: A subcommand is required; see lightprobe calib --help");
  const fs::path config = scratch() / "twice.toml";
  std::ofstream(config) << "[sample]\nn = 64\nn = 32\n";
  expect_one_line_error(lightprobe("--config " + config.string() + " sample x.exr -o l.json"), config.string());
}

TEST(Cli, InfoReadsEveryRealMapAndReportsJson) {
  const std::vector<std::string> maps = {
      "probes-blender-studiolights/city.exr",      "probes-blender-studiolights/courtyard.exr",
      "probes-blender-studiolights/forest.exr",    "probes-blender-studiolights/interior.exr",
      "probes-blender-studiolights/night.exr",     "probes-blender-studiolights/studio.exr",
      "probes-blender-studiolights/sunrise.exr",   "probes-blender-studiolights/sunset.exr",
      "probes-probulator-latlong256/ennis.hdr",    "probes-probulator-latlong256/grace.hdr",
      "probes-probulator-latlong256/pisa.hdr",     "probes-probulator-latlong256/uffizi.hdr",
      "probes-probulator-latlong256/wells.hdr",    "probes-threejs-spot-and-cube/spot1Lux.hdr",
      "probes-threejs-spot-and-cube/pisa_cube/px.hdr", "hdr-memorial-debevec/reference/memorial_radiance_hdrshop.hdr"};
  for (const auto& m : maps) {
    // A cube face and a fused photo are no map's shape: they are read as the layout given.
    const bool photo = m.find("pisa_cube") != std::string::npos || m.find("memorial") != std::string::npos;
    CliRun r = lightprobe("info --json " + shared(m) + (photo ? " --layout hemisphere" : ""));
    ASSERT_EQ(r.code, 0) << m << ": " << r.err;
    const auto j = nlohmann::json::parse(r.out);
    EXPECT_GT(j["power_luminance"].get<double>(), 0) << m;
    EXPECT_GT(j["luminance"]["max"].get<double>(), 0) << m;
  }
  // spot1Lux: one lit pixel whose L dw sums to 0.959 (PROVENANCE.md), at u=(597.5)/1024, v=(213.5)/512.
  CliRun r = lightprobe("info --json " + shared("probes-threejs-spot-and-cube/spot1Lux.hdr"));
  const auto j = nlohmann::json::parse(r.out);
  EXPECT_EQ(j["layout"], "latlong");
  EXPECT_NEAR(j["power_rgb"][0].get<double>(), 0.959, 0.002);
  const double phi = 2 * M_PI * 597.5 / 1024, theta = M_PI * 213.5 / 512;
  EXPECT_NEAR(j["brightest_direction"][0].get<double>(), std::sin(theta) * std::cos(phi), 1e-6);
  EXPECT_NEAR(j["brightest_direction"][2].get<double>(), std::cos(theta), 1e-6);
}

TEST(Cli, ConvertWorksOnEveryRealLatlongMapAndKeepsPower) {
  for (const std::string m : {"probes-blender-studiolights/sunrise.exr", "probes-probulator-latlong256/grace.hdr",
                              "probes-threejs-spot-and-cube/spot1Lux.hdr"}) {
    for (const std::string target : {"--layout healpix --nside 64", "--layout hemisphere --size 360x90",
                                     "--layout latlong --size 256x128"}) {
      const fs::path out = scratch() / "converted.exr";
      CliRun r = lightprobe("convert --json " + shared(m) + " " + out.string() + " " + target);
      ASSERT_EQ(r.code, 0) << m << " " << target << ": " << r.err;
      const auto j = nlohmann::json::parse(r.out);
      const double kept = j["power_out"].get<double>() / j["power_in"].get<double>();
      if (target.find("hemisphere") == std::string::npos) {
        EXPECT_NEAR(kept, 1.0, 1e-4) << m << " " << target;
        EXPECT_EQ(r.err.find("warning"), std::string::npos) << r.err;
      } else if (kept < 0.999) {  // the hemisphere keeps only the upper half: said, with how much went
        char pct[32];
        std::snprintf(pct, sizeof pct, "the %.1f %%", 100 * (1 - kept));
        EXPECT_NE(r.err.find("a hemisphere map holds the upper half only; " + std::string(pct)), std::string::npos)
            << m << ": " << r.err;
      }
      CliRun info = lightprobe("info --json " + out.string());
      ASSERT_EQ(info.code, 0) << info.err;
      EXPECT_NEAR(nlohmann::json::parse(info.out)["power_luminance"].get<double>(), j["power_out"].get<double>(),
                  1e-5 * j["power_out"].get<double>());
    }
  }
}

TEST(Cli, BadInputsGetOneLineNamingTheFileAndExitTwo) {
  const fs::path dir = scratch();
  // Missing file.
  expect_one_line_error(lightprobe("info " + (dir / "nope.exr").string()), "nope.exr");
  // Corrupt file (see hdr-memorial-debevec/PROVENANCE.md).
  expect_one_line_error(lightprobe("info " + shared("hdr-memorial-debevec/reference/memorial_CORRUPT_from_SSARCandy.hdr")),
                        "memorial_CORRUPT_from_SSARCandy.hdr");
  // Truncated file.
  {
    const std::string bytes = slurp(shared("probes-probulator-latlong256/grace.hdr"));
    std::ofstream(dir / "truncated.hdr", std::ios::binary) << bytes.substr(0, bytes.size() / 2);
    expect_one_line_error(lightprobe("info " + (dir / "truncated.hdr").string()), "truncated.hdr");
  }
  // Not an image at all, and an unknown extension.
  std::ofstream(dir / "text.exr") << "hello\n";
  expect_one_line_error(lightprobe("info " + (dir / "text.exr").string()), "text.exr");
  std::ofstream(dir / "map.xyz") << "hello\n";
  expect_one_line_error(lightprobe("info " + (dir / "map.xyz").string()), "map.xyz");
  // NaN pixels in a PFM.
  {
    std::ofstream f(dir / "nan.pfm", std::ios::binary);
    f << "PF\n4 2\n-1.0\n";
    for (int i = 0; i < 24; ++i) {
      const float v = i == 7 ? std::nanf("") : 1.0f;
      f.write(reinterpret_cast<const char*>(&v), 4);
    }
  }
  expect_one_line_error(lightprobe("info " + (dir / "nan.pfm").string()), "nan.pfm");
  // Wrong dimensions for a declared layout.
  expect_one_line_error(lightprobe("info --layout latlong " + shared("probes-threejs-spot-and-cube/pisa_cube/px.hdr")),
                        "px.hdr");
  // Unknown layout.
  expect_one_line_error(lightprobe("convert " + shared("probes-probulator-latlong256/grace.hdr") + " " +
                                   (dir / "x.exr").string() + " --layout cubist"),
                        "cubist");
  // Unwritable output: error, and nothing left behind.
  const fs::path unwritable = dir / "no_such_dir" / "out.exr";
  expect_one_line_error(lightprobe("convert " + shared("probes-probulator-latlong256/grace.hdr") + " " + unwritable.string() +
                                   " --layout healpix --nside 16"),
                        "out.exr");
  EXPECT_FALSE(fs::exists(unwritable));
  // Sampling bad input: n <= 0, an all-black map.
  expect_one_line_error(lightprobe("sample " + shared("probes-probulator-latlong256/grace.hdr") + " --n 0 -o " +
                                   (dir / "l.json").string()),
                        "--n");
  {
    std::ofstream f(dir / "black.pfm", std::ios::binary);
    f << "PF\n8 4\n-1.0\n";
    const float z = 0;
    for (int i = 0; i < 96; ++i) f.write(reinterpret_cast<const char*>(&z), 4);
  }
  expect_one_line_error(lightprobe("sample " + (dir / "black.pfm").string() + " --n 16 -o " + (dir / "l.json").string()),
                        "black.pfm");
  EXPECT_FALSE(fs::exists(dir / "l.json"));
}

// sample's report: the diffuse error by default, the glossy errors with --glossy-errors,
// each equal to the yardstick computed here from the map and the written lights.
TEST(Cli, SampleReportsDiffuseByDefaultAndGlossyWhenAsked) {
  const std::string map = shared("probes-probulator-latlong256/grace.hdr");
  const std::string out = (scratch() / "report.json").string();
  const CliRun plain = lightprobe("sample --json " + map + " --n 64 -o " + out);
  ASSERT_EQ(plain.code, 0) << plain.err;
  const auto p = nlohmann::json::parse(plain.out);
  EXPECT_TRUE(p["glossy10_error"].is_null());
  EXPECT_TRUE(p["glossy100_error"].is_null());
  EXPECT_NE(p["not_scored"].get<std::string>().find("--glossy-errors"), std::string::npos);
  const CliRun text = lightprobe("sample " + map + " --n 64 -o " + out);
  EXPECT_NE(text.out.find("glossy errors not scored (--glossy-errors)"), std::string::npos) << text.out;

  const CliRun full = lightprobe("sample --json --glossy-errors " + map + " --n 64 -o " + out);
  ASSERT_EQ(full.code, 0) << full.err;
  const auto f = nlohmann::json::parse(full.out);
  EXPECT_FALSE(f.contains("not_scored"));
  const lp::LightList lights = lp::light_list_from_json(slurp(out));
  const lp::EnvMap m = lp::read_envmap(map);
  const lp::LightError want = lp::light_error(lp::make_accuracy_reference(m), lights.lights);
  EXPECT_DOUBLE_EQ(p["diffuse_error"].get<double>(), want.diffuse);
  EXPECT_DOUBLE_EQ(f["diffuse_error"].get<double>(), want.diffuse);
  EXPECT_DOUBLE_EQ(f["glossy10_error"].get<double>(), want.glossy[0]);
  EXPECT_DOUBLE_EQ(f["glossy100_error"].get<double>(), want.glossy[1]);
}

// --n auto holds the measure asked for: glossy s=100 here, rescored by the report.
TEST(Cli, SampleAutoCountHoldsTheErrorMeasureAskedFor) {
  const std::string map = shared("probes-probulator-latlong256/grace.hdr");
  const std::string out = (scratch() / "measure.json").string();
  CliRun r = lightprobe("sample --json " + map + " --method q2tree --n auto --target-error 0.1 --error-measure glossy100 -o " + out);
  ASSERT_EQ(r.code, 0) << r.err;
  const auto report = nlohmann::json::parse(r.out);
  EXPECT_LE(report["glossy100_error"].get<double>(), 0.1);
  CliRun diffuse = lightprobe("sample --json " + map + " --method q2tree --n auto --target-error 0.1 -o " + out);
  ASSERT_EQ(diffuse.code, 0) << diffuse.err;
  EXPECT_GT(report["lights"].get<int>(), nlohmann::json::parse(diffuse.out)["lights"].get<int>());
  for (const std::string& command : {"sample " + map + " --n auto --error-measure specular -o " + out,
                                    "stream --source replay:" + map + " --n auto --error-measure specular"}) {
    const CliRun bad = lightprobe(command);
    EXPECT_EQ(bad.code, 2) << command;
    EXPECT_NE(bad.err.find("--error-measure: unknown measure 'specular'"), std::string::npos) << bad.err;
  }
}

TEST(Cli, SampleWritesALightListThatPreservesPower) {
  const fs::path out = scratch() / "lights.json";
  const fs::path png = scratch() / "lights.png";
  CliRun r = lightprobe("sample --json " + shared("probes-probulator-latlong256/grace.hdr") + " --method pharr --n 64 -o " +
                     out.string() + " --overlay " + png.string());
  ASSERT_EQ(r.code, 0) << r.err;
  const auto report = nlohmann::json::parse(r.out);
  EXPECT_EQ(report["lights"].get<int>(), 64);
  EXPECT_LT(report["diffuse_error"].get<double>(), 0.1);
  const auto list = nlohmann::json::parse(slurp(out));
  EXPECT_EQ(list["format"], "lightprobe.lights/1");
  EXPECT_EQ(list["frame_convention"], "z-up");
  EXPECT_EQ(list["lights"].size(), 64u);
  CliRun info = lightprobe("info --json " + shared("probes-probulator-latlong256/grace.hdr"));
  const auto map = nlohmann::json::parse(info.out);
  double sum = 0;
  for (const auto& l : list["lights"]) sum += l["rgb"][1].get<double>();
  EXPECT_NEAR(sum, map["power_rgb"][1].get<double>(), 1e-5 * sum);
  EXPECT_GT(fs::file_size(png), 1000u);
}

TEST(Cli, SynthSceneWritesAMapWhoseSunCarriesMostOfThePower) {
  const fs::path out = scratch() / "scene.exr";
  CliRun r = lightprobe("synth scene --json -o " + out.string() + " --size 512x256");
  ASSERT_EQ(r.code, 0) << r.err;
  const auto j = nlohmann::json::parse(r.out);
  EXPECT_GT(j["sun_power_luminance"].get<double>() / j["power_luminance"].get<double>(), 0.4);
  CliRun info = lightprobe("info --json " + out.string());
  EXPECT_NEAR(nlohmann::json::parse(info.out)["power_luminance"].get<double>(), j["power_luminance"].get<double>(),
              1e-5 * j["power_luminance"].get<double>());
}

TEST(Cli, ConvertAssemblesACubeMapDirectoryIntoALatlongMap) {
  const fs::path out = scratch() / "pisa_latlong.exr";
  CliRun r = lightprobe("convert --json " + shared("probes-threejs-spot-and-cube/pisa_cube") + " " + out.string() +
                        " --layout latlong --size 512x256");
  ASSERT_EQ(r.code, 0) << r.err;
  const auto j = nlohmann::json::parse(r.out);
  EXPECT_EQ(j["width"].get<int>(), 512);
  // Same scene as Probulator's pisa probe (differently processed): power within 10 %.
  CliRun ref = lightprobe("info --json " + shared("probes-probulator-latlong256/pisa.hdr"));
  const double p_ref = nlohmann::json::parse(ref.out)["power_luminance"].get<double>();
  EXPECT_NEAR(j["power_out"].get<double>() / p_ref, 1.0, 0.1);
  expect_one_line_error(lightprobe("convert " + scratch().string() + " " + (scratch() / "x.exr").string()),
                        scratch().string());
}

TEST(Cli, ASynthesisedSequenceIsSampledFrameByFrameWithStableIdsAndTheFilterDelayReported) {
  const fs::path dir = scratch() / "seq";
  CliRun s = lightprobe("synth sequence --json --scenario abrupt-switch --frames 12 --size 128x64 -o " + dir.string());
  ASSERT_EQ(s.code, 0) << s.err;
  EXPECT_TRUE(fs::exists(dir / "frame_0011.exr"));
  const auto truth = nlohmann::json::parse(slurp(dir / "truth.json"));
  EXPECT_EQ(truth["step_frame"].get<int>(), 6);

  const fs::path out = scratch() / "seq.ndjson";
  CliRun r = lightprobe("sample --json " + dir.string() + " --method hemigon --n 32 -o " + out.string());
  ASSERT_EQ(r.code, 0) << r.err;
  const auto report = nlohmann::json::parse(r.out);
  EXPECT_EQ(report["filter_delay_frames"].get<int>(), 4);
  EXPECT_EQ(report["frames"].size(), 12u);
  std::istringstream lines(slurp(out));
  std::string line;
  std::vector<nlohmann::json> frames;
  while (std::getline(lines, line)) frames.push_back(nlohmann::json::parse(line));
  ASSERT_EQ(frames.size(), 12u);
  for (size_t f = 0; f < frames.size(); ++f) {
    EXPECT_EQ(frames[f]["frame"].get<int>(), int(f));
    EXPECT_NEAR(frames[f]["timestamp"].get<double>(), double(f) / 21, 1e-9);
    ASSERT_EQ(frames[f]["lights"].size(), 32u);
    for (size_t i = 0; i < 32; ++i) EXPECT_EQ(frames[f]["lights"][i]["id"], frames[0]["lights"][i]["id"]);
  }
  // Known capture times replace --fps; a wrong count of them is refused.
  std::ofstream(dir / "timestamps.txt") << "0\n0.1\n0.2\n0.3\n0.4\n0.5\n0.6\n0.7\n0.8\n0.9\n1.0\n1.5\n";
  ASSERT_EQ(lightprobe("sample " + dir.string() + " --method q2tree --n 32 -o " + out.string()).code, 0);
  {
    std::istringstream l2(slurp(out));
    std::string last;
    while (std::getline(l2, line)) last = line;
    EXPECT_NEAR(nlohmann::json::parse(last)["timestamp"].get<double>(), 1.5, 1e-12);
  }
  std::ofstream(dir / "timestamps.txt") << "0\n0.1\n";
  expect_one_line_error(lightprobe("sample " + dir.string() + " --n 32 -o " + out.string()), "timestamps.txt");
  fs::remove(dir / "timestamps.txt");
  // Clustering bounds the count.
  CliRun c = lightprobe("sample --json " + dir.string() + " --method pharr --n 64 --cluster 10 -o " + out.string());
  ASSERT_EQ(c.code, 0) << c.err;
  const auto clustered = nlohmann::json::parse(c.out);  // kept alive: a range-for over a temporary's member dangles
  for (const auto& fr : clustered["frames"]) EXPECT_LE(fr["lights"].get<int>(), 10);
}

TEST(Cli, EvalTemporalWritesTheAtlasAndRejectsUnknownScenarios) {
  const fs::path dir = scratch() / "temporal";
  CliRun r = lightprobe("eval temporal --json scene --frames 8 --scenarios abrupt-switch,static-noise --methods q2tree,pharr -o " +
                        dir.string());
  ASSERT_EQ(r.code, 0) << r.err;
  const auto j = nlohmann::json::parse(r.out);
  ASSERT_EQ(j["rows"].size(), 4u);
  for (const auto& row : j["rows"])
    if (row["scenario"] == "abrupt-switch" && row["method"] == "q2tree") { EXPECT_LE(row["lag_frames"].get<double>(), 1.0); }
  EXPECT_TRUE(fs::exists(dir / "temporal.csv"));
  EXPECT_TRUE(fs::exists(dir / "temporal.svg"));
  expect_one_line_error(lightprobe("eval temporal scene --scenarios earthquake -o " + dir.string()), "earthquake");
}

TEST(Cli, HdrFuseOfMemorialBeatsNothingLessThanAValidRadianceImageAndBadBracketsExitTwo) {
  const std::string m = shared("hdr-memorial-debevec");
  std::string frames;
  for (int i = 61; i <= 76; ++i) frames += fmt_frame(m, i);
  const fs::path resp = scratch() / "resp.json", out = scratch() / "memorial.exr";
  ASSERT_EQ(lightprobe("hdr response " + frames + " --exposure-times " + m + "/exposures.csv --ignore-colour 0,0,255 -o " +
                       resp.string()).code,
            0);
  CliRun r = lightprobe("hdr fuse --json " + frames + " --exposure-times " + m + "/exposures.csv --response " +
                        resp.string() + " --ignore-colour 0,0,255 -o " + out.string());
  ASSERT_EQ(r.code, 0) << r.err;
  EXPECT_EQ(nlohmann::json::parse(r.out)["frames"].get<int>(), 16);
  // A fused photo is no map: described as a photo, with what makes a map of it, and its range.
  CliRun described = lightprobe("info --json " + out.string());
  ASSERT_EQ(described.code, 0) << described.err;
  const auto p = nlohmann::json::parse(described.out);
  EXPECT_EQ(p["kind"], "photo");
  EXPECT_EQ(p["width"], 512);
  EXPECT_GT(p["range_stops"].get<double>(), 15);
  EXPECT_NE(lightprobe("info " + out.string()).out.find("not a map: `lightprobe probe unwrap` makes a map of it"),
            std::string::npos);
  // Read as one layout it is a map, as before (no layout changes its range).
  CliRun info = lightprobe("info --json --layout hemisphere " + out.string());
  ASSERT_EQ(info.code, 0) << info.err;
  // Debevec's own map spans ~1e-3 .. 274 (5+ decades); ours must too, up to scale.
  const auto j = nlohmann::json::parse(info.out);
  EXPECT_GT(j["dynamic_range_stops"].get<double>(), 15);

  // One exposure; no exposure times for PNGs without EXIF; frames of different sizes.
  expect_one_line_error(lightprobe("hdr fuse " + fmt_frame(m, 61) + " --exposure-times 1 -o " + out.string()), "");
  expect_one_line_error(lightprobe("hdr fuse " + fmt_frame(m, 61) + fmt_frame(m, 62) + " -o " + out.string()),
                        "memorial0061.png");
  const std::string k = shared("hdr-mirrorball-kartik");
  expect_one_line_error(lightprobe("hdr fuse " + k + "/ball_1-10s.jpg " + k + "/ball_1-40s.jpg -o " + out.string()),
                        "ball_1-40s.jpg");
  // Photos that record ISO 100 and f/1.8 are fused at ISO 100 and f/1 (x 1.8^2); Memorial's
  // PNGs record neither and stay at code / t.
  // (Its longer frame: a brighter JPEG of the same photo, given the photo's EXIF segment; the
  // same file twice is not a bracket.)
  const std::string bright = (scratch() / "bright.jpg").string();
  ASSERT_EQ(lightprobe("preview " + k + "/ball_1-10s.jpg --percentile 0.3 -o " + bright).code, 0);
  {
    const std::string photo_bytes = slurp(k + "/ball_1-10s.jpg"), preview_bytes = slurp(bright);
    size_t at = 2;  // after SOI: walk the segments to APP1 "Exif"
    std::string exif;
    while (at + 4 < photo_bytes.size() && uint8_t(photo_bytes[at]) == 0xFF) {
      const size_t length = size_t(uint8_t(photo_bytes[at + 2])) << 8 | uint8_t(photo_bytes[at + 3]);
      if (uint8_t(photo_bytes[at + 1]) == 0xE1 && photo_bytes.compare(at + 4, 4, "Exif") == 0) {
        exif = photo_bytes.substr(at, 2 + length);
        break;
      }
      at += 2 + length;
    }
    ASSERT_FALSE(exif.empty());
    std::ofstream(bright, std::ios::binary) << preview_bytes.substr(0, 2) << exif << preview_bytes.substr(2);
  }
  const CliRun photo =
      lightprobe("hdr fuse --json " + k + "/ball_1-10s.jpg " + bright + " --exposure-times 0.1,0.4 -o " + out.string());
  ASSERT_EQ(photo.code, 0) << photo.err;
  const auto reference = nlohmann::json::parse(photo.out)["exposure_reference"];
  EXPECT_EQ(reference["iso"].get<double>(), 100);
  EXPECT_NEAR(reference["f_number"].get<double>(), 1.8, 1e-6);
  EXPECT_NEAR(reference["scale"].get<double>(), 3.24, 1e-5);
  EXPECT_FALSE(nlohmann::json::parse(r.out).contains("exposure_reference"));
  const CliRun told = lightprobe("hdr fuse " + k + "/ball_1-10s.jpg " + bright + " --exposure-times 0.1,0.4 -o " + out.string());
  EXPECT_NE(told.out.find("scaled x3.24 to ISO 100 and f/1 from the frames' ISO 100, f/1.8"), std::string::npos) << told.out;
}

TEST(Cli, PhotometricCalibrationRecoversAKnownScaleAndRejectsBadReadings) {
  const fs::path csv = scratch() / "readings.csv", cal = scratch() / "photometric.json";
  std::ofstream(csv) << "region,camera_value,measured,unit\npatch1,0.5,100,cd/m2\npatch2,1.0,200,cd/m2\n"
                        "patch3,2.0,400,cd/m2\nmeter,3.14159,628.318,lux\n";
  CliRun r = lightprobe("calib photometric --json " + csv.string() + " -o " + cal.string());
  ASSERT_EQ(r.code, 0) << r.err;
  EXPECT_NEAR(nlohmann::json::parse(r.out)["scale_luminance"].get<double>(), 200.0, 200.0 * 1e-6);
  std::ofstream(csv) << "region,camera_value,measured,unit\npatch1,0.5,-100,cd/m2\npatch2,1.0,200,cd/m2\n";
  expect_one_line_error(lightprobe("calib photometric " + csv.string() + " -o " + cal.string()), "readings.csv:2");
  // Readings that contradict each other (an audit's: ratios 200, 20, 2000, 2; a meter that
  // falls as the camera value rises; a meter that does not move) gave a k with exit 0.
  fs::remove(cal);
  for (const char* body : {"p1,0.5,100,cd/m2\np2,1.0,20,cd/m2\np3,2.0,4000,cd/m2\np4,4.0,8,cd/m2\n",
                           "p1,4.0,100,cd/m2\np2,2.0,200,cd/m2\np3,1.0,400,cd/m2\np4,0.5,800,cd/m2\n",
                           "p1,0.5,100,cd/m2\np2,1.0,100,cd/m2\np3,2.0,100,cd/m2\np4,4.0,100,cd/m2\n"}) {
    std::ofstream(csv) << "region,camera_value,measured,unit\n" << body;
    expect_one_line_error(lightprobe("calib photometric " + csv.string() + " -o " + cal.string()),
                          "readings.csv: the readings contradict each other");
    EXPECT_FALSE(fs::exists(cal));
  }
  // One wild reading: the robust fit keeps k, and the reading is named.
  std::ofstream(csv) << "region,camera_value,measured,unit\np1,0.5,100,cd/m2\np2,1.0,200,cd/m2\np3,2.0,400,cd/m2\n"
                        "p4,4.0,80000,cd/m2\n";
  const CliRun wild = lightprobe("calib photometric --json --loss huber " + csv.string() + " -o " + cal.string());
  ASSERT_EQ(wild.code, 0) << wild.err;
  EXPECT_NEAR(nlohmann::json::parse(wild.out)["scale_luminance"].get<double>(), 200.0, 200.0 * 0.05);
  EXPECT_NE(wild.err.find("reading 'p4' is off by"), std::string::npos) << wild.err;
  // A log sensor whose value falls as the light rises.
  std::ofstream(csv) << "region,camera_value,measured,unit\na,0.65,10,cd/m2\nb,0.5,40,cd/m2\nc,0.35,160,cd/m2\n"
                        "d,0.2,640,cd/m2\n";
  expect_one_line_error(lightprobe("calib photometric --model log " + csv.string() + " -o " + cal.string()),
                        "falls as the luminance rises");
}

TEST(Cli, ASynthesisedMirrorBallUnwrapsToTheMapItCameFrom) {
  const fs::path ball = scratch() / "ball.exr", map = scratch() / "unwrapped.exr";
  ASSERT_EQ(lightprobe("synth probe scene --type mirrorball --size 400x400 -o " + ball.string()).code, 0);
  CliRun r = lightprobe("probe unwrap --json " + ball.string() + " --type mirrorball --layout latlong --size 256x128 -o " +
                        map.string());
  ASSERT_EQ(r.code, 0) << r.err;
  const auto j = nlohmann::json::parse(r.out);
  const auto b = j["per_frame"][0]["ball"];
  EXPECT_NEAR(b[0].get<double>(), 200, 0.2);  // the renderer centres the ball, radius 40 % of 400
  EXPECT_NEAR(b[2].get<double>(), 160, 0.3);
  // How it was found: the sub-pixel rim fit, with standard errors well under its 0.2 px error bound.
  const auto fit = j["per_frame"][0]["ball_fit"];
  EXPECT_TRUE(fit["subpixel"].get<bool>());
  EXPECT_GT(fit["sigma_centre_px"].get<double>(), 0);
  EXPECT_LT(fit["sigma_centre_px"].get<double>(), 0.2);
  // The sun survives the round trip: most of the power in the brightest direction.
  CliRun info = lightprobe("info --json " + map.string());
  const auto d = nlohmann::json::parse(info.out)["brightest_direction"];
  const double theta = std::acos(d[2].get<double>()) * 180 / M_PI, phi = std::atan2(d[1].get<double>(), d[0].get<double>()) * 180 / M_PI;
  EXPECT_NEAR(theta, 50, 2);  // the procedural sun: theta 50, phi 30
  EXPECT_NEAR(phi, 30, 2);
  // No ball in a flat image.
  const fs::path flat = scratch() / "flat.pfm";
  {
    std::ofstream f(flat, std::ios::binary);
    f << "PF\n64 64\n-1.0\n";
    const float v = 0.5f;
    for (int i = 0; i < 64 * 64 * 3; ++i) f.write(reinterpret_cast<const char*>(&v), 4);
  }
  expect_one_line_error(lightprobe("probe unwrap " + flat.string() + " --type mirrorball -o " + map.string()), "flat.pfm");
  // A ball given by hand (--ball) too small to find is unwrapped as asked, with one warning.
  const CliRun tiny = lightprobe("probe unwrap " + ball.string() + " --type mirrorball --ball 200,200,5 --size 64x32 -o " +
                                 map.string());
  EXPECT_EQ(tiny.code, 0) << tiny.err;
  EXPECT_NE(tiny.err.find("warning: --ball radius 5 px: a ball under 8 px"), std::string::npos) << tiny.err;
  const CliRun given = lightprobe("probe unwrap " + ball.string() + " --type mirrorball --ball 200,200,160 --size 64x32 -o " +
                                  map.string());
  EXPECT_EQ(given.err.find("--ball radius"), std::string::npos) << given.err;
}

// CONVENTIONS.md: the probe's rotation is part of its metadata, the map is in the world
// frame. Unwrapped with --rotation, the sun turns with the probe and the file records the
// rotation (identity without one), which `info` and OpenImageIO's iinfo show.
TEST(Cli, AnUnwrappedMapRecordsTheProbeRotationItWasTurnedBy) {
  const fs::path ball = scratch() / "ball_r.exr", plain = scratch() / "plain_r.exr", turned = scratch() / "turned_r.exr";
  ASSERT_EQ(lightprobe("synth probe scene --type mirrorball --size 400x400 -o " + ball.string()).code, 0);
  const std::string unwrap = "probe unwrap " + ball.string() + " --type mirrorball --layout latlong --size 256x128 -o ";
  ASSERT_EQ(lightprobe(unwrap + plain.string()).code, 0);
  ASSERT_EQ(lightprobe(unwrap + turned.string() + " --rotation 90,0,0").code, 0);
  const auto info = [](const fs::path& f) {
    const CliRun r = lightprobe("info --json " + f.string());
    EXPECT_EQ(r.code, 0) << r.err;
    return nlohmann::json::parse(r.out);
  };
  const auto a = info(plain), b = info(turned);
  const std::vector<double> identity{1, 0, 0, 0, 1, 0, 0, 0, 1};
  EXPECT_EQ(a["world_from_probe"].get<std::vector<double>>(), identity);
  const lp::Mat3 yaw90 = lp::rotation_from_yaw_pitch_roll_deg(90, 0, 0);
  const auto got = b["world_from_probe"].get<std::vector<double>>();
  ASSERT_EQ(got.size(), 9u);
  for (size_t k = 0; k < 9; ++k) EXPECT_NEAR(got[k], yaw90.m[k], 1e-15) << k;
  // The sun (theta 50, phi 30 in the probe's frame) is at phi 120 in the turned world.
  const auto phi = [](const nlohmann::json& j) {
    const auto d = j["brightest_direction"];
    return std::atan2(d[1].get<double>(), d[0].get<double>()) * 180 / M_PI;
  };
  EXPECT_NEAR(phi(a), 30, 2);
  EXPECT_NEAR(phi(b), 120, 2);
  const auto ypr = b["probe_yaw_pitch_roll_deg"].get<std::vector<double>>();
  ASSERT_EQ(ypr.size(), 3u);
  EXPECT_NEAR(ypr[0], 90, 1e-9);
  EXPECT_NEAR(ypr[1], 0, 1e-9);
  EXPECT_NEAR(ypr[2], 0, 1e-9);
  EXPECT_NE(lightprobe("info " + turned.string()).out.find("yaw 90, pitch 0, roll 0 deg"), std::string::npos);
  // A matrix typed to four decimals, which --rotation accepts, is unwrapped with (and recorded
  // as) the exact rotation nearest to it: the yaw of 45 degrees it stands for.
  const fs::path typed = scratch() / "typed_r.exr";
  const CliRun tr = lightprobe(unwrap + typed.string() + " --rotation 0.7071,-0.7071,0,0.7071,0.7071,0,0,0,1");
  ASSERT_EQ(tr.code, 0) << tr.err;
  const auto t = info(typed)["world_from_probe"].get<std::vector<double>>();
  const lp::Mat3 yaw45 = lp::rotation_from_yaw_pitch_roll_deg(45, 0, 0);
  for (size_t k = 0; k < 9; ++k) EXPECT_NEAR(t[k], yaw45.m[k], 1e-12) << k;
  // OpenImageIO, a consumer that knows nothing of lightprobe, lists the attribute.
  if (std::system("command -v iinfo >/dev/null 2>&1") != 0) GTEST_SKIP() << "iinfo (openimageio-tools) not installed";
  std::string listing;
  if (FILE* p = popen(("iinfo -v " + turned.string() + " 2>&1").c_str(), "r")) {
    char buf[512];
    while (fgets(buf, sizeof buf, p)) listing += buf;
    pclose(p);
  }
  EXPECT_NE(listing.find("lightprobe.world_from_probe"), std::string::npos) << listing;
}

// A Mono12 frame saved as 16-bit PNG: its lamp clipped at code 4095 was unwrapped as a valid
// value of 4095 / 65535 and the report said no pixel clipped.
TEST(Cli, SixteenBitFramesOfATwelveBitSensorAreReadAtItsWhiteLevel) {
  const fs::path png = scratch() / "mono12.png", dark = scratch() / "dark16.png", map = scratch() / "mono12.exr";
  lp::RgbImage frame;
  frame.width = frame.height = 120;
  frame.rgb.assign(3 * 120 * 120, 1000.0f / 65535.0f);
  lp::write_code_image(dark.string(), frame, 16);  // no pile-up: the container's own scale
  for (int y = 57; y < 63; ++y)
    for (int x = 57; x < 63; ++x)
      for (int c = 0; c < 3; ++c) frame.rgb[3 * size_t(y * 120 + x) + c] = 4095.0f / 65535.0f;
  lp::write_code_image(png.string(), frame, 16);
  const std::string ball = " --type mirrorball --ball 60,60,50 --layout latlong --size 64x32 --codes linear -o " + map.string();
  CliRun r = lightprobe("probe unwrap --json " + png.string() + ball);
  ASSERT_EQ(r.code, 0) << r.err;
  EXPECT_NE(r.err.find(png.string() + ": its 16-bit codes stop at 4095, 108 values clipped there: read as a 12-bit "
                                      "sensor's codes, white level 4095"),
            std::string::npos)
      << r.err;
  EXPECT_NEAR(nlohmann::json::parse(r.out)["per_frame"][0]["clipped_fraction"].get<double>(), 36.0 / 14400, 1e-12);
  lp::EnvMap m = lp::read_envmap(map.string());
  EXPECT_NEAR(m.rgb[3 * (16 * 64 + 10)], 1000.0 / 4095.0, 1e-6);  // was 1000 / 65535
  r = lightprobe("probe unwrap --json " + dark.string() + ball);
  ASSERT_EQ(r.code, 0) << r.err;
  EXPECT_EQ(r.err.find("white level"), std::string::npos) << r.err;
  m = lp::read_envmap(map.string());
  EXPECT_NEAR(m.rgb[3 * (16 * 64 + 10)], 1000.0 / 65535.0, 1e-6);
}

// A photo's codes are made linear before they become a map (maps are radiance): an 8-bit
// PNG of code 128 unwraps to 0.2158605, sRGB's decoding, not 0.502; a 16-bit one says how
// its codes encode light (--codes) or is refused, and nothing is written.
TEST(Cli, APhotosCodesAreMadeLinearBeforeTheyBecomeAMap) {
  const fs::path png8 = scratch() / "grey8.png", png16 = scratch() / "grey16.png", map = scratch() / "grey.exr";
  lp::RgbImage grey;
  grey.width = grey.height = 120;
  grey.rgb.assign(3 * 120 * 120, 128.0f / 255.0f);
  lp::write_code_image(png8.string(), grey, 8);
  grey.rgb.assign(3 * 120 * 120, 30000.0f / 65535.0f);
  lp::write_code_image(png16.string(), grey, 16);
  const std::string ball = " --type mirrorball --ball 60,60,50 --layout latlong --size 64x32 -o " + map.string();
  CliRun r = lightprobe("probe unwrap --json " + png8.string() + ball);
  ASSERT_EQ(r.code, 0) << r.err;
  const auto frame = nlohmann::json::parse(r.out)["per_frame"][0];
  EXPECT_EQ(frame["codes"], "srgb");
  EXPECT_EQ(frame["clipped_fraction"].get<double>(), 0.0);
  lp::EnvMap m = lp::read_envmap(map.string());
  EXPECT_NEAR(m.rgb[3 * (16 * 64 + 10)], 0.2158605, 1e-6);
  fs::remove(map);
  // A photo with a clipped light (36 of 14,400 pixels at the top code) says so once.
  const fs::path lamp = scratch() / "lamp8.png";
  grey.rgb.assign(3 * 120 * 120, 128.0f / 255.0f);
  for (int y = 57; y < 63; ++y)
    for (int x = 57; x < 63; ++x) grey.rgb[3 * size_t(y * 120 + x)] = 1.0f;
  lp::write_code_image(lamp.string(), grey, 8);
  r = lightprobe("probe unwrap --json " + lamp.string() + ball);
  ASSERT_EQ(r.code, 0) << r.err;
  EXPECT_NEAR(nlohmann::json::parse(r.out)["per_frame"][0]["clipped_fraction"].get<double>(), 36.0 / 14400, 1e-12);
  EXPECT_NE(r.err.find(lamp.string() + ": 0.25 % of its pixels are at the top code"), std::string::npos) << r.err;
  fs::remove(map);
  const CliRun refused = lightprobe("probe unwrap " + png16.string() + ball);
  expect_one_line_error(refused, png16.string());
  EXPECT_NE(refused.err.find("16-bit camera codes may be linear"), std::string::npos) << refused.err;
  EXPECT_FALSE(fs::exists(map));
  r = lightprobe("probe unwrap " + png16.string() + ball + " --codes linear");
  ASSERT_EQ(r.code, 0) << r.err;
  m = lp::read_envmap(map.string());
  EXPECT_NEAR(m.rgb[3 * (16 * 64 + 10)], 30000.0 / 65535.0, 1e-6);
  // A response from `hdr response` (g(z) = ln E per level): code 128 of channel c is worth
  // exp g(128) = (c + 1) (128 + 1) / 256 here, per channel.
  const fs::path response = scratch() / "grey_response.json";
  {
    nlohmann::json g;
    const char* names[] = {"r", "g", "b"};
    for (int c = 0; c < 3; ++c) {
      std::vector<double> levels;
      for (int z = 0; z < 256; ++z) levels.push_back(std::log((c + 1) * (z + 1.0) / 256));
      g[names[c]] = levels;
    }
    std::ofstream(response) << nlohmann::json{{"format", "lightprobe.response/1"}, {"levels", 256}, {"linear", false},
                                              {"log_exposure", g}}.dump();
  }
  r = lightprobe("probe unwrap --json " + png8.string() + ball + " --codes " + response.string());
  ASSERT_EQ(r.code, 0) << r.err;
  EXPECT_EQ(nlohmann::json::parse(r.out)["per_frame"][0]["codes"], response.string());
  m = lp::read_envmap(map.string());
  for (int c = 0; c < 3; ++c) EXPECT_NEAR(m.rgb[3 * (16 * 64 + 10) + c], (c + 1) * 129.0 / 256, 1e-5) << c;
}

// A photo in Display P3 (a matrix ICC profile) was unwrapped as if sRGB; hdr fuse already
// read a bracket's profile. The map is now the sRGB reading turned by the profile's matrix.
TEST(Cli, AProbePhotosIccProfileTurnsItsColoursToRec709) {
  const fs::path plain = scratch() / "p3_plain.jpg", tagged = scratch() / "p3_tagged.jpg";
  std::vector<float> rgb;
  for (int y = 0; y < 120; ++y)
    for (int x = 0; x < 120; ++x) rgb.insert(rgb.end(), {0.2f + 0.6f * x / 119, 0.5f, 0.2f + 0.6f * y / 119});
  lp::write_display_image(plain.string(), 120, 120, rgb);
  {
    std::ifstream in(plain, std::ios::binary);
    const std::string jpeg((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
    const std::string app2 = std::string("ICC_PROFILE\0", 12) + char(1) + char(1) + lp::icc_blob("Display P3", &lp::kP3Colorants);
    const size_t length = app2.size() + 2;
    std::ofstream(tagged, std::ios::binary) << jpeg.substr(0, 2) << char(0xFF) << char(0xE2) << char(length >> 8)
                                            << char(length & 0xff) << app2 << jpeg.substr(2);
  }
  const std::string ball = " --type mirrorball --ball 60,60,50 --layout latlong --size 64x32 -o ";
  const fs::path a = scratch() / "p3_plain.exr", b = scratch() / "p3_tagged.exr";
  ASSERT_EQ(lightprobe("probe unwrap " + plain.string() + ball + a.string()).code, 0);
  const CliRun r = lightprobe("probe unwrap --json " + tagged.string() + ball + b.string());
  ASSERT_EQ(r.code, 0) << r.err;
  EXPECT_EQ(nlohmann::json::parse(r.out)["colour_profile"], "Display P3");
  const auto m = lp::icc_colorants_to_rec709(*lp::summarize_icc_profile(lp::icc_blob("Display P3", &lp::kP3Colorants)), "t");
  const lp::RgbImage sa = lp::read_rgb_image(a.string()), sb = lp::read_rgb_image(b.string());
  ASSERT_EQ(sa.rgb.size(), sb.rgb.size());
  size_t compared = 0;
  for (size_t p = 0; p < sa.rgb.size() / 3; ++p) {
    if (!sa.valid.empty() && !sa.valid[p]) continue;
    const float* x = &sa.rgb[3 * p];
    for (int c = 0; c < 3; ++c) {
      const double want = m[3 * c] * x[0] + m[3 * c + 1] * x[1] + m[3 * c + 2] * x[2];
      ASSERT_NEAR(sb.rgb[3 * p + size_t(c)], std::max(want, 0.0), 1e-5) << "pixel " << p << " channel " << c;
    }
    ++compared;
  }
  EXPECT_GT(compared, 1000u);
  // A replay of such photos streams in Rec. 709 too (live/pipeline.h to_rec709).
  const fs::path replay = scratch() / "p3_replay";
  fs::remove_all(replay);
  fs::create_directories(replay);
  fs::copy_file(tagged, replay / "frame_0.jpg");
  const CliRun stream = lightprobe("stream --json --source replay:" + replay.string() + " --fov 180 --duration 1 --listen 127.0.0.1:0");
  ASSERT_EQ(stream.code, 0) << stream.err;
  EXPECT_EQ(nlohmann::json::parse(stream.out)["colour_profile"], "Display P3");
}

TEST(Cli, TrackingTheBallFrameByFrameKeepsTheUnwrappedMapStillWhenTheCameraShakes) {
  const fs::path world = scratch() / "nosun.exr", seq = scratch() / "ballseq", out = scratch() / "ballseq_maps";
  ASSERT_EQ(lightprobe("synth scene --no-sun --size 512x256 -o " + world.string()).code, 0);
  ASSERT_EQ(lightprobe("synth probe " + world.string() + " --type mirrorball --size 256x256 --frames 8 --jitter 1.5 "
                       "--noise 0.01 -o " + seq.string()).code,
            0);
  CliRun tracked = lightprobe("probe unwrap --json " + seq.string() + " --type mirrorball --layout latlong --size 128x64 -o " +
                              out.string());
  ASSERT_EQ(tracked.code, 0) << tracked.err;
  CliRun fixed = lightprobe("probe unwrap --json " + seq.string() +
                            " --type mirrorball --fixed-ball --layout latlong --size 128x64 -o " + out.string());
  ASSERT_EQ(fixed.code, 0) << fixed.err;
  const double jt = nlohmann::json::parse(tracked.out)["map_jitter_deg"].get<double>();
  const double jf = nlohmann::json::parse(fixed.out)["map_jitter_deg"].get<double>();
  EXPECT_LT(jt, 0.3);
  EXPECT_LT(jt * 5, jf);
  EXPECT_TRUE(fs::exists(out / "frame_0007.exr"));
}

TEST(Cli, DifferentlyCroppedBallPhotosAreRegisteredFusedAndUnwrapped) {
  const std::string k = shared("hdr-mirrorball-kartik");
  const fs::path dir = scratch() / "kartik";
  CliRun reg = lightprobe("probe register --json " + k + "/ball_1-10s.jpg " + k + "/ball_1-40s.jpg " + k +
                          "/ball_1-160s.jpg --size 320 -o " + dir.string());
  ASSERT_EQ(reg.code, 0) << reg.err;
  const fs::path fused = scratch() / "kartik.exr", map = scratch() / "kartik_map.exr", png = scratch() / "kartik.png";
  // The JPEGs' EXIF times are not in the registered PNGs: exposures.csv beside them has them,
  // named, so a glob in any order finds its own. Their ISO 100 and f/1.8 are folded in (the
  // exposure at ISO 100, f/1: 0.1 s / 1.8^2), as hdr fuse scales a map of the photos.
  EXPECT_EQ(slurp(dir / "exposures.csv"),
            "# seconds x (ISO / 100) / f-number^2: the exposure at ISO 100 and f/1, as hdr fuse scales maps\n"
            "file,exposure_s\nball_1-10s.png,0.0308642\nball_1-40s.png,0.00771605\nball_1-160s.png,0.00192901\n");
  CliRun fuse = lightprobe("hdr fuse " + (dir / "ball_1-160s.png").string() + " " + (dir / "ball_1-10s.png").string() +
                           " " + (dir / "ball_1-40s.png").string() + " --exposure-times " + (dir / "exposures.csv").string() +
                           " -o " + fused.string());
  ASSERT_EQ(fuse.code, 0) << fuse.err;
  CliRun un = lightprobe("probe unwrap --json " + fused.string() + " --type mirrorball --layout latlong --size 256x128 -o " +
                         map.string());
  ASSERT_EQ(un.code, 0) << un.err;
  // Where register put the ball, recorded in each PNG and carried by hdr fuse: taken, not
  // searched for (the search found no sub-pixel rim on this canvas and missed by 0.8 px).
  const auto frame = nlohmann::json::parse(un.out)["per_frame"][0];
  const auto registered = nlohmann::json::parse(reg.out)["registered_ball"];
  EXPECT_EQ(frame["ball_source"], "recorded");
  for (int k = 0; k < 3; ++k) EXPECT_EQ(frame["ball"][k].get<double>(), registered[k].get<double>()) << k;
  EXPECT_EQ(un.err.find("rim"), std::string::npos) << un.err;
  EXPECT_NEAR(frame["ball"][0].get<double>(), 160, 1e-9);  // registered to the centre
  EXPECT_NEAR(frame["ball"][1].get<double>(), 160, 1e-9);
  // info says what each holds: the registered PNG's codes and ball, the fused photo's.
  const auto png_info = nlohmann::json::parse(lightprobe("info --json " + (dir / "ball_1-40s.png").string()).out);
  EXPECT_EQ(png_info["kind"], "photo");
  EXPECT_EQ(png_info["code_bits"], 8);
  EXPECT_GT(png_info["clipped_fraction"].get<double>(), 0.001);  // the 1/40 s photo clips its lamps
  EXPECT_LT(png_info["valid_fraction"].get<double>(), 1.0);      // beyond the photo's edge: no data
  EXPECT_EQ(png_info["mirror_ball"], registered);
  const auto fused_info = nlohmann::json::parse(lightprobe("info --json " + fused.string()).out);
  EXPECT_EQ(fused_info["mirror_ball"], registered);
  EXPECT_GT(fused_info["range_stops"].get<double>(), 5);
  EXPECT_EQ(nlohmann::json::parse(lightprobe("info --json " + map.string()).out)["kind"], "map");
  const auto jpeg_info = nlohmann::json::parse(lightprobe("info --json " + k + "/ball_1-10s.jpg").out);
  EXPECT_NEAR(jpeg_info["exposure_s"].get<double>(), 0.1, 1e-9);
  EXPECT_NEAR(jpeg_info["f_number"].get<double>(), 1.8, 1e-6);
  // OpenImageIO, a consumer that knows nothing of lightprobe, reads the PNG's alpha and the
  // record in both files.
  if (std::system("command -v iinfo >/dev/null 2>&1") == 0) {
    for (const fs::path& f : {dir / "ball_1-10s.png", fused}) {
      std::string listing;
      if (FILE* p = popen(("iinfo -v " + f.string() + " 2>&1").c_str(), "r")) {
        char buf[512];
        while (fgets(buf, sizeof buf, p)) listing += buf;
        pclose(p);
      }
      EXPECT_NE(listing.find("channel list: R, G, B, A"), std::string::npos) << listing;
      EXPECT_NE(listing.find("lightprobe.mirror_ball: \"160 160 "), std::string::npos) << listing;
    }
  }
  // --ball still overrides it.
  CliRun given = lightprobe("probe unwrap --json " + fused.string() +
                            " --type mirrorball --ball 161,159,150 --layout latlong --size 64x32 -o " + map.string());
  ASSERT_EQ(given.code, 0) << given.err;
  EXPECT_EQ(nlohmann::json::parse(given.out)["per_frame"][0]["ball_source"], "given");
  EXPECT_EQ(nlohmann::json::parse(given.out)["per_frame"][0]["ball"][0].get<double>(), 161);
  ASSERT_EQ(lightprobe("preview " + fused.string() + " -o " + png.string()).code, 0);
  EXPECT_GT(fs::file_size(png), 1000u);
}

// Registered photos keep what they hold: all were written as 8-bit PNGs, so radiance was
// clipped at 1 and 16-bit codes lost 8 bits.
TEST(Cli, RegisteredPhotosKeepTheirRadianceOrTheirBitDepth) {
  const fs::path dir = scratch() / "register_kinds";
  fs::remove_all(dir);
  fs::create_directories(dir);
  const std::string map = shared("probes-probulator-latlong256/ennis.hdr");
  const fs::path a = dir / "a.exr", b = dir / "b.exr";
  ASSERT_EQ(lightprobe("synth probe " + map + " --size 300x300 -o " + a.string()).code, 0);
  ASSERT_EQ(lightprobe("synth probe " + map + " --size 340x320 -o " + b.string()).code, 0);
  fs::create_directories(dir / "exr");
  std::ofstream(dir / "exr" / "exposures.csv") << "file,exposure_s\na.exr,0.5\n";  // an earlier run's
  const CliRun exr = lightprobe("probe register " + a.string() + " " + b.string() + " --size 256 -o " + (dir / "exr").string());
  ASSERT_EQ(exr.code, 0) << exr.err;
  const lp::RgbImage in = lp::read_rgb_image(a.string()), out = lp::read_rgb_image((dir / "exr" / "a.exr").string());
  const float in_max = *std::max_element(in.rgb.begin(), in.rgb.end());
  const float out_max = *std::max_element(out.rgb.begin(), out.rgb.end());
  EXPECT_GT(in_max, 10.0f);
  EXPECT_GT(out_max, 0.5f * in_max) << "radiance above 1 kept (resampled)";
  EXPECT_FALSE(fs::exists(dir / "exr" / "exposures.csv")) << "maps have no exposure time, and an old list is not theirs";
  ASSERT_TRUE(out.mirror_ball.has_value()) << "an EXR records where the ball was put";
  EXPECT_NEAR((*out.mirror_ball)[0], 128, 1e-9);
  // 16-bit codes: the same photo at 1/64 of its radiance, as a 16-bit camera stored it.
  lp::RgbImage codes = in;
  for (float& v : codes.rgb) v = std::min(1.0f, v / 64);
  lp::write_code_image((dir / "c.png").string(), codes, 16);
  lp::write_code_image((dir / "d.png").string(), codes, 16);
  ASSERT_EQ(lightprobe("probe register " + (dir / "c.png").string() + " " + (dir / "d.png").string() + " --size 256 -o " +
                       (dir / "png").string())
                .code,
            0);
  const lp::RgbImage c = lp::read_rgb_image((dir / "png" / "c.png").string());
  EXPECT_EQ(c.code_bits, 16);
  ASSERT_TRUE(c.mirror_ball.has_value()) << "a PNG records where the ball was put";
  EXPECT_EQ(*c.mirror_ball, *out.mirror_ball);
  size_t between = 0;  // values that are no 8-bit code
  for (float v : c.rgb) between += std::abs(v * 255 - std::round(v * 255)) > 0.01f;
  EXPECT_GT(between, c.rgb.size() / 4);
}

TEST(Cli, GeometricCalibrationRecoversASyntheticFisheyeAndRefusesBadSets) {
  const fs::path boards = scratch() / "boards", out = scratch() / "cal";
  fs::create_directories(out);
  ASSERT_EQ(lightprobe("synth boards --views 10 --seed 3 -o " + boards.string()).code, 0);
  std::string images;
  for (int i = 0; i < 10; ++i) images += " " + (boards / ("board_0" + std::to_string(i) + ".png")).string();
  CliRun r = lightprobe("calib geometric --json" + images + " --board 9x6 --square 30 -o " + (out / "cam.cameramodel").string());
  ASSERT_EQ(r.code, 0) << r.err;
  const auto j = nlohmann::json::parse(r.out);
  EXPECT_EQ(j["lensmodel"], "LENSMODEL_KANNALA_BRANDT");  // the model the views were rendered with
  EXPECT_LT(j["cross_validation_px"].get<double>(), 0.5);
  // The selection ranked on the cross-validation repeated over 8 splits (10 views: a small
  // set, SelectionOptions::small_set_views); the chosen model's per-split values are in its
  // table row, the first being the odd/even one.
  EXPECT_EQ(j["selection"]["ranked_on"], "cross_validation_repeated_px");
  EXPECT_EQ(j["selection"]["splits"].get<int>(), 8);
  bool chosen_row = false;
  for (const auto& row : j["table"]) {
    // A row the race stopped (SelectionOptions::race_dear_candidates) holds only the splits
    // it was fitted on and no repeated value; every row says whether it was.
    ASSERT_TRUE(row["raced_out"].is_boolean()) << row["model"];
    if (row["raced_out"].get<bool>()) {
      EXPECT_NE(row["model"], j["selected"]);
      EXPECT_LT(row["cross_validation_splits_px"].size(), 8u) << row["model"];
      EXPECT_TRUE(row["cross_validation_repeated_px"].is_null()) << row["model"];
    }
  }
  for (const auto& row : j["table"])
    if (row["model"] == j["selected"]) {
      chosen_row = true;
      ASSERT_EQ(row["cross_validation_splits_px"].size(), 8u);
      EXPECT_FALSE(row["outfitted"].get<bool>());  // the pick is never one that another outfits
      EXPECT_EQ(row["cross_validation_splits_px"][0].get<double>(), row["cross_validation_px"].get<double>());
      EXPECT_EQ(row["cross_validation_repeated_px"].get<double>(), j["cross_validation_repeated_px"].get<double>());
    }
  EXPECT_TRUE(chosen_row);
  // Kannala-Brandt is not an mrcal model: the YAML holds it, and it loads back in OpenCV's
  // keys; the .cameramodel holds the best mrcal candidate of the same solve (the stand-in),
  // near the choice over the covered area, and the report says which file holds what.
  EXPECT_TRUE(fs::exists(out / "cam.yaml"));
  EXPECT_NE(slurp(out / "cam.yaml").find("distortion_model: fisheye"), std::string::npos);
  // The 197 degree lens sees beyond 90 degrees, where cv::fisheye projects rays to the wrong side.
  EXPECT_NE(r.err.find((out / "cam.yaml").string() + ": the model maps the frame's edges to rays up to "), std::string::npos) << r.err;
  EXPECT_NE(r.err.find("OpenCV's cv::fisheye functions take rays within 90 degrees only"), std::string::npos) << r.err;
  const auto& stand_in = j["mrcal_stand_in"];
  ASSERT_TRUE(stand_in.is_object()) << j.dump();
  EXPECT_EQ(stand_in["file"], (out / "cam.cameramodel").string());
  EXPECT_EQ(j["output"], (std::vector<std::string>{(out / "cam.cameramodel").string(), (out / "cam.yaml").string()}));
  EXPECT_TRUE(j["optimization_inputs"].get<bool>());
  EXPECT_LT(stand_in["median_from_chosen_px"].get<double>(), 0.5);
  // The same ray in both frames, no rotation fitted out: an audit found the stand-in's frame
  // tilted 0.25-1 degree from the choice's, hidden by the fitted rotation.
  EXPECT_GE(stand_in["same_ray_from_chosen_px"].get<double>(), 0.5 * stand_in["median_from_chosen_px"].get<double>());
  EXPECT_NE(r.err.find("with the rotation between their frames fitted out"), std::string::npos) << r.err;
  EXPECT_FALSE(stand_in["fits_poorly"].get<bool>());
  const std::string cameramodel = slurp(out / "cam.cameramodel");
  EXPECT_NE(cameramodel.find("'lensmodel':  '" + stand_in["lensmodel"].get<std::string>() + "'"), std::string::npos);
  EXPECT_NE(cameramodel.find("'optimization_inputs'"), std::string::npos);
  EXPECT_NE(r.err.find("LENSMODEL_KANNALA_BRANDT (the choice) is not an mrcal model: " + (out / "cam.yaml").string() +
                       " holds it; " + (out / "cam.cameramodel").string() + " holds LENSMODEL_"),
            std::string::npos)
      << r.err;
  EXPECT_TRUE(fs::exists(out / "cam_residuals.png"));
  // Projection uncertainty: the headline (jackknife) at the centre below the median below the
  // rim, the linear one alongside, and the heat map.
  const auto u = j["uncertainty"];
  EXPECT_EQ(u["headline"], "jackknife");
  EXPECT_GT(u["headline_px"]["median_px"].get<double>(), 0);
  EXPECT_LT(u["headline_px"]["centre_px"].get<double>(), u["headline_px"]["median_px"].get<double>());
  EXPECT_TRUE(u["linear_ok"].get<bool>());
  EXPECT_GT(u["predicted_cross_validation_linear_px"].get<double>(), 0);
  EXPECT_GT(u["predicted_cross_validation_jackknife_px"].get<double>(), 0);
  EXPECT_TRUE(fs::exists(out / "cam_uncertainty.png"));
  // The truth: fx of the rendering camera within 1 %.
  const auto truth = nlohmann::json::parse(slurp(boards / "truth.json"));
  EXPECT_NEAR(j["intrinsics"][0].get<double>(), truth["intrinsics"][0].get<double>(),
              0.01 * truth["intrinsics"][0].get<double>());

  // No board in any image; too few views; mixed resolutions: one line, exit 2, nothing written.
  const std::string m = shared("hdr-memorial-debevec");
  expect_one_line_error(lightprobe("calib geometric" + fmt_frame(m, 61) + fmt_frame(m, 62) +
                                   " --board 9x6 --square 25 -o " + (out / "none.yaml").string()),
                        "no 9x6 board");
  EXPECT_FALSE(fs::exists(out / "none.yaml"));
  expect_one_line_error(lightprobe("calib geometric " + (boards / "board_00.png").string() + " " +
                                   (boards / "board_01.png").string() + " --board 9x6 --square 30 -o " +
                                   (out / "few.yaml").string()),
                        "at least 4 views");
  expect_one_line_error(lightprobe("calib geometric " + (boards / "board_00.png").string() + fmt_frame(m, 61) +
                                   " --board 9x6 --square 30 -o " + (out / "mixed.yaml").string()),
                        "memorial0061.png");
}

TEST(Cli, StreamComesUpOnTheFakeCameraFromAConfigFileAndReportsEveryFrame) {
  const fs::path cfg = scratch() / "rig.toml";
  std::ofstream(cfg) << "[stream]\nsource = \"aravis:Fake_1\"\nlisten = \"127.0.0.1:0\"\nduration = 2\n"
                        "exposures = \"0.0002,0.002,0.02\"\nmethod = \"q2tree\"\nn = 64\n";
  CliRun r = lightprobe("stream --json --config " + cfg.string());
  ASSERT_EQ(r.code, 0) << r.err;
  const auto j = nlohmann::json::parse(r.out);
  EXPECT_GT(j["brackets_processed"].get<int>(), 3);
  EXPECT_EQ(j["frames_in"].get<int>(), 3 * (j["brackets_processed"].get<int>() + j["brackets_dropped"].get<int>()) +
                                           j["frames_dropped_partial"].get<int>());
  EXPECT_EQ(j["last_error"], "");
  // No camera: libcamera has none here.
  CliRun none = lightprobe("stream --source libcamera --duration 1 --listen 127.0.0.1:0");
  EXPECT_EQ(none.code, 2);
  EXPECT_NE(none.err.find("no libcamera camera"), std::string::npos) << none.err;
}

namespace {

// Median |log10 Y(a) - log10 Y(b)| after one global scale (the median log ratio), over pixels
// valid and positive in both: CONVENTIONS.md's HDR measure, on two fused images.
double median_log10_difference(const lp::RgbImage& a, const lp::RgbImage& b) {
  std::vector<double> d;
  for (size_t i = 0; i < size_t(a.width) * size_t(a.height); ++i) {
    if ((!a.valid.empty() && !a.valid[i]) || (!b.valid.empty() && !b.valid[i])) continue;
    const double ya = 0.2126 * a.rgb[3 * i] + 0.7152 * a.rgb[3 * i + 1] + 0.0722 * a.rgb[3 * i + 2];
    const double yb = 0.2126 * b.rgb[3 * i] + 0.7152 * b.rgb[3 * i + 1] + 0.0722 * b.rgb[3 * i + 2];
    if (ya > 0 && yb > 0) d.push_back(std::log10(ya) - std::log10(yb));
  }
  if (d.empty()) return 1e9;
  std::vector<double> s = d;
  std::nth_element(s.begin(), s.begin() + long(s.size() / 2), s.end());
  const double scale = s[s.size() / 2];
  for (double& v : d) v = std::abs(v - scale);
  std::nth_element(d.begin(), d.begin() + long(d.size() / 2), d.end());
  return d[d.size() / 2];
}

}  // namespace

// A hand-held bracket: Memorial 0064-0070 cut at offsets up to 18 px apart (an audit's). Alignment found
// the shifts, but the response was recovered from the frames before they were aligned: a curve
// flat over 70 codes, and a map off by a median factor of 1.66 (0.22 decades) with exit 0.
// Both commands now register the frames first.
TEST(Cli, AHandHeldBracketIsAlignedBeforeItsResponseIsRecovered) {
  const std::string m = shared("hdr-memorial-debevec");
  const fs::path dir = scratch() / "handheld";
  fs::create_directories(dir / "steady");
  fs::create_directories(dir / "shaken");
  const int offsets[7][2] = {{-9, -3}, {-3, -6}, {-14, 1}, {0, 0}, {-11, -11}, {-6, 6}, {-18, -5}};
  const int w = 448, h = 704, x0 = 41, y0 = 35;
  std::string steady, shaken;
  for (int k = 0; k < 7; ++k) {
    const lp::CameraImage full = lp::read_camera_image(m + "/memorial00" + std::to_string(64 + k) + ".png");
    for (const bool shake : {false, true}) {
      lp::RgbImage crop;
      crop.width = w, crop.height = h;
      crop.rgb.resize(size_t(3) * w * h);
      const int ox = x0 + (shake ? offsets[k][0] : 0), oy = y0 + (shake ? offsets[k][1] : 0);
      for (int y = 0; y < h; ++y)
        std::copy_n(&full.rgb[3 * (size_t(y + oy) * size_t(full.width) + size_t(ox))], 3 * w, &crop.rgb[3 * size_t(y) * w]);
      const fs::path path = dir / (shake ? "shaken" : "steady") / ("f" + std::to_string(k) + ".png");
      lp::write_code_image(path.string(), crop, 8);
      (shake ? shaken : steady) += " " + path.string();
    }
  }
  const std::string times = " --exposure-times 4,2,1,0.5,0.25,0.125,0.0625 --ignore-colour 0,0,255";
  const fs::path ref = dir / "steady.exr", fused = dir / "shaken.exr", resp = dir / "r.json";
  ASSERT_EQ(lightprobe("hdr fuse" + steady + times + " -o " + ref.string()).code, 0);
  const CliRun r = lightprobe("hdr fuse --json" + shaken + times + " --align mtb -o " + fused.string());
  ASSERT_EQ(r.code, 0) << r.err;
  const auto shifts = nlohmann::json::parse(r.out)["alignment"];
  ASSERT_EQ(shifts.size(), 7u);
  // The middle exposure (frame 3, not moved) is the reference; frame k's content moved by
  // (reference offset - its offset).
  for (int k = 0; k < 7; ++k) {
    EXPECT_EQ(shifts[size_t(k)][0].get<double>(), -offsets[k][0]) << k;
    EXPECT_EQ(shifts[size_t(k)][1].get<double>(), -offsets[k][1]) << k;
  }
  // Where the shaken frames cover the steady crop's pixels (all but an 18 px border), the
  // maps agree (0.22 decades when the response came from the frames unaligned).
  const lp::RgbImage a = lp::read_rgb_image(ref.string()), b = lp::read_rgb_image(fused.string());
  ASSERT_EQ(a.width, b.width);
  EXPECT_LT(median_log10_difference(a, b), 0.02);
  // hdr response --align gives that curve too: fused with it, the shaken frames agree alike.
  ASSERT_EQ(lightprobe("hdr response" + shaken + times + " --align mtb -o " + resp.string()).code, 0);
  const fs::path with_resp = dir / "shaken_resp.exr";
  ASSERT_EQ(lightprobe("hdr fuse" + shaken + times + " --align mtb --response " + resp.string() + " -o " + with_resp.string()).code, 0);
  EXPECT_LT(median_log10_difference(a, lp::read_rgb_image(with_resp.string())), 0.02);
}
