// Ending on SIGINT / SIGTERM cleanly, whatever the command is doing.
//
// Default (install_interrupt_handlers, once in main): a signal removes the temp files that
// atomic writers have registered (so no "out.exr.tmp-XXXXXX" is left behind) and ends the
// process at once with the shell's code, 128 + signal (130 for SIGINT, 143 for SIGTERM).
// Installing the handlers also undoes an inherited "ignore SIGINT" (a background job of a
// non-interactive shell starts so), which made `sample` deaf to it.
// A command that ends itself cleanly (stream, merge: stop the servers, print the summary)
// calls defer_interrupts(): from then a first signal only sets the flag it polls
// (interrupt_signal()), and a second one ends the process as above. main returns
// 128 + interrupt_signal() when the command comes back after a deferred signal.
// Everything the handler does is async-signal-safe (unlink, _exit, atomics).
#pragma once

#include <csignal>
#include <string>

namespace lp {

void install_interrupt_handlers();
void defer_interrupts();
// The signal received (SIGINT, SIGTERM), or 0 when none has been.
int interrupt_signal();
// 128 + the signal received, the exit code for it; 0 when none has been.
int interrupt_exit_code();

// SIGINT and SIGTERM held back (blocked) while it lives, so that a temp file is never
// created without being registered; a signal that came meanwhile is handled on release.
class InterruptsHeld {
 public:
  InterruptsHeld();
  ~InterruptsHeld();
  InterruptsHeld(const InterruptsHeld&) = delete;
  InterruptsHeld& operator=(const InterruptsHeld&) = delete;

 private:
  sigset_t previous_;
};

// Registers a temp file for removal by the handler while it exists (a fixed number of
// slots; past them a file is not registered, which only loses the cleanup). Unregisters
// on destruction: call it once the file is renamed or removed.
class TempFileRegistration {
 public:
  explicit TempFileRegistration(const std::string& path);
  ~TempFileRegistration();
  TempFileRegistration(const TempFileRegistration&) = delete;
  TempFileRegistration& operator=(const TempFileRegistration&) = delete;

 private:
  int slot_ = -1;
};

}  // namespace lp
