// Large allocations on transparent huge pages. A one-shot command touches its buffers once:
// `sample` on a 1024x512 map faults in ~45 MB of fresh pages (the map, the sampler's CDFs,
// the accuracy reference's ring sums), 11,700 page faults that cost more than the work done
// on those pages (on this project's VMs a fault costs ~8 us). The kernel here backs memory
// with 2 MB pages only where madvise(MADV_HUGEPAGE) asks (THP "madvise" mode), and glibc asks
// only when started with GLIBC_TUNABLES=glibc.malloc.hugetlb=1, which a program cannot set
// for itself. So the executable's operator new asks for blocks of 2 MB and more, aligned to
// 2 MB: glibc maps them fresh, and the advice comes before the first touch.
//
// Only operator new: malloc from C libraries is left alone. Not in sanitizer builds, whose
// runtime replaces operator new itself.
#include <sys/mman.h>

#include <cstddef>
#include <cstdint>
#include <cstdlib>
#include <new>

#if defined(__has_feature)
#if __has_feature(address_sanitizer)
#define LIGHTPROBE_ASAN 1
#endif
#endif
#if !defined(__SANITIZE_ADDRESS__) && !defined(LIGHTPROBE_ASAN)

namespace {

constexpr std::size_t kHugePage = std::size_t(2) << 20;

// `alignment`: 0 for plain new (malloc's), else the over-alignment a type asks (a power of
// two, as operator new's align_val_t must be).
void* allocate(std::size_t size, std::size_t alignment = 0) {
  void* p = nullptr;
  if (size >= kHugePage) {
    // Aligned and rounded up to whole 2 MB pages (at most half of the block more), so that
    // every page of it is a huge one; the advice is a hint, its failure harmless.
    const std::size_t rounded = (size + kHugePage - 1) & ~(kHugePage - 1);
    p = std::aligned_alloc(alignment > kHugePage ? alignment : kHugePage, rounded);
    if (p) (void)madvise(p, rounded, MADV_HUGEPAGE);
  } else if (alignment > alignof(std::max_align_t)) {
    // aligned_alloc wants a size that is a multiple of the alignment.
    p = std::aligned_alloc(alignment, (size + alignment - 1) & ~(alignment - 1));
  } else {
    p = std::malloc(size ? size : 1);
  }
  if (!p) throw std::bad_alloc();
  return p;
}

}  // namespace

void* operator new(std::size_t size) { return allocate(size); }
void* operator new[](std::size_t size) { return allocate(size); }
void* operator new(std::size_t size, const std::nothrow_t&) noexcept {
  try {
    return allocate(size);
  } catch (const std::bad_alloc&) {
    return nullptr;
  }
}
void* operator new[](std::size_t size, const std::nothrow_t& tag) noexcept { return operator new(size, tag); }
// Over-aligned types (q2tree's 32-byte bins, an 8 MB pyramid at 1024 x 512) come through
// these: without them their blocks missed the advice.
void* operator new(std::size_t size, std::align_val_t a) { return allocate(size, std::size_t(a)); }
void* operator new[](std::size_t size, std::align_val_t a) { return allocate(size, std::size_t(a)); }
void* operator new(std::size_t size, std::align_val_t a, const std::nothrow_t&) noexcept {
  try {
    return allocate(size, std::size_t(a));
  } catch (const std::bad_alloc&) {
    return nullptr;
  }
}
void* operator new[](std::size_t size, std::align_val_t a, const std::nothrow_t& tag) noexcept {
  return operator new(size, a, tag);
}
void operator delete(void* p, std::align_val_t) noexcept { std::free(p); }
void operator delete[](void* p, std::align_val_t) noexcept { std::free(p); }
void operator delete(void* p, std::size_t, std::align_val_t) noexcept { std::free(p); }
void operator delete[](void* p, std::size_t, std::align_val_t) noexcept { std::free(p); }
void operator delete(void* p, std::align_val_t, const std::nothrow_t&) noexcept { std::free(p); }
void operator delete[](void* p, std::align_val_t, const std::nothrow_t&) noexcept { std::free(p); }
void operator delete(void* p) noexcept { std::free(p); }
void operator delete[](void* p) noexcept { std::free(p); }
void operator delete(void* p, std::size_t) noexcept { std::free(p); }
void operator delete[](void* p, std::size_t) noexcept { std::free(p); }
void operator delete(void* p, const std::nothrow_t&) noexcept { std::free(p); }
void operator delete[](void* p, const std::nothrow_t&) noexcept { std::free(p); }

#endif
