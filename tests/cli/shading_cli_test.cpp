// `lightprobe eval shading` and `lightprobe tables` as a user and a script see them:
// exit codes, one-line errors naming the option or file, --json fields, outputs exist.
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

TEST(ShadingCli, EvalOnARealMapReportsEveryVariantAsJson) {
  const fs::path dir = scratch() / "eval";
  const CliRun r = lightprobe("eval shading " + shared("probes-probulator-latlong256/grace.hdr") +
                              " --n 64,256 --points 2000 --json -o " + dir.string());
  ASSERT_EQ(r.code, 0) << r.err;
  const auto j = nlohmann::json::parse(r.out);
  EXPECT_TRUE(fs::exists(dir / "shading.csv"));
  EXPECT_TRUE(fs::exists(dir / "shading.svg"));
  EXPECT_EQ(j["regions"], 256);
  ASSERT_EQ(j["points"].size(), 8u);  // 2 counts x 4 variants
  for (const auto& p : j["points"]) {
    EXPECT_GT(p["ns_per_point"].get<double>(), 0);
    EXPECT_GT(p["diffuse"].get<double>(), 0);
    if (p["variant"] == "all") {
      EXPECT_DOUBLE_EQ(p["speedup"].get<double>(), 1.0);
    }
  }
  // Culling costs no accuracy: the culled rows carry the all-lights errors.
  const auto& pts = j["points"];
  EXPECT_EQ(pts[0]["variant"], "all");
  EXPECT_EQ(pts[1]["variant"], "culled");
  EXPECT_NEAR(pts[1]["diffuse"].get<double>(), pts[0]["diffuse"].get<double>(), 1e-6);
  EXPECT_GT(pts[1]["visit_ratio"].get<double>(), 1.3);  // culling visits fewer lights
  EXPECT_LT(pts[1]["visit_ratio"].get<double>(), 2.0);
  const std::string csv = slurp(dir / "shading.csv");
  EXPECT_EQ(line_count(csv), 9);
  EXPECT_EQ(csv.rfind("map,n,variant,", 0), 0u);
}

TEST(ShadingCli, CoherentOrderAndRegionCopiesChangeTimesNotErrors) {
  const std::string map = shared("probes-probulator-latlong256/uffizi.hdr");
  const CliRun a = lightprobe("eval shading " + map + " --n 128 --points 500 --json -o " + (scratch() / "e1").string());
  const CliRun b = lightprobe("eval shading " + map + " --n 128 --points 500 --coherent --region-copies --json -o " +
                              (scratch() / "e2").string());
  ASSERT_EQ(a.code, 0) << a.err;
  ASSERT_EQ(b.code, 0) << b.err;
  const auto ja = nlohmann::json::parse(a.out)["points"], jb = nlohmann::json::parse(b.out)["points"];
  ASSERT_EQ(ja.size(), 4u);
  ASSERT_EQ(jb.size(), 4u);
  for (size_t i = 0; i < 4; ++i) {
    EXPECT_NEAR(ja[i]["diffuse"].get<double>(), jb[i]["diffuse"].get<double>(), 1e-9);
    EXPECT_NEAR(ja[i]["glossy100"].get<double>(), jb[i]["glossy100"].get<double>(), 1e-9);
    EXPECT_DOUBLE_EQ(ja[i]["visits"].get<double>(), jb[i]["visits"].get<double>());
  }
}

TEST(ShadingCli, TablesExportJsonAndTexture) {
  const fs::path json = scratch() / "tables.json", bin = scratch() / "tables.lpst";
  CliRun r = lightprobe("tables scene --n 128 --regions 64 --json -o " + json.string());
  ASSERT_EQ(r.code, 0) << r.err;
  auto j = nlohmann::json::parse(r.out);
  EXPECT_EQ(j["format"], "json");
  EXPECT_EQ(j["high"], 128);
  EXPECT_EQ(j["low"], 1024);
  const auto doc = nlohmann::json::parse(slurp(json));
  EXPECT_EQ(doc["format"], "lightprobe.shading_tables/1");
  EXPECT_EQ(doc["tables"][0]["regions"].size(), 64u);

  r = lightprobe("tables scene --n 128 --json -o " + bin.string());
  ASSERT_EQ(r.code, 0) << r.err;
  j = nlohmann::json::parse(r.out);
  EXPECT_EQ(j["format"], "texture");
  const std::string bytes = slurp(bin);
  ASSERT_GT(bytes.size(), 16u);
  EXPECT_EQ(bytes.substr(0, 8), "LPSHADE1");
  EXPECT_EQ(bytes.size(), j["bytes"].get<size_t>());
  EXPECT_EQ((bytes.size() - 16) % (1024 * 16), 0u);  // whole rows of 1024 RGBA32F texels
}

TEST(ShadingCli, BadInputIsAOneLineErrorNamingTheOptionOrFile) {
  const std::string o = " -o " + (scratch() / "bad").string();
  expect_one_line_error(lightprobe("eval shading scene --regions 0" + o), "--regions");
  expect_one_line_error(lightprobe("eval shading scene --q -2" + o), "--q");
  expect_one_line_error(lightprobe("eval shading scene --n 0" + o), "--n");
  expect_one_line_error(lightprobe("eval shading scene --method q2tree" + o), "--method");
  expect_one_line_error(lightprobe("eval shading scene --cone 120" + o), "--cone");
  expect_one_line_error(lightprobe("eval shading /nonexistent/map.exr" + o), "/nonexistent/map.exr");
  expect_one_line_error(lightprobe("tables scene --k 0 -o " + (scratch() / "t.bin").string()), "--k");
  expect_one_line_error(lightprobe("tables /nonexistent/m.hdr -o " + (scratch() / "t.bin").string()), "/nonexistent/m.hdr");
  EXPECT_FALSE(fs::exists(scratch() / "t.bin"));
}
