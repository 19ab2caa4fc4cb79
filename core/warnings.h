// Warnings from library code, one line each, to whoever the program installed: the CLI
// prints "lightprobe: warning: ..." on stderr. Library code prints nothing itself, and where
// no sink is installed, code that would warn and go on refuses instead (read_envmap's slight
// negatives), so that no input is changed without someone being told.
#pragma once

#include <functional>
#include <string>

namespace lp {

using WarningSink = std::function<void(const std::string& line)>;

// Installs the process's sink (an empty function removes it); returns the previous one.
WarningSink set_warning_sink(WarningSink sink);
bool has_warning_sink();
// Hands one line to the sink; nothing without one. Safe from any thread.
void warn(const std::string& line);

}  // namespace lp
