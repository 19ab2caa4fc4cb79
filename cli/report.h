// Printing a command's report: one JSON object on stdout with --json, human lines otherwise.
#pragma once

#include <fmt/format.h>
#include <nlohmann/json.hpp>

#include <chrono>
#include <cstdio>
#include <string>

#include "cli/commands.h"

namespace lp::cli {

// Human text: stdout normally, stderr when stdout carries JSON.
template <typename... Args>
void say(const Output& out, fmt::format_string<Args...> f, Args&&... args) {
  std::fputs(fmt::format(f, std::forward<Args>(args)...).c_str(), out.json ? stderr : stdout);
}

using Clock = std::chrono::steady_clock;

// The times a report carries: seconds since `t0`.
inline double seconds_since(Clock::time_point t0) { return std::chrono::duration<double>(Clock::now() - t0).count(); }

inline void emit_json(const Output& out, const nlohmann::json& report) {
  if (out.json) std::printf("%s\n", report.dump().c_str());
}

}  // namespace lp::cli
