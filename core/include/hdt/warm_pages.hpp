// Host memory and threads made ready before the work that needs them.
//
// A fresh process pays twice for its first large arrays: oneTBB starts its
// worker threads at the first parallel loop, and every page of fresh memory
// is faulted in (and zeroed by the kernel) at its first write, which on a VM
// costs more than the write. Both can be done early, while the process waits
// for something else: the mesh file's read, the CUDA context's creation.
//
// Warm pages: reserveWarmPages maps memory, advises huge pages and faults it
// in from all host threads. The large arrays allocated afterwards (those of
// HugePageAllocator and DefaultInitAllocator: prepareMesh's scratch and
// lattice triangles, a volume's leaf words) take their memory from the
// reserved pages where a free range fits, and give it back when freed: their
// first pass then runs at memory speed. Where nothing fits they allocate as
// before. The contents of taken memory are unspecified (these allocators
// never assume zeroed memory).
#pragma once

#include <cstddef>
#include <cstdint>

namespace hdt {

// Starts oneTBB's worker threads now (each one that comes waits for the
// others, at most 20 ms), in the arena prepareMesh runs in: its first call
// afterwards does not wait for threads to be created or moved.
void startHostThreads();

// Keeps oneTBB's workers awake in that arena, without blocking the caller,
// until prepareMesh is called or `limitMs` has passed: each yields its core
// to any other thread that wants one. Call it after startHostThreads and
// reserveWarmPages, while the mesh is read: idle workers fall asleep soon,
// and waking them, one after another, is a few tenths of a ms of
// prepareMesh's first call on a VM (its first loop waits for them).
void keepHostThreadsAwake(unsigned limitMs);

// Reserves `bytes` (rounded up to 2 MiB) of faulted-in memory, in parallel.
// Only a hint: when the memory cannot be mapped nothing is reserved. Thread-safe.
// `smallestArray`: only arrays of at least this many bytes take these pages
// (a reservation for one large array that smaller ones allocated before it
// would otherwise split).
void reserveWarmPages(size_t bytes, size_t smallestArray = 0);

// Gives the reserved memory that no array holds back to the system (unmaps
// regions wholly free, drops the pages of free ranges of 2 MiB and more):
// e.g. an estimate's excess once the arrays it was for exist.
void trimWarmPages();

// Reserved bytes, and those of them free (held by no array).
struct WarmPagesState {
  size_t reserved = 0, free = 0;
};
WarmPagesState warmPagesState();

namespace detail {
// Arrays under this size allocate as before (malloc's own caches serve them).
constexpr size_t kWarmMinBytes = size_t(64) << 10;
// Taken ranges are whole granules.
constexpr size_t kWarmGranule = size_t(64) << 10;
constexpr size_t warmRounded(size_t bytes) { return (bytes + kWarmGranule - 1) & ~(kWarmGranule - 1); }
// A free range of the reserved memory of at least `bytes`, or null.
void* takeWarmPages(size_t bytes) noexcept;
// True (and the range is free again) when `p` came from takeWarmPages.
bool returnWarmPages(void* p, size_t bytes) noexcept;
} // namespace detail

} // namespace hdt
