#include "core/warnings.h"

#include <mutex>
#include <utility>

namespace lp {
namespace {

std::mutex& sink_mutex() {
  static std::mutex m;
  return m;
}

WarningSink& sink() {
  static WarningSink s;
  return s;
}

}  // namespace

WarningSink set_warning_sink(WarningSink next) {
  std::lock_guard lock(sink_mutex());
  return std::exchange(sink(), std::move(next));
}

bool has_warning_sink() {
  std::lock_guard lock(sink_mutex());
  return bool(sink());
}

void warn(const std::string& line) {
  std::lock_guard lock(sink_mutex());
  if (sink()) sink()(line);
}

}  // namespace lp
