// Transparent huge pages for large arrays about to be written for the first
// time. On a VM a 4 KiB page fault costs microseconds, and a fresh array of
// 100 MB is 25,000 of them; with 2 MiB pages it is 50. Where the kernel's
// THP mode is "madvise" (Debian's default) only advised ranges get them.
#pragma once

#include "hdt/default_init_allocator.hpp"

#include <cstddef>
#include <cstdint>
#include <cstdlib>
#include <memory>
#include <new>
#include <type_traits>
#include <utility>

#include "hdt/warm_pages.hpp"

#include <tbb/parallel_for.h>

#include <algorithm>

#if defined(__linux__)
#include <sys/mman.h>
#include <unistd.h>
#endif

namespace hdt {

constexpr size_t kHugePageBytes = size_t(2) << 20;

// Advises the whole 2 MiB pages inside [p, p + bytes); only a hint: where the
// kernel says no, 4 KiB pages it is. Pages already touched keep their size.
inline void adviseHugePages(void* p, size_t bytes) {
#if defined(__linux__) && defined(MADV_HUGEPAGE)
  const uintptr_t begin = (reinterpret_cast<uintptr_t>(p) + kHugePageBytes - 1) & ~uintptr_t(kHugePageBytes - 1);
  const uintptr_t end = (reinterpret_cast<uintptr_t>(p) + bytes) & ~uintptr_t(kHugePageBytes - 1);
  if (end > begin) madvise(reinterpret_cast<void*>(begin), end - begin, MADV_HUGEPAGE);
#else
  (void)p;
  (void)bytes;
#endif
}

// Faults in the whole pages of [p, p + bytes) for writing, 1 MiB pieces in
// parallel, so that a fresh array's first pass runs at memory speed instead of
// one page fault at a time. Only a hint: a kernel without
// MADV_POPULATE_WRITE (before Linux 5.14) leaves the faults to the first
// writes.
inline void prefaultParallel(void* p, size_t bytes) {
#if defined(__linux__) && defined(MADV_POPULATE_WRITE)
  const uintptr_t page = uintptr_t(sysconf(_SC_PAGESIZE)), piece = uintptr_t(1) << 20;
  const uintptr_t begin = (reinterpret_cast<uintptr_t>(p) + page - 1) & ~(page - 1);
  const uintptr_t end = (reinterpret_cast<uintptr_t>(p) + bytes) & ~(page - 1);
  if (end <= begin + piece) return;
  tbb::parallel_for(begin, end, piece, [&](uintptr_t q) {
    madvise(reinterpret_cast<void*>(q), std::min(piece, end - q), MADV_POPULATE_WRITE); // a hint: may fail
  });
#else
  (void)p;
  (void)bytes;
#endif
}

// std::allocator whose large blocks are 2 MiB aligned and advised for huge
// pages (for vectors that grow to many MB: each growth writes fresh memory),
// or taken from reserved warm pages (warm_pages.hpp) where they fit.
template <class T>
struct HugePageAllocator {
  using value_type = T;
  HugePageAllocator() noexcept = default;
  template <class U> HugePageAllocator(const HugePageAllocator<U>&) noexcept {}

  T* allocate(size_t n) {
    const size_t bytes = n * sizeof(T);
    if (n <= SIZE_MAX / sizeof(T))
      if (void* p = detail::takeWarmPages(bytes)) return static_cast<T*>(p); // already faulted in
    if (bytes < 2 * kHugePageBytes) return std::allocator<T>().allocate(n);
    const size_t rounded = (bytes + kHugePageBytes - 1) & ~(kHugePageBytes - 1);
    void* p = std::aligned_alloc(kHugePageBytes, rounded);
    if (!p) throw std::bad_alloc();
    adviseHugePages(p, rounded);
    return static_cast<T*>(p);
  }
  void deallocate(T* p, size_t n) noexcept {
    if (detail::returnWarmPages(p, n * sizeof(T))) return;
    if (n * sizeof(T) < 2 * kHugePageBytes) {
      std::allocator<T>().deallocate(p, n);
    } else {
      std::free(p);
    }
  }
};
template <class T, class U>
bool operator==(const HugePageAllocator<T>&, const HugePageAllocator<U>&) noexcept { return true; }
template <class T, class U>
bool operator!=(const HugePageAllocator<T>&, const HugePageAllocator<U>&) noexcept { return false; }

// HugePageAllocator whose resize(n) leaves new elements unwritten: for
// arrays written in parallel right after they are sized.
template <class T> using HugePageScratchAllocator = DefaultInit<HugePageAllocator<T>>;

} // namespace hdt
