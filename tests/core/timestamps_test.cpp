#include "core/timestamps.h"

#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <string>

#include <unistd.h>

#include "core/error.h"

namespace lp {
namespace {

namespace fs = std::filesystem;

std::string write(const std::string& name, const std::string& text) {
  const fs::path dir = fs::temp_directory_path() / ("lightprobe_timestamps_test_" + std::to_string(::getpid()));
  fs::create_directories(dir);
  const std::string path = (dir / name).string();
  std::ofstream(path, std::ios::binary) << text;
  return path;
}

std::string message_of(const std::string& path) {
  try {
    read_timestamps(path);
  } catch (const InputError& e) {
    return e.what();
  }
  return "(accepted)";
}

TEST(Timestamps, ParseSecondsTakesOnlyOneFiniteDecimalNumber) {
  EXPECT_EQ(parse_seconds("12.5"), 12.5);
  EXPECT_EQ(parse_seconds("  1.7e9 "), 1.7e9);
  EXPECT_EQ(parse_seconds("+3"), 3.0);
  EXPECT_EQ(parse_seconds("-0.25"), -0.25);
  for (const char* bad : {"", " ", "0x10", "0.05x", "1 2", "nan", "inf", "1e999", "1,5", "--1", "+-1"})
    EXPECT_FALSE(parse_seconds(bad).has_value()) << "'" << bad << "'";
  EXPECT_FALSE(parse_seconds(std::string("1\0", 2)).has_value());
}

TEST(Timestamps, ReadsOneIncreasingTimePerLineSkippingCommentsAndBlankLines) {
  EXPECT_EQ(read_timestamps(write("good.txt", "# capture times\n0\n\n0.04\r\n  0.08\n1e-1\n")),
            (std::vector<double>{0, 0.04, 0.08, 0.1}));
  EXPECT_TRUE(read_timestamps(write("empty.txt", "# none\n")).empty());
}

TEST(Timestamps, RefusesEveryKindOfGarbageWithTheFileAndLine) {
  const std::string backwards = write("backwards.txt", "0\n0.2\n0.1\n");
  EXPECT_EQ(message_of(backwards), backwards + ":3: time 0.1 s is not after 0.2 s (line 2); times must increase strictly");
  const std::string equal = write("equal.txt", "1\n1\n1\n");
  EXPECT_EQ(message_of(equal), equal + ":2: time 1 s is not after 1 s (line 1); times must increase strictly");
  const std::string suffix = write("suffix.txt", "0\n0.05x\n");
  EXPECT_EQ(message_of(suffix), suffix + ":2: '0.05x' is not one decimal number of seconds");
  const std::string columns = write("columns.txt", "0 1\n");
  EXPECT_EQ(message_of(columns), columns + ":1: '0 1' is not one decimal number of seconds");
  const std::string nul = write("nul.txt", std::string("0\n0.1\0\n", 7));
  EXPECT_EQ(message_of(nul), nul + ":2: '0.1?' is not one decimal number of seconds");
  const std::string hex = write("hex.txt", "0\n0x10\n");
  EXPECT_EQ(message_of(hex), hex + ":2: '0x10' is not one decimal number of seconds");
  EXPECT_EQ(message_of("/nonexistent/timestamps.txt"), "/nonexistent/timestamps.txt: cannot open the timestamps: No such file or directory");
}

}  // namespace
}  // namespace lp
