// `lightprobe eval calib`: our calibration next to OpenCV run alone on one real set; usage
// errors.
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

TEST(EvalCalibCli, ComparesWithOpenCVAloneOnVMRImage) {
  const fs::path dir = fs::path(LIGHTPROBE_SHARED_DATA) / "calib-ocamcalib-omni-samples" / "VMRImage";
  if (!fs::exists(dir)) GTEST_SKIP() << "no shared data";
  std::string images;
  for (int i = 0; i <= 9; ++i) {  // appended piecewise: gcc 12 warns (-Wrestrict) on " " + string
    images += ' ';
    images += (dir / ("VMRImage" + std::to_string(i) + ".jpg")).string();
  }
  const fs::path out = scratch() / "vmr";
  const CliRun r = lightprobe("eval calib --json" + images + " --board 6x7 --square 30 -o " + out.string());
  ASSERT_EQ(r.code, 0) << r.err;
  const auto j = nlohmann::json::parse(r.out);
  ASSERT_EQ(j["compare"].size(), 5u);  // ours + four OpenCV solvers
  EXPECT_EQ(j["compare"][0]["solver"], "lightprobe");
  EXPECT_EQ(j["compare"][0]["model"], "LENSMODEL_OMNIDIR_MEI");
  const double ours = j["compare"][0]["cross_validation_px"].get<double>();
  for (const auto& row : j["compare"])
    if (row["solver"] == "cv::omnidir") {
      ASSERT_TRUE(row["ok"].get<bool>()) << row.dump();
      // Our Mei fit starts from cv::omnidir's and refines it jointly: never worse in RMS.
      EXPECT_LE(j["compare"][0]["rms_px"].get<double>(), row["rms_px"].get<double>() + 1e-6);
      std::printf("  cross-validation: ours %.3f px, cv::omnidir alone %.3f px\n", ours,
                  row["cross_validation_px"].get<double>());
    }
  EXPECT_TRUE(fs::exists(out / "calib_compare.csv"));
  // One solve of each of our models next to its OpenCV peer: Mei (cv::omnidir's seed refined
  // jointly) fits the corners at least as well as cv::omnidir alone.
  ASSERT_EQ(j["speed"].size(), 4u);
  for (const auto& row : j["speed"]) {
    if (row["model"] != "LENSMODEL_OMNIDIR_MEI") continue;
    EXPECT_EQ(row["peer"], "cv::omnidir");
    ASSERT_TRUE(row["ours_rms_px"].is_number() && row["peer_rms_px"].is_number()) << row.dump();
    EXPECT_LE(row["ours_rms_px"].get<double>(), row["peer_rms_px"].get<double>() + 1e-6);
    EXPECT_GT(row["ours_one_solve_seconds"].get<double>(), 0);
    EXPECT_GT(row["model_command_seconds"].get<double>(), 0);
  }
  EXPECT_TRUE(fs::exists(out / "calib_speed.csv"));
}

TEST(EvalCalibCli, NothingToDoIsAUsageError) {
  const CliRun r = lightprobe("eval calib -o " + (scratch() / "none").string());
  EXPECT_EQ(r.code, 2);
  EXPECT_EQ(line_count(r.err), 1) << r.err;
  EXPECT_NE(r.err.find("--sweep"), std::string::npos) << r.err;
  const CliRun b = lightprobe("eval calib --sweep --board 1x7 -o " + (scratch() / "none").string());
  EXPECT_EQ(b.code, 2);
  EXPECT_NE(b.err.find("--board"), std::string::npos) << b.err;
}
