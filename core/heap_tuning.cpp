#include "core/heap_tuning.h"

#include <cstdlib>  // defines __GLIBC__ where glibc is the C library

#if defined(__GLIBC__)
#include <malloc.h>
#endif

namespace lp {

void keep_heap_top_for_solvers() {
#if defined(__GLIBC__)
  static const bool once = [] {
    mallopt(M_TOP_PAD, 64 << 20);
    mallopt(M_MMAP_THRESHOLD, 32 << 20);  // large blocks from the heap too, reused
    return true;
  }();
  (void)once;
#endif
}

}  // namespace lp
