#include "core/interrupt.h"

#include <atomic>
#include <csignal>
#include <cstring>
#include <mutex>
#include <string>
#include <thread>
#include <vector>

#include <fcntl.h>
#include <unistd.h>

namespace lp {
namespace {

// The handler only records the signal and wakes a watcher thread through a pipe (both
// async-signal-safe); the watcher removes the temp files under the same lock that writers
// hold while they create and register one. Blocking the signals around the creation, as
// before, held them back in the writing thread only: the kernel then delivered them to
// another thread (TBB's, OpenCV's), whose handler found the new file not yet registered and
// left it behind.
struct Registry {
  std::mutex lock;
  std::vector<std::string> paths;
};
Registry& registry() {
  static Registry* r = new Registry;  // never destroyed: the watcher may use it during exit
  return *r;
}

std::atomic<int> g_signal{0};
std::atomic<bool> g_deferred{false};
std::atomic<bool> g_ending{false};  // a signal that ends the process has come
int g_wake[2] = {-1, -1};

[[noreturn]] void remove_temp_files_and_exit(int sig) {
  std::lock_guard<std::mutex> hold(registry().lock);  // kept until _exit: no new temp file
  for (const std::string& p : registry().paths) ::unlink(p.c_str());
  ::_exit(128 + sig);
}

extern "C" void on_interrupt(int sig) {
  const int saved_errno = errno;
  const int before = g_signal.exchange(sig);
  if (!(g_deferred.load() && before == 0)) {  // deferred: the command polls and stops itself
    g_ending = true;
    const char byte = char(sig);
    [[maybe_unused]] const ssize_t n = ::write(g_wake[1], &byte, 1);
  }
  errno = saved_errno;
}

void watch_for_signals() {
  char byte = 0;
  for (;;) {
    const ssize_t n = ::read(g_wake[0], &byte, 1);
    if (n == 1) remove_temp_files_and_exit(byte);
    if (n < 0 && errno == EINTR) continue;
    return;
  }
}

}  // namespace

void install_interrupt_handlers() {
  static std::once_flag once;
  std::call_once(once, [] {
    if (::pipe2(g_wake, O_CLOEXEC) != 0) return;  // no watcher: signals then end the process by default
    std::thread(watch_for_signals).detach();
    struct sigaction sa {};
    sa.sa_handler = on_interrupt;
    sigemptyset(&sa.sa_mask);
    sa.sa_flags = SA_RESTART;
    sigaction(SIGINT, &sa, nullptr);
    sigaction(SIGTERM, &sa, nullptr);
  });
}

void defer_interrupts() { g_deferred = true; }

int interrupt_signal() { return g_signal.load(); }

int interrupt_exit_code() {
  const int sig = g_signal.load();
  return sig ? 128 + sig : 0;
}

void end_if_interrupted() {
  if (g_ending.load()) remove_temp_files_and_exit(g_signal.load());
}

int create_registered_temp_file(const std::function<std::string()>& next_name, std::string& path) {
  std::lock_guard<std::mutex> hold(registry().lock);
  for (int attempt = 0; attempt < 100; ++attempt) {
    path = next_name();
    const int fd = ::open(path.c_str(), O_WRONLY | O_CREAT | O_EXCL | O_CLOEXEC, 0666);
    if (fd >= 0) {
      registry().paths.push_back(path);
      return fd;
    }
    if (errno != EEXIST) return -1;
  }
  errno = EEXIST;
  return -1;
}

void unregister_temp_file(const std::string& path) {
  std::lock_guard<std::mutex> hold(registry().lock);
  auto& paths = registry().paths;
  for (auto it = paths.begin(); it != paths.end(); ++it)
    if (*it == path) {
      paths.erase(it);
      return;
    }
}

TempFileRegistration::TempFileRegistration(const std::string& path) : path_(path) {
  std::lock_guard<std::mutex> hold(registry().lock);
  registry().paths.push_back(path);
}

TempFileRegistration::~TempFileRegistration() { unregister_temp_file(path_); }

}  // namespace lp
