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
// The handler itself only sets a flag and writes to a pipe; a watcher thread started here
// removes the temp files and exits, under the lock temp files are created with.
#pragma once

#include <functional>
#include <string>

namespace lp {

void install_interrupt_handlers();
void defer_interrupts();
// The signal received (SIGINT, SIGTERM), or 0 when none has been.
int interrupt_signal();
// 128 + the signal received, the exit code for it; 0 when none has been.
int interrupt_exit_code();

// A signal that ends the process (any while not deferred, the second when deferred) ends it
// here at once, in the calling thread, rather than moments later from the watcher (temp files removed,
// 128 + signal); main calls it before returning, so a command finishing as the signal lands
// does not exit 0.
void end_if_interrupted();

// Creates a new file at the first name next_name() gives that does not exist yet (O_EXCL;
// up to 100 tries), registered for removal by a signal in the same step, so no signal can
// find it created but unregistered. Returns the open descriptor (path set to its name), or
// -1 with errno set. Unregister it (unregister_temp_file) once renamed or removed.
int create_registered_temp_file(const std::function<std::string()>& next_name, std::string& path);
void unregister_temp_file(const std::string& path);

// Registers an existing temp file for removal by a signal while this lives.
class TempFileRegistration {
 public:
  explicit TempFileRegistration(const std::string& path);
  ~TempFileRegistration();
  TempFileRegistration(const TempFileRegistration&) = delete;
  TempFileRegistration& operator=(const TempFileRegistration&) = delete;

 private:
  std::string path_;
};

}  // namespace lp
