// Capture times in text files (a sequence's timestamps.txt, a replay's sidecar): the one
// rule every reader of them applies. A time is one plain decimal number of seconds
// ("12.5", "1.7e9"; no hex, no suffix, not NaN or infinite), and the times of a recording
// are strictly increasing in file order (equal or backward times would make rates and
// filters divide by zero or run backwards).
#pragma once

#include <optional>
#include <string>
#include <string_view>
#include <vector>

namespace lp {

// The seconds in `text` (surrounding blanks ignored), or nullopt when it is anything but
// one finite decimal number.
std::optional<double> parse_seconds(std::string_view text);

// A time with the line it was read from, for messages.
struct TimedLine {
  double seconds = 0;
  int line = 0;
};

// Throws InputError "path:LINE: time T s is not after T0 s (line L0)" at the first time
// that is not strictly after the one before it.
void check_increasing(const std::string& path, const std::vector<TimedLine>& times);

// One time per line; blank lines and lines starting with '#' are skipped. Throws
// InputError "path:LINE: ..." on a line that is not one decimal number of seconds (two
// columns, "0x10", "0.05x", a NUL byte) or a time not after the previous one.
std::vector<double> read_timestamps(const std::string& path);

}  // namespace lp
