// A terminal progress bar (core/progress.h) fed by a library's (done, total) callback,
// such as the eval harnesses' EvalProgress: the bar starts at the first call, when the
// total is known.
#pragma once

#include <cstddef>
#include <functional>
#include <memory>
#include <string>

#include "cli/command_table.h"
#include "cli/report.h"
#include "core/progress.h"

namespace lp::cli {

class ProgressBar {
 public:
  ProgressBar(std::string label, const Output& out) : label_(std::move(label)), enabled_(out.progress) {}
  // The callback to hand the library; valid while this bar lives.
  std::function<void(size_t, size_t)> callback() {
    return [this](size_t done, size_t total) {
      if (!bar_) bar_ = std::make_unique<Progress>(label_, total, enabled_);
      if (done > reported_) bar_->advance(done - reported_);
      reported_ = done;
    };
  }
  // Ends the bar's line before the report is printed (the destructor does it otherwise).
  void finish() {
    if (bar_) bar_->finish();
  }

 private:
  std::string label_;
  bool enabled_;
  std::unique_ptr<Progress> bar_;
  size_t reported_ = 0;
};

// Runs a harness under a progress bar, then prints its table and (--json) its report.
template <typename Evaluate>
int evaluate_and_report(const char* label, const Output& out, Evaluate&& evaluate) {
  ProgressBar bar(label, out);
  const auto report = evaluate(bar.callback());
  bar.finish();
  say(out, "{}", report.summary());
  emit_json(out, report.to_json());
  return 0;
}

}  // namespace lp::cli
