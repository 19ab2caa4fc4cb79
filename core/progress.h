// A progress bar with rate and ETA on a terminal's stderr; silent when stderr is not a
// terminal (piped, CI) or when disabled. Thread-safe `advance`.
#pragma once

#include <atomic>
#include <chrono>
#include <cstdint>
#include <cstddef>
#include <functional>
#include <memory>
#include <string>
#include <utility>

namespace lp {

class Progress {
 public:
  Progress(std::string label, uint64_t total, bool enabled = true);
  ~Progress();
  void advance(uint64_t steps = 1);
  void finish();

 private:
  void draw(bool final);
  std::string label_;
  uint64_t total_;
  std::atomic<uint64_t> done_{0};
  bool active_;
  std::chrono::steady_clock::time_point start_, last_draw_;
};

// Bars for a library's (stage, done, total) callback, such as calibration's StageProgress:
// one bar a stage, labelled `prefix` + stage. The library reports a step as it starts, so
// a new stage completes and closes the last one's bar; the stage "done" opens none.
std::function<void(const std::string& stage, int done, int total)> stage_progress_bars(std::string prefix,
                                                                                      bool enabled);

// A bar fed by a library's (done, total) callback, such as the eval harnesses'
// EvalProgress: it starts at the first call, when the total is known.
class CallbackProgress {
 public:
  CallbackProgress(std::string label, bool enabled) : label_(std::move(label)), enabled_(enabled) {}
  // The callback to hand the library; valid while this bar lives.
  std::function<void(size_t, size_t)> callback() {
    return [this](size_t done, size_t total) {
      if (!bar_) bar_ = std::make_unique<Progress>(label_, total, enabled_);
      if (done > reported_) bar_->advance(done - reported_);
      reported_ = done;
    };
  }
  // Ends the bar's line before a report is printed (the destructor does it otherwise).
  void finish() {
    if (bar_) bar_->finish();
  }

 private:
  std::string label_;
  bool enabled_;
  std::unique_ptr<Progress> bar_;
  size_t reported_ = 0;
};

}  // namespace lp
