#include "core/heap_tuning.h"

#include <cstdlib>  // defines __GLIBC__ where glibc is the C library

#if defined(__GLIBC__)
#include <malloc.h>
#endif

namespace lp {

void keep_heap_for_reuse() {
#if defined(__GLIBC__)
  static const bool once = [] {
    mallopt(M_TOP_PAD, 64 << 20);
    mallopt(M_MMAP_THRESHOLD, 32 << 20);  // large blocks from the heap too, reused
    mallopt(M_TRIM_THRESHOLD, 512 << 20);  // and freed ones kept for the next frame or solve
    return true;
  }();
  (void)once;
#endif
}

}  // namespace lp
