// Warnings from library code, one line each, to whoever the program installed: the CLI
// prints "lightprobe: warning: ..." on stderr. Library code prints nothing itself. Where no
// sink is installed, code that would change an input's values and go on refuses instead
// (read_envmap's slight negatives), so that no value is changed without someone being told;
// notices that change no value (transparent pixels read as a mask, a colour profile not
// applied) are then simply not heard.
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
