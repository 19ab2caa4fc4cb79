#include "core/thread_arena.h"

#include <tbb/task_arena.h>

#include <map>
#include <memory>
#include <mutex>

namespace lp {

void run_in_thread_arena(int threads, const std::function<void()>& work) {
  if (threads <= 0) {
    work();
    return;
  }
  // Never destroyed: an arena torn down among the static destructors could outlive TBB's
  // own global state. The map only grows by the thread counts a process asks for (a few).
  static std::mutex* mutex = new std::mutex;
  static auto* arenas = new std::map<int, std::unique_ptr<tbb::task_arena>>;
  tbb::task_arena* arena;
  {
    std::lock_guard<std::mutex> lock(*mutex);
    std::unique_ptr<tbb::task_arena>& slot = (*arenas)[threads];
    if (!slot) {
      slot = std::make_unique<tbb::task_arena>(threads);
      slot->initialize();
    }
    arena = slot.get();
  }
  arena->execute(work);
}

}  // namespace lp
