#include "core/json_file.h"

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
  const fs::path dir = fs::temp_directory_path() / ("lightprobe_json_file_test_" + std::to_string(::getpid()));
  fs::create_directories(dir);
  const std::string path = (dir / name).string();
  std::ofstream(path, std::ios::binary) << text;
  return path;
}

template <typename F>
std::string message_of(F f) {
  try {
    f();
  } catch (const InputError& e) {
    return e.what();
  }
  return "(accepted)";
}

TEST(JsonFile, SyntaxErrorsAndMissingFilesNameTheFile) {
  const std::string broken = write("broken.json", "{\"format\": ");
  EXPECT_EQ(message_of([&] { read_json_file(broken); }), broken + ": not JSON (syntax error at byte 12)");
  EXPECT_EQ(message_of([&] { read_json_file("/nonexistent/x.json"); }), "/nonexistent/x.json: cannot open: No such file or directory");
  EXPECT_EQ(read_json_file(write("ok.json", "{\"a\": 1}"))["a"], 1);
}

TEST(JsonFile, AFormatThatIsNotTheExpectedStringIsNamedWithWhatItIs) {
  const std::string want = "lightprobe.response/1";
  EXPECT_EQ(message_of([&] { check_json_format(nlohmann::json::parse(R"({"format": 5})"), "r.json", want); }),
            "r.json: not a lightprobe.response/1 file (\"format\" is 5)");
  EXPECT_EQ(message_of([&] { check_json_format(nlohmann::json::parse(R"({"levels": 5})"), "r.json", want); }),
            "r.json: not a lightprobe.response/1 file (no \"format\")");
  EXPECT_EQ(message_of([&] { check_json_format(nlohmann::json::parse("[1, 2]"), "r.json", want); }),
            "r.json: not a lightprobe.response/1 file (not a JSON object)");
  EXPECT_EQ(message_of([&] { check_json_format(nlohmann::json::parse(R"({"format": "lightprobe.response/1"})"), "r.json", want); }),
            "(accepted)");
}

TEST(JsonFile, FieldProblemsDropNlohmannsPrefix) {
  const nlohmann::json j = nlohmann::json::parse(R"({"levels": "many"})");
  try {
    (void)j.at("levels").get<int>();
    ADD_FAILURE();
  } catch (const nlohmann::json::exception& e) {
    EXPECT_EQ(json_field_problem("r.json", e), "r.json: a field has the wrong type (type must be number, but is string)");
  }
  try {
    (void)j.at("log_exposure");
    ADD_FAILURE();
  } catch (const nlohmann::json::exception& e) {
    EXPECT_EQ(json_field_problem("r.json", e), "r.json: key 'log_exposure' not found");
  }
}

}  // namespace
}  // namespace lp
