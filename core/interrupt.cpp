#include "core/interrupt.h"

#include <atomic>
#include <csignal>
#include <cstring>

#include <pthread.h>
#include <unistd.h>

namespace lp {
namespace {

// Slots the handler can read without locks: state 0 free, 1 being written, 2 holds a path.
constexpr int kSlots = 64;
constexpr size_t kPathMax = 4096;
struct Slot {
  std::atomic<int> state{0};
  char path[kPathMax];
};
Slot g_slots[kSlots];

std::atomic<int> g_signal{0};
std::atomic<bool> g_deferred{false};

void remove_temp_files() {
  for (Slot& s : g_slots)
    if (s.state.load() == 2) ::unlink(s.path);
}

extern "C" void on_interrupt(int sig) {
  const int before = g_signal.exchange(sig);
  if (g_deferred.load() && before == 0) return;  // the command stops itself and polls
  remove_temp_files();
  ::_exit(128 + sig);
}

}  // namespace

void install_interrupt_handlers() {
  struct sigaction sa {};
  sa.sa_handler = on_interrupt;
  sigemptyset(&sa.sa_mask);
  sa.sa_flags = SA_RESTART;
  sigaction(SIGINT, &sa, nullptr);
  sigaction(SIGTERM, &sa, nullptr);
}

void defer_interrupts() { g_deferred = true; }

int interrupt_signal() { return g_signal.load(); }

int interrupt_exit_code() {
  const int sig = g_signal.load();
  return sig ? 128 + sig : 0;
}

InterruptsHeld::InterruptsHeld() {
  sigset_t held;
  sigemptyset(&held);
  sigaddset(&held, SIGINT);
  sigaddset(&held, SIGTERM);
  pthread_sigmask(SIG_BLOCK, &held, &previous_);
}

InterruptsHeld::~InterruptsHeld() { pthread_sigmask(SIG_SETMASK, &previous_, nullptr); }

TempFileRegistration::TempFileRegistration(const std::string& path) {
  if (path.size() >= kPathMax) return;
  for (int i = 0; i < kSlots; ++i) {
    int expected = 0;
    if (!g_slots[i].state.compare_exchange_strong(expected, 1)) continue;
    std::memcpy(g_slots[i].path, path.c_str(), path.size() + 1);
    g_slots[i].state = 2;
    slot_ = i;
    return;
  }
}

TempFileRegistration::~TempFileRegistration() {
  if (slot_ >= 0) g_slots[slot_].state = 0;
}

}  // namespace lp
