#include "core/timestamps.h"

#include <fmt/format.h>

#include <cctype>
#include <charconv>
#include <cmath>
#include <sstream>

#include "core/error.h"
#include "core/file_io.h"

namespace lp {

std::optional<double> parse_seconds(std::string_view text) { return parse_decimal(text); }

void check_increasing(const std::string& path, const std::vector<TimedLine>& times) {
  for (size_t i = 1; i < times.size(); ++i)
    if (!(times[i].seconds > times[i - 1].seconds))
      throw InputError(fmt::format("{}:{}: time {} s is not after {} s (line {}); times must increase strictly", path,
                                   times[i].line, times[i].seconds, times[i - 1].seconds, times[i - 1].line));
}

std::vector<double> read_timestamps(const std::string& path) {
  std::istringstream in(read_text_file(path, "the timestamps"));
  std::vector<TimedLine> times;
  int line_number = 0;
  for (std::string line; std::getline(in, line);) {
    ++line_number;
    if (!line.empty() && line.back() == '\r') line.pop_back();
    if (line.find_first_not_of(" \t") == std::string::npos || line[0] == '#') continue;
    const auto t = parse_seconds(line);
    if (!t) {
      std::string shown;  // printable, so a NUL or control byte cannot break the one-line message
      for (char c : line.substr(0, 40)) shown += std::isprint(static_cast<unsigned char>(c)) ? c : '?';
      throw InputError(fmt::format("{}:{}: '{}' is not one decimal number of seconds", path, line_number, shown));
    }
    times.push_back({*t, line_number});
  }
  check_increasing(path, times);
  std::vector<double> out;
  out.reserve(times.size());
  for (const TimedLine& t : times) out.push_back(t.seconds);
  return out;
}

}  // namespace lp
