#include "core/progress.h"

#include <fmt/format.h>
#include <unistd.h>

#include <algorithm>
#include <cstdio>
#include <memory>
#include <mutex>

namespace lp {

namespace {

// One terminal, one bar at a time: whoever holds this lock draws; other threads that
// advance meanwhile skip drawing rather than wait. It also guards last_draw_.
std::mutex g_draw_mutex;

constexpr auto kMinInterval = std::chrono::milliseconds(100);  // at most 10 redraws a second
constexpr int kBarWidth = 30;

std::string format_duration(double seconds) {
  if (!(seconds >= 0) || seconds > 359999) return "--:--";
  const long s = long(seconds + 0.5);
  if (s >= 3600) return fmt::format("{}:{:02}:{:02}", s / 3600, (s / 60) % 60, s % 60);
  return fmt::format("{}:{:02}", s / 60, s % 60);
}

}  // namespace

Progress::Progress(std::string label, uint64_t total, bool enabled)
    : label_(std::move(label)), total_(total), active_(enabled && isatty(2) == 1) {
  start_ = std::chrono::steady_clock::now();
  last_draw_ = start_ - kMinInterval;  // the first advance draws
}

Progress::~Progress() { finish(); }

void Progress::advance(uint64_t steps) {
  done_.fetch_add(steps, std::memory_order_relaxed);
  if (!active_) return;
  std::unique_lock lock(g_draw_mutex, std::try_to_lock);
  if (!lock.owns_lock() || !active_) return;  // re-checked: finish() may have run
  const auto now = std::chrono::steady_clock::now();
  if (now - last_draw_ < kMinInterval) return;
  last_draw_ = now;
  draw(false);
}

void Progress::finish() {
  std::lock_guard lock(g_draw_mutex);
  if (!active_) return;
  draw(true);
  std::fputc('\n', stderr);
  std::fflush(stderr);
  active_ = false;  // finish once; the destructor then does nothing
}

void Progress::draw(bool final) {
  const uint64_t done = std::min(done_.load(std::memory_order_relaxed), total_ ? total_ : UINT64_MAX);
  const double elapsed = std::chrono::duration<double>(std::chrono::steady_clock::now() - start_).count();
  const double fraction = total_ ? double(done) / double(total_) : (final ? 1.0 : 0.0);
  const int filled = std::clamp(int(fraction * kBarWidth + 0.5), 0, kBarWidth);
  const double rate = elapsed > 0 ? double(done) / elapsed : 0.0;
  std::string line = fmt::format("\r{} [{}{}] {:3d}% {}/{}", label_, std::string(size_t(filled), '#'),
                                 std::string(size_t(kBarWidth - filled), '.'), int(fraction * 100 + 1e-9),
                                 done, total_);
  if (rate >= 100)
    line += fmt::format(" {:.0f}/s", rate);
  else
    line += fmt::format(" {:.1f}/s", rate);
  if (final)
    line += fmt::format(" {}", format_duration(elapsed));
  else
    line += fmt::format(" ETA {}", rate > 0 ? format_duration(double(total_ - done) / rate) : "--:--");
  line += "\x1b[K";  // clear what a longer previous line left behind
  std::fputs(line.c_str(), stderr);
  std::fflush(stderr);
}

std::function<void(const std::string&, int, int)> stage_progress_bars(std::string prefix, bool enabled) {
  struct Bars {
    std::unique_ptr<Progress> bar;
    std::string stage;
    int done = 0, total = 0;
  };
  auto bars = std::make_shared<Bars>();
  return [bars, prefix = std::move(prefix), enabled](const std::string& stage, int done, int total) {
    Bars& b = *bars;
    if (stage != b.stage) {
      if (b.bar) {
        if (b.total > b.done) b.bar->advance(uint64_t(b.total - b.done));
        b.bar->finish();
      }
      b.bar.reset();
      b.stage = stage;
      b.done = 0;
      b.total = std::max(1, total);
      if (stage != "done") b.bar = std::make_unique<Progress>(prefix + stage, uint64_t(b.total), enabled);
    }
    if (b.bar && done > b.done) {
      b.bar->advance(uint64_t(done - b.done));
      b.done = done;
    }
  };
}

}  // namespace lp
