#include "hdt/warm_pages.hpp"

#include "hdt/huge_pages.hpp" // kHugePageBytes, adviseHugePages

#include "host_arena.hpp"

#include <tbb/parallel_for.h>
#include <tbb/partitioner.h>
#include <tbb/task_arena.h>

#include <algorithm>
#include <atomic>
#include <chrono>
#include <cstdint>
#include <cstring>
#include <iterator>
#include <map>
#include <memory>
#include <mutex>
#include <thread>
#include <vector>

#if defined(__linux__)
#include <sys/mman.h>
#endif
#if defined(__linux__) && !defined(MADV_POPULATE_WRITE)
#define MADV_POPULATE_WRITE 23 // Linux 5.14; older kernels answer EINVAL and the pages are touched instead
#endif

namespace hdt {

tbb::task_arena& hostArena() {
  static tbb::task_arena arena; // all cores, one slot kept for the calling thread
  return arena;
}

void startHostThreads() {
  hostArena().execute([] {
    const int lanes = tbb::this_task_arena::max_concurrency();
    std::atomic<int> arrived{0};
    const auto deadline = std::chrono::steady_clock::now() + std::chrono::milliseconds(20);
    tbb::parallel_for(
        0, lanes,
        [&](int) {
          arrived.fetch_add(1);
          while (arrived.load() < lanes && std::chrono::steady_clock::now() < deadline) std::this_thread::yield();
        },
        tbb::static_partitioner());
  });
}

namespace {
std::atomic<bool> keepAwake{false};
} // namespace

void keepHostThreadsAwake(unsigned limitMs) {
  keepAwake.store(true);
  const auto deadline = std::chrono::steady_clock::now() + std::chrono::milliseconds(limitMs);
  // One task a worker (the arena keeps a slot for a caller); one more queued
  // behind them would find the flag down and end at once.
  const int workers = std::max(1, hostArena().max_concurrency() - 1);
  for (int i = 0; i < workers; ++i) {
    hostArena().enqueue([deadline] {
      while (keepAwake.load(std::memory_order_relaxed) && std::chrono::steady_clock::now() < deadline)
        std::this_thread::yield();
    });
  }
}

void releaseHostThreads() { keepAwake.store(false, std::memory_order_relaxed); }

#if defined(__linux__)
namespace {

constexpr size_t kDropOnMissBytes = size_t(64) << 20;

// One mapping of faulted-in pages; `free` maps offsets to lengths (granules),
// neighbours merged.
struct Region {
  uint8_t* base = nullptr;
  size_t size = 0;
  size_t smallestArray = 0; // arrays under this size do not take these pages
  std::map<size_t, size_t> free;
  bool wholeFree() const { return free.size() == 1 && free.begin()->first == 0 && free.begin()->second == size; }
};

struct Pool {
  std::mutex mutex;
  std::vector<Region> regions;
  std::atomic<size_t> count{0}; // regions.size(), read without the lock
};

Pool& pool() {
  static Pool* p = new Pool; // never destroyed: arrays may be freed by static destructors after main
  return *p;
}

// Under the lock: unmaps the regions no array holds memory of (of those an
// array of `arrayBytes` may take).
void unmapWholeFree(Pool& p, size_t arrayBytes = SIZE_MAX) {
  auto keep = std::remove_if(p.regions.begin(), p.regions.end(), [arrayBytes](const Region& r) {
    if (!r.wholeFree() || arrayBytes < r.smallestArray) return false;
    munmap(r.base, r.size);
    return true;
  });
  p.regions.erase(keep, p.regions.end());
  p.count.store(p.regions.size());
}

// 2 MiB aligned anonymous memory of `size` (a multiple of 2 MiB), or null.
uint8_t* mapAligned(size_t size) {
  void* m = mmap(nullptr, size + kHugePageBytes, PROT_READ | PROT_WRITE, MAP_PRIVATE | MAP_ANONYMOUS, -1, 0);
  if (m == MAP_FAILED) return nullptr;
  const uintptr_t raw = reinterpret_cast<uintptr_t>(m);
  const uintptr_t base = (raw + kHugePageBytes - 1) & ~uintptr_t(kHugePageBytes - 1);
  if (base > raw) munmap(m, base - raw);
  if (raw + kHugePageBytes > base) munmap(reinterpret_cast<void*>(base + size), raw + kHugePageBytes - base);
  return reinterpret_cast<uint8_t*>(base);
}

} // namespace

void reserveWarmPages(size_t bytes, size_t smallestArray) {
  if (bytes == 0) return;
  const size_t size = (bytes + kHugePageBytes - 1) & ~(kHugePageBytes - 1);
  uint8_t* base = mapAligned(size);
  if (!base) return;
  adviseHugePages(base, size);
  tbb::parallel_for(size_t(0), size / kHugePageBytes, [base](size_t k) {
    uint8_t* page = base + k * kHugePageBytes;
    if (madvise(page, kHugePageBytes, MADV_POPULATE_WRITE) == 0) return;
    for (size_t i = 0; i < kHugePageBytes; i += 4096) page[i] = 0; // an older kernel: touch each page
  });
  Pool& p = pool();
  std::lock_guard<std::mutex> lock(p.mutex);
  Region r;
  r.base = base;
  r.size = size;
  r.smallestArray = smallestArray;
  r.free.emplace(0, size);
  p.regions.push_back(std::move(r));
  p.count.store(p.regions.size());
}

void trimWarmPages() {
  Pool& p = pool();
  std::lock_guard<std::mutex> lock(p.mutex);
  unmapWholeFree(p);
  for (const Region& r : p.regions) {
    for (const auto& [offset, length] : r.free) {
      const uintptr_t begin = (reinterpret_cast<uintptr_t>(r.base + offset) + kHugePageBytes - 1) & ~uintptr_t(kHugePageBytes - 1);
      const uintptr_t end = reinterpret_cast<uintptr_t>(r.base + offset + length) & ~uintptr_t(kHugePageBytes - 1);
      if (end > begin) madvise(reinterpret_cast<void*>(begin), end - begin, MADV_DONTNEED);
    }
  }
}

WarmPagesState warmPagesState() {
  Pool& p = pool();
  std::lock_guard<std::mutex> lock(p.mutex);
  WarmPagesState s;
  for (const Region& r : p.regions) {
    s.reserved += r.size;
    for (const auto& f : r.free) s.free += f.second;
  }
  return s;
}

namespace detail {

void* takeWarmPages(size_t bytes) noexcept {
  Pool& p = pool();
  if (bytes < kWarmMinBytes || p.count.load() == 0) return nullptr;
  const size_t length = warmRounded(bytes);
  std::lock_guard<std::mutex> lock(p.mutex);
  // The newest reservation first: the one made for the arrays now allocated
  // (older ones' free ranges may have been trimmed, i.e. are no longer warm).
  for (auto region = p.regions.rbegin(); region != p.regions.rend(); ++region) {
    Region& r = *region;
    if (bytes < r.smallestArray) continue;
    for (auto it = r.free.begin(); it != r.free.end(); ++it) {
      if (it->second < length) continue;
      const size_t offset = it->first, left = it->second - length;
      r.free.erase(it);
      if (left) r.free.emplace(offset + length, left);
      return r.base + offset;
    }
  }
  // A large array will be fresh memory: a reservation no array holds (an
  // estimate that fell short) is not kept beside it.
  if (bytes >= kDropOnMissBytes) unmapWholeFree(p, bytes);
  return nullptr;
}

bool returnWarmPages(void* ptr, size_t bytes) noexcept {
  Pool& p = pool();
  if (bytes < kWarmMinBytes || p.count.load() == 0) return false;
  const auto* q = static_cast<const uint8_t*>(ptr);
  std::lock_guard<std::mutex> lock(p.mutex);
  for (Region& r : p.regions) {
    if (q < r.base || q >= r.base + r.size) continue;
    size_t offset = size_t(q - r.base), length = warmRounded(bytes);
    auto next = r.free.lower_bound(offset);
    if (next != r.free.end() && next->first == offset + length) { // merge with the range after
      length += next->second;
      next = r.free.erase(next);
    }
    if (next != r.free.begin()) { // and the one before
      auto before = std::prev(next);
      if (before->first + before->second == offset) {
        offset = before->first;
        length += before->second;
        r.free.erase(before);
      }
    }
    r.free.emplace(offset, length);
    return true;
  }
  return false;
}

} // namespace detail

#else // no mmap: nothing is reserved, every array allocates as before

void reserveWarmPages(size_t, size_t) {}
void trimWarmPages() {}
WarmPagesState warmPagesState() { return {}; }
namespace detail {
void* takeWarmPages(size_t) noexcept { return nullptr; }
bool returnWarmPages(void*, size_t) noexcept { return false; }
} // namespace detail

#endif

} // namespace hdt
