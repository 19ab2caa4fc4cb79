// `lightprobe estimate metadata|query`, `synth walkthrough`, `eval metadata` as scripts see
// them: exit codes, one-line errors naming the file and line, --json fields, outputs.
#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>

#include <sys/wait.h>
#include <unistd.h>

#include "tests/cli/cli_run.h"

namespace fs = std::filesystem;

using namespace lp::cli_test;

namespace {

void write(const fs::path& p, const std::string& text) {
  std::ofstream f(p);
  f << text;
}

// One small walk-through shared by the tests (probes 32 x 16, 4 x 3 rays per frame).
const fs::path& walkthrough_dir() {
  static const fs::path dir = [] {
    const fs::path d = scratch() / "walk";
    const CliRun r = lightprobe("synth walkthrough --probe-size 32 --samples 2 --rays 4 -o " + d.string() + " --json");
    EXPECT_EQ(r.code, 0) << r.err;
    return d;
  }();
  return dir;
}

}  // namespace

TEST(EstimateCli, SynthWalkthroughWritesTrackProbesAndTruth) {
  const fs::path d = walkthrough_dir();
  EXPECT_TRUE(fs::exists(d / "track.jsonl"));
  EXPECT_TRUE(fs::exists(d / "probes" / "q0.exr"));
  EXPECT_TRUE(fs::exists(d / "probes" / "q5.exr"));
  const auto truth = nlohmann::json::parse(slurp(d / "truth.json"));
  EXPECT_EQ(truth["format"], "lightprobe.walkthrough/1");
  EXPECT_EQ(truth["queries"].size(), 6u);
  EXPECT_GT(truth["frames"].get<int>(), 100);
}

TEST(EstimateCli, MetadataThenQueryGivesSixLightsInRadianceUnits) {
  const fs::path d = walkthrough_dir();
  const fs::path model = scratch() / "model.json", lights = scratch() / "lights.json";
  CliRun r = lightprobe("estimate metadata " + (d / "track.jsonl").string() + " -o " + model.string() + " --json");
  ASSERT_EQ(r.code, 0) << r.err;
  auto j = nlohmann::json::parse(r.out);
  EXPECT_GT(j["nodes"].get<int>(), 5);
  EXPECT_EQ(j["camera"]["route"], "calibration");
  EXPECT_GT(j["illuminance_lux"]["median"].get<double>(), 10);
  EXPECT_GT(j["cct_k"]["median"].get<double>(), 2500);
  EXPECT_LT(j["cct_k"]["median"].get<double>(), 7000);
  // The meter equation gives the same luminance here (the synthetic camera is built so).
  CliRun m = lightprobe("estimate metadata " + (d / "track.jsonl").string() + " -o " + (scratch() / "m2.json").string() +
                        " --meter-equation --json");
  ASSERT_EQ(m.code, 0) << m.err;
  const auto jm = nlohmann::json::parse(m.out);
  EXPECT_EQ(jm["camera"]["route"], "meter");
  EXPECT_NEAR(jm["luminance_cd_m2"]["median"].get<double>() / j["luminance_cd_m2"]["median"].get<double>(), 1.0, 1e-6);

  r = lightprobe("estimate query " + model.string() + " --at 4,3 -o " + lights.string() + " --json");
  ASSERT_EQ(r.code, 0) << r.err;
  j = nlohmann::json::parse(r.out);
  EXPECT_EQ(j["lights"], 6);
  EXPECT_EQ(j["sectors"].size(), 6u);
  const auto list = nlohmann::json::parse(slurp(lights));
  EXPECT_EQ(list["format"], "lightprobe.lights/1");
  EXPECT_EQ(list["units"], "radiance");
  EXPECT_EQ(list["lights"].size(), 6u);
  // A tracker's height: the same lights (the model is a floor plan), and said.
  const CliRun z = lightprobe("estimate query " + model.string() + " --at 4,3,1.5 -o " + (scratch() / "z.json").string());
  ASSERT_EQ(z.code, 0) << z.err;
  EXPECT_NE(z.err.find("the height Z = 1.5 m is not used"), std::string::npos) << z.err;
  EXPECT_EQ(nlohmann::json::parse(slurp(scratch() / "z.json"))["lights"], list["lights"]);
  // Other formats through the exporters.
  r = lightprobe("estimate query " + model.string() + " --at 4,3 --shrink 20 -o " + (scratch() / "l.pbrt").string());
  EXPECT_EQ(r.code, 0) << r.err;
  EXPECT_NE(slurp(scratch() / "l.pbrt").find("distant"), std::string::npos);
}

TEST(EstimateCli, EvalMetadataReportsProbesAndModel) {
  const fs::path d = walkthrough_dir();
  const fs::path out = scratch() / "eval";
  CliRun r = lightprobe("eval metadata " + d.string() + " -o " + out.string() + " --fractions 0.5,1 --json");
  ASSERT_EQ(r.code, 0) << r.err;
  const auto j = nlohmann::json::parse(r.out);
  EXPECT_TRUE(fs::exists(out / "metadata.csv"));
  EXPECT_TRUE(fs::exists(out / "metadata.svg"));
  ASSERT_EQ(j["rows"].size(), 5u + 1u + 2u * 4u);  // probes, best six, standing, 4 variants x 2
  double q2 = -1, paper = -1;
  for (const auto& row : j["rows"]) {
    if (row["method"] == "probe q2tree 64") q2 = row["diffuse_mean"].get<double>();
    if (row["method"] == "metadata (paper: nearest informed)" && row["path_fraction"] == 1) paper = row["diffuse_mean"].get<double>();
  }
  EXPECT_GT(q2, 0);
  EXPECT_LT(q2, 0.05);   // a real probe with 64 lights
  EXPECT_GT(paper, q2);  // the price of going probe-less
}

TEST(EstimateCli, BadMetadataIsAOneLineErrorNamingFileAndLine) {
  const fs::path t = scratch() / "bad.jsonl";
  write(t, "{\"position\":[0,0],\"view_dir\":[1,0,0],\"exposure_s\":0.01,\"gain_db\":0}\n"
           "{\"position\":[0,0],\"view_dir\":[1,0,0],\"exposure_s\":0,\"gain_db\":0}\n");
  expect_one_line_error(lightprobe("estimate metadata " + t.string() + " -o " + (scratch() / "x.json").string()),
                        "bad.jsonl:2: exposure_s");
  EXPECT_FALSE(fs::exists(scratch() / "x.json"));
  write(t, "{\"position\":[0,0],\"view_dir\":[1,0,0],\"exposure_s\":0.01}\n");
  expect_one_line_error(lightprobe("estimate metadata " + t.string() + " -o " + (scratch() / "x.json").string()),
                        "bad.jsonl:1: no gain");
  write(t, "{\"position\":[0,0],\"view_dir\":[0,0,0],\"exposure_s\":0.01,\"gain_db\":0}\n");
  expect_one_line_error(lightprobe("estimate metadata " + t.string() + " -o " + (scratch() / "x.json").string()),
                        "bad.jsonl:1: view_dir");
  write(t, "not json\n");
  expect_one_line_error(lightprobe("estimate metadata " + t.string() + " -o " + (scratch() / "x.json").string()),
                        "bad.jsonl:1");
  expect_one_line_error(lightprobe("estimate metadata " + (scratch() / "missing.jsonl").string() + " -o x.json"),
                        "missing.jsonl");
  expect_one_line_error(lightprobe("estimate query " + (scratch() / "nomodel.json").string() + " --at 1,2 -o l.json"),
                        "nomodel.json");
  expect_one_line_error(lightprobe("eval metadata " + scratch().string() + " -o " + (scratch() / "e").string()),
                        "truth.json");
}

// Camera options that the run never reads were dropped without a word, and so were a NaN or
// negative aperture (read as "not given"). The walk-through's track has a photometric scale
// and records every frame's aperture, mean code and gain.
TEST(EstimateCli, CameraOptionsTheRouteNeverReadsAreRefusedOrWarnedAbout) {
  const std::string track = (walkthrough_dir() / "track.jsonl").string();
  const fs::path out = scratch() / "unread.json";
  const std::string metadata = "estimate metadata " + track + " -o " + out.string() + " ";
  expect_one_line_error(lightprobe(metadata + "--meter-constant 14"), "--meter-constant is read by the meter equation only");
  expect_one_line_error(lightprobe(metadata + "--meter-equation --calibration-f-number 4"),
                        "--calibration-f-number is the aperture of a photometric scale");
  expect_one_line_error(lightprobe(metadata + "--meter-equation --f-number nan"), "--f-number must be positive, got nan");
  expect_one_line_error(lightprobe(metadata + "--ae-target -0.5"), "--ae-target must be in (0, 1]");
  const fs::path cal = scratch() / "photometric.json";
  write(cal, "{}");
  expect_one_line_error(lightprobe(metadata + "--meter-equation --photometric " + cal.string()), "contradict");
  EXPECT_FALSE(fs::exists(out));

  const CliRun fallback = lightprobe(metadata + "--f-number 2.8 --iso-base 200");
  ASSERT_EQ(fallback.code, 0) << fallback.err;
  EXPECT_NE(fallback.err.find("warning: --f-number 2.8 is not used: every frame of " + track + " records its aperture"),
            std::string::npos) << fallback.err;
  EXPECT_NE(fallback.err.find("warning: --iso-base 200 is not used: the photometric scale reads each frame's own gain"),
            std::string::npos) << fallback.err;
  const std::string model = (scratch() / "query_model.json").string();
  ASSERT_EQ(lightprobe("estimate metadata " + track + " -o " + model).code, 0);
  const std::string query = "estimate query " + model + " --at 4,3 -o " + (scratch() / "q.json").string() + " ";
  expect_one_line_error(lightprobe(query + "--shrink 5 --max-depth 2"), "--shrink blends every level");
  expect_one_line_error(lightprobe(query + "--shrink 5 --min-frames 3"), "--shrink blends every level");
  expect_one_line_error(lightprobe(query + "--max-depth -7"), "--max-depth must be >= 0");
  EXPECT_EQ(lightprobe(query + "--shrink 5").code, 0);
  const CliRun meter = lightprobe(metadata + "--meter-equation --meter-constant 14");
  ASSERT_EQ(meter.code, 0) << meter.err;
  EXPECT_EQ(meter.err, "");
}

// The probe-less mode fed live: Aravis' simulated camera, a fixed rig.
TEST(EstimateCli, StreamFeedsTheMetadataModelLive) {
  const fs::path model = scratch() / "live_model.json";
  const CliRun r = lightprobe("stream --source aravis:Fake_1 --listen 127.0.0.1:0 --duration 1.5 --metadata-model " +
                              model.string() + " --position 1,2 --view-dir 0,0,1 --json");
  ASSERT_EQ(r.code, 0) << r.err;
  const auto j = nlohmann::json::parse(r.out);
  EXPECT_GT(j["frames_used"].get<int>(), 5);
  EXPECT_GT(j["last_luminance_cd_m2"].get<double>(), 0);
  const auto m = nlohmann::json::parse(slurp(model));
  EXPECT_EQ(m["format"], "lightprobe.metadata-model/1");
  EXPECT_EQ(m["origin"][0], 1.0);
  // Looking straight up fills an up sector (azimuth 0: sector 0) of the root.
  EXPECT_GT(m["nodes"][0]["sectors"][0]["weight"].get<double>(), 5);
  EXPECT_EQ(m["nodes"][0]["sectors"][3]["weight"].get<double>(), 0);
  expect_one_line_error(lightprobe("stream --source aravis:Fake_1 --listen 127.0.0.1:0 --duration 1 --metadata-model " +
                                   model.string() + " --view-dir 0,0,0"),
                        "--view-dir");
}

// The calibration route with a real `calib photometric` result: luminance scales with its k.
TEST(EstimateCli, PhotometricCalibrationFileSetsTheScale) {
  const fs::path d = walkthrough_dir();
  const fs::path readings = scratch() / "readings.csv", cal = scratch() / "photometric.json";
  // Noiseless readings of k = 5.5 cd/m2 per relative unit (about twice the synthetic camera's 2.78).
  write(readings, "region,camera_value,measured,unit\np1,1.0,5.5,cd/m2\np2,2.0,11.0,cd/m2\np3,4.0,22.0,cd/m2\n");
  CliRun r = lightprobe("calib photometric " + readings.string() + " -o " + cal.string());
  ASSERT_EQ(r.code, 0) << r.err;
  r = lightprobe("estimate metadata " + (d / "track.jsonl").string() + " -o " + (scratch() / "m3.json").string() + " --json");
  ASSERT_EQ(r.code, 0) << r.err;
  const auto base = nlohmann::json::parse(r.out);
  r = lightprobe("estimate metadata " + (d / "track.jsonl").string() + " -o " + (scratch() / "m4.json").string() +
                 " --photometric " + cal.string() + " --json");
  ASSERT_EQ(r.code, 0) << r.err;
  const auto scaled = nlohmann::json::parse(r.out);
  EXPECT_NEAR(scaled["camera"]["photometric_scale"].get<double>(), 5.5, 1e-6);
  const double k_track = base["camera"]["photometric_scale"].get<double>();
  EXPECT_NEAR(scaled["luminance_cd_m2"]["median"].get<double>() / base["luminance_cd_m2"]["median"].get<double>(),
              5.5 / k_track, 1e-6);
}
