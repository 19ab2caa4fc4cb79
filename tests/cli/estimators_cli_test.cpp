// `lightprobe eval estimators` as scripts use it: exit codes, one-line errors naming the
// option or file, the --json report's fields, the CSV and charts written, a recorded
// sequence directory and a real map accepted.
#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>

#include <sys/wait.h>
#include <unistd.h>

#include "core/envmap.h"
#include "core/image_io.h"

#include "tests/cli/cli_run.h"

namespace fs = std::filesystem;

using namespace lp::cli_test;

TEST(EstimatorsCli, QuickRunWritesCsvChartAndJson) {
  const fs::path dir = scratch() / "quick";
  const CliRun r = lightprobe("eval estimators scene --quick --size 64x32 --scenarios abrupt-switch --json -o " + dir.string());
  ASSERT_EQ(r.code, 0) << r.err;
  const auto j = nlohmann::json::parse(r.out);
  EXPECT_TRUE(fs::exists(j["csv"].get<std::string>()));
  EXPECT_TRUE(fs::exists(j["chart"].get<std::string>()));
  EXPECT_EQ(j["sequences"].size(), 1u);
  EXPECT_EQ(j["shading_points"], 16);
  // 5 estimators x 3 budgets x (4 lobes + all)
  ASSERT_EQ(j["rows"].size(), 75u);
  for (const auto& row : j["rows"]) {
    for (const char* key : {"estimator", "lobe", "budget", "rel_rmse", "rel_variance", "temporal_noise", "us_per_estimate"})
      EXPECT_TRUE(row.contains(key)) << key;
    EXPECT_GE(row["rel_rmse"].get<double>(), 0.0);
    EXPECT_GT(row["us_per_estimate"].get<double>(), 0.0);
  }
  EXPECT_FALSE(j.contains("sweep"));  // --quick skips it
  const std::string csv = slurp(j["csv"].get<std::string>());
  EXPECT_EQ(csv.rfind("estimator,variant,lobe,budget,rel_rmse", 0), 0u);
  EXPECT_EQ(line_count(csv), 76);
  EXPECT_EQ(j["repeats"], 2);  // --quick's
  // What the user gives beside --quick stays: --repeats 3 ran as 2.
  const CliRun given = lightprobe("eval estimators scene --quick --size 64x32 --scenarios abrupt-switch --budgets 4 "
                                  "--repeats 3 --json -o " + (scratch() / "quick3").string());
  ASSERT_EQ(given.code, 0) << given.err;
  EXPECT_EQ(nlohmann::json::parse(given.out)["repeats"], 3);
  EXPECT_NE(slurp(j["chart"].get<std::string>()).find("<svg"), std::string::npos);
}

TEST(EstimatorsCli, SweepAndASequenceDirectory) {
  const fs::path seq = scratch() / "estimators_seq";
  fs::remove_all(seq);
  ASSERT_EQ(lightprobe("synth sequence --scenario flicker --frames 3 --size 64x32 -o " + seq.string()).code, 0);
  const fs::path dir = scratch() / "sweep";
  const CliRun r = lightprobe("eval estimators " + seq.string() +
                              " --size 32x16 --budgets 4 --repeats 2 --estimators mis,smc --json -o " + dir.string());
  ASSERT_EQ(r.code, 0) << r.err;
  const auto j = nlohmann::json::parse(r.out);
  EXPECT_EQ(j["sequences"][0]["frames"], 3);
  EXPECT_EQ(j["rows"].size(), 2u * 5u);
  ASSERT_TRUE(j.contains("sweep"));
  EXPECT_GE(j["sweep"].size(), 5u * 10u);
  for (const auto& row : j["sweep"]) EXPECT_EQ(row["estimator"], "smc-mix");
  EXPECT_TRUE(fs::exists(dir / "smc_sweep.csv"));
  EXPECT_TRUE(fs::exists(dir / "smc_sweep.svg"));
}

TEST(EstimatorsCli, RealMapIsAccepted) {
  const std::string map = std::string(LIGHTPROBE_SHARED_DATA) + "/probes-probulator-latlong256/grace.hdr";
  const CliRun r = lightprobe("eval estimators " + map + " --quick --size 64x32 --scenarios moving-light --estimators bis -o " +
                              (scratch() / "real").string());
  EXPECT_EQ(r.code, 0) << r.err;
  EXPECT_NE(r.out.find("grace/moving-light"), std::string::npos) << r.out;
}

TEST(EstimatorsCli, BadInputIsOneLineAndExitTwo) {
  const std::string o = " -o " + (scratch() / "bad").string();
  expect_one_line_error(lightprobe("eval estimators scene --budgets 0" + o), "--budgets");
  expect_one_line_error(lightprobe("eval estimators scene --estimators mis,foo" + o), "foo");
  expect_one_line_error(lightprobe("eval estimators scene --repeats 1" + o), "--repeats");
  expect_one_line_error(lightprobe("eval estimators scene --size 100x100" + o), "--size");
  expect_one_line_error(lightprobe("eval estimators /nonexistent/map.exr" + o), "/nonexistent/map.exr");
  // A black map: nothing to sample, and the error names the file.
  const fs::path black = scratch() / "black.exr";
  lp::write_envmap(black.string(), lp::make_latlong(32, 16));
  const CliRun r = lightprobe("eval estimators " + black.string() + " --size 32x16" + o);
  expect_one_line_error(r, "black.exr");
  EXPECT_NE(r.err.find("black"), std::string::npos);
  EXPECT_EQ(lightprobe("eval estimators --help").code, 0);
}
