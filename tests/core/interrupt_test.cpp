#include "core/interrupt.h"

#include <gtest/gtest.h>

#include <csignal>
#include <filesystem>
#include <fstream>
#include <string>

#include <sys/wait.h>
#include <unistd.h>

namespace lp {
namespace {

namespace fs = std::filesystem;

fs::path temp_file(const std::string& name) {
  const fs::path dir = fs::temp_directory_path() / ("lightprobe_interrupt_test_" + std::to_string(::getpid()));
  fs::create_directories(dir);
  const fs::path p = dir / name;
  std::ofstream(p) << "half written";
  return p;
}

// Runs `body` in a child with the handlers installed; the child's exit code.
template <typename F>
int in_child(F body) {
  const pid_t pid = ::fork();
  if (pid == 0) {
    install_interrupt_handlers();
    body();
    ::_exit(0);
  }
  int status = 0;
  ::waitpid(pid, &status, 0);
  return WIFEXITED(status) ? WEXITSTATUS(status) : -1;
}

TEST(Interrupt, ASignalRemovesRegisteredTempFilesAndExitsWith128PlusTheSignal) {
  const fs::path registered = temp_file("out.exr.tmp-abc123"), done = temp_file("done.tmp-xyz");
  EXPECT_EQ(in_child([&] {
              { TempFileRegistration renamed(done.string()); }  // unregistered: left alone
              TempFileRegistration r(registered.string());
              ::raise(SIGTERM);
            }),
            143);
  EXPECT_FALSE(fs::exists(registered));
  EXPECT_TRUE(fs::exists(done));
  EXPECT_EQ(in_child([] { ::raise(SIGINT); }), 130);
}

TEST(Interrupt, DeferredCommandsSeeTheFlagAndASecondSignalEndsThem) {
  EXPECT_EQ(in_child([] {
              defer_interrupts();
              ::raise(SIGINT);
              ::_exit(interrupt_signal() == SIGINT && interrupt_exit_code() == 130 ? 7 : 1);
            }),
            7);
  const fs::path registered = temp_file("second.tmp-1");
  EXPECT_EQ(in_child([&] {
              defer_interrupts();
              TempFileRegistration r(registered.string());
              ::raise(SIGTERM);
              ::raise(SIGTERM);
              ::_exit(1);
            }),
            143);
  EXPECT_FALSE(fs::exists(registered));
}

}  // namespace
}  // namespace lp
