// merge --camera-positions --target, also from a config file's [merge] section (issue 20
// item 4): the weights come out of where the cameras stand, and positions that do not fit
// are refused with one line and exit 2.
#include <gtest/gtest.h>

#include <nlohmann/json.hpp>

#include "cli_run.h"

namespace lp::cli_test {
namespace {

// Nobody listens on ports 1 and 2: the merge runs its second, publishes nothing, and reports the
// weights it would merge with.
const std::string kDeadUrls = "http://127.0.0.1:1 http://127.0.0.1:2 ";

TEST(MergePositionsCli, AConfigFileGivesPositionsAndTheTargetAndTheWeightsFollow) {
  const fs::path cfg = scratch() / "merge.toml";
  std::ofstream(cfg) << "[merge]\nlisten = \"127.0.0.1:0\"\nduration = 1\n"
                        "camera-positions = \"0,0,1.6; 1,0,1.6\"\ntarget = \"0.25,0,1.6\"\n";
  const CliRun r = lightprobe("merge --json " + kDeadUrls + "--config " + cfg.string());
  ASSERT_EQ(r.code, 0) << r.err;
  const auto j = nlohmann::json::parse(r.out);
  EXPECT_EQ(j["weights_from"], "camera positions");
  ASSERT_EQ(j["weights"].size(), 2u);
  EXPECT_NEAR(j["weights"][0].get<double>(), 0.9, 1e-9);  // 1/0.25^2 against 1/0.75^2
  EXPECT_NEAR(j["weights"][1].get<double>(), 0.1, 1e-9);
}

TEST(MergePositionsCli, PositionsThatDoNotFitAreRefusedWithOneLine) {
  const std::string run = "merge " + kDeadUrls + "--listen 127.0.0.1:0 --duration 1 ";
  expect_one_line_error(lightprobe(run + "--camera-positions 0,0,0 --target 1,1,1"), "--camera-positions takes 6");
  expect_one_line_error(lightprobe(run + "--camera-positions '0,0,0;1,0,0'"), "--target go together");
  expect_one_line_error(lightprobe(run + "--target 1,1"), "--target takes 3");
  expect_one_line_error(lightprobe(run + "--camera-positions '0,0,0;1,0,0' --target 0,0,0 --weights 1,2"), "not both");
}

}  // namespace
}  // namespace lp::cli_test
