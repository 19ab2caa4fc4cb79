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

namespace fs = std::filesystem;

namespace {

struct CliRun {
  int code = -1;
  std::string out, err;
};

std::string slurp(const fs::path& p) {
  std::ifstream f(p, std::ios::binary);
  std::stringstream s;
  s << f.rdbuf();
  return s.str();
}

fs::path scratch() {
  static const fs::path dir = [] {
    fs::path d = fs::path(::testing::TempDir()) / ("lightprobe_eval_calib_" + std::to_string(::getpid()));
    fs::create_directories(d);
    return d;
  }();
  return dir;
}

CliRun lightprobe(const std::string& args) {
  const fs::path out = scratch() / "stdout.txt", err = scratch() / "stderr.txt";
  const std::string cmd = std::string(LIGHTPROBE_CLI) + " --no-progress " + args + " >" + out.string() + " 2>" + err.string();
  const int status = std::system(cmd.c_str());
  CliRun r;
  r.code = WIFEXITED(status) ? WEXITSTATUS(status) : -1;
  r.out = slurp(out);
  r.err = slurp(err);
  return r;
}

int line_count(const std::string& s) {
  int n = 0;
  for (char c : s) n += c == '\n';
  return n;
}

}  // namespace

TEST(EvalCalibCli, ComparesWithOpenCVAloneOnVMRImage) {
  const fs::path dir = fs::path(LIGHTPROBE_SHARED_DATA) / "calib-ocamcalib-omni-samples" / "VMRImage";
  if (!fs::exists(dir)) GTEST_SKIP() << "no shared data";
  std::string images;
  for (int i = 0; i <= 9; ++i) images += " " + (dir / ("VMRImage" + std::to_string(i) + ".jpg")).string();
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
