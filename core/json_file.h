// Reading the project's JSON files (responses, photometric and colour calibrations,
// metadata models) with the project's rule for bad input: one line naming the file and
// what is wrong, never nlohmann's own text or exit code.
#pragma once

#include <nlohmann/json.hpp>

#include <string>

namespace lp {

// The whole file parsed. InputError "path: cannot open" / "path: not JSON (syntax error at
// byte N)".
nlohmann::json read_json_file(const std::string& path);
// The same for text already read; `source` names it in messages.
nlohmann::json parse_json_text(const std::string& text, const std::string& source);

// Throws InputError `path: not a lightprobe.response/1 file ("format" is 5)` unless the
// document is an object whose "format" is the string `format`.
void check_json_format(const nlohmann::json& doc, const std::string& path, const std::string& format);

// A field that is missing or of the wrong type, as "path: key 'levels' not found" or
// "path: a field has the wrong type (type must be number, but is string)".
std::string json_field_problem(const std::string& path, const nlohmann::json::exception& e);

}  // namespace lp
