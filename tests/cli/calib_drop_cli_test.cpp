// `calib geometric --drop-influential N`: the views with the highest leverage among those
// flagged influential are left out and the calibration solved again; both answers shown.
#include <nlohmann/json.hpp>

#include <algorithm>
#include <string>

#include "tests/cli/cli_run.h"

namespace lp::cli_test {
namespace {

const std::string kSet = "calib-ocamcalib-omni-samples/Fisheye190deg/";

std::string views() {
  std::string s;
  for (int i = 1; i <= 8; ++i) {
    s += ' ';
    s += shared(kSet + "Fisheye190deg" + std::to_string(i) + ".jpg");
  }
  return s;
}

TEST(CalibDropCli, DropsTheMostInfluentialViewAndSolvesAgain) {
  if (!fs::exists(shared(kSet))) GTEST_SKIP() << "no shared data";
  const std::string common = "calib geometric --json --board 6x7 --square 30 --model LENSMODEL_KANNALA_BRANDT" + views();
  const CliRun all = lightprobe(common + " -o " + (scratch() / "all.yaml").string());
  ASSERT_EQ(all.code, 0) << all.err;
  const auto a = nlohmann::json::parse(all.out);
  // The first run flags influential views and offers to drop them.
  std::string worst;
  double worst_leverage = -1;
  for (const auto& v : a["views"])
    if (v["influential"].get<bool>() && v["leverage_px"].get<double>() > worst_leverage) {
      worst_leverage = v["leverage_px"].get<double>();
      worst = v["file"].get<std::string>();
    }
  ASSERT_FALSE(worst.empty()) << "no influential view flagged on Fisheye190deg";
  EXPECT_NE(all.err.find("--drop-influential"), std::string::npos) << all.err;
  EXPECT_TRUE(a["dropped_views"].empty());

  const CliRun one = lightprobe(common + " --drop-influential 1 -o " + (scratch() / "one.yaml").string());
  ASSERT_EQ(one.code, 0) << one.err;
  const auto b = nlohmann::json::parse(one.out);
  ASSERT_EQ(b["dropped_views"].size(), 1u);
  EXPECT_EQ(b["dropped_views"][0]["file"], worst);
  EXPECT_NEAR(b["dropped_views"][0]["leverage_px"].get<double>(), worst_leverage, 1e-9);
  // The answer before dropping is the first run's, the one after differs and leaves it out.
  EXPECT_NEAR(b["before_dropping"]["cross_validation_px"].get<double>(), a["cross_validation_px"].get<double>(), 1e-9);
  EXPECT_NE(b["cross_validation_px"].get<double>(), a["cross_validation_px"].get<double>());
  for (const auto& v : b["views"])
    if (v["file"] == worst) {
      EXPECT_FALSE(v["used"].get<bool>());
      EXPECT_EQ(v["why"].get<std::string>().rfind("dropped", 0), 0u) << v["why"];
    }
  EXPECT_EQ(b["intrinsics"].size(), a["intrinsics"].size());
}

TEST(CalibDropCli, NegativeCountIsAUsageError) {
  expect_one_line_error(lightprobe("calib geometric a.jpg b.jpg --board 6x7 --square 30 --drop-influential -1 -o " +
                                   (scratch() / "x.yaml").string()),
                        "--drop-influential");
  EXPECT_FALSE(fs::exists(scratch() / "x.yaml"));
}

}  // namespace
}  // namespace lp::cli_test
