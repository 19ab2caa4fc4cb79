#include "core/json_file.h"

#include <fmt/format.h>

#include "core/error.h"
#include "core/file_io.h"

namespace lp {

nlohmann::json parse_json_text(const std::string& text, const std::string& source) {
  try {
    return nlohmann::json::parse(text);
  } catch (const nlohmann::json::parse_error& e) {
    throw InputError(fmt::format("{}: not JSON (syntax error at byte {})", source, e.byte));
  } catch (const nlohmann::json::exception&) {
    throw InputError(source + ": not JSON");
  }
}

nlohmann::json read_json_file(const std::string& path) { return parse_json_text(read_text_file(path), path); }

void check_json_format(const nlohmann::json& doc, const std::string& path, const std::string& format) {
  if (!doc.is_object()) throw InputError(fmt::format("{}: not a {} file (not a JSON object)", path, format));
  const auto it = doc.find("format");
  if (it == doc.end()) throw InputError(fmt::format("{}: not a {} file (no \"format\")", path, format));
  if (!it->is_string() || it->get<std::string>() != format)
    throw InputError(fmt::format("{}: not a {} file (\"format\" is {})", path, format, it->dump()));
}

std::string json_field_problem(const std::string& path, const nlohmann::json::exception& e) {
  // nlohmann's text is "[json.exception.type_error.302] type must be number, but is string".
  std::string what = e.what();
  if (const size_t end = what.find("] "); what.rfind("[json.exception.", 0) == 0 && end != std::string::npos)
    what = what.substr(end + 2);
  if (dynamic_cast<const nlohmann::json::type_error*>(&e)) what = "a field has the wrong type (" + what + ")";
  return path + ": " + what;
}

}  // namespace lp
