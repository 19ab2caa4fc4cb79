// A progress bar with rate and ETA on a terminal's stderr; silent when stderr is not a
// terminal (piped, CI) or when disabled. Thread-safe `advance`.
#pragma once

#include <atomic>
#include <chrono>
#include <cstdint>
#include <string>

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

}  // namespace lp
