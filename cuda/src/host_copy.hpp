// Copy-back at the interconnect's speed: device memory to pageable host
// memory through a ring of pinned staging buffers. What bounds it on a VM is
// the host side: the first touch of the destination's pages and the copy out
// of the staging buffers (the link moves 55 GB/s; bench/results/end-to-end.md).
// So the copy out never waits at a barrier: the destination is cut at its own
// 2 MiB (huge page) boundaries into tasks that the host threads take in order,
// each thread faulting in and filling whole pages of its own, and a slot of the
// ring goes back to the DMA as soon as its last task is done.
#pragma once

#include <cuda_runtime.h>

#include <cstddef>
#include <functional>

namespace hdt {
namespace cuda {

// Called with n each time bytes [0, n) of the destination hold their final
// value (n grows; the last call has n = bytes), on one of the copying threads,
// never two at once.
using CopiedPrefix = std::function<void(size_t n)>;

// Copies `bytes` from `device` (memory of the current device) to `host` in
// stream order (after the work queued on `stream`) and returns when `host`
// holds them. Small copies, and all copies where no memory can be pinned,
// take the driver's pageable path. Thread-safe: concurrent callers take turns
// on the current device's ring (one a device, for the life of the process).
// spareThreads: of the calling arena's threads, how many the copy leaves to
// other work (a thread that drives the device beside it, say).
void copyToHost(cudaStream_t stream, void* host, const void* device, size_t bytes,
                const CopiedPrefix& copied = {}, int spareThreads = 0);

// Host to device through the same ring (the host threads fill a slot while
// the link drains the others); returns when `device` holds the bytes. Small
// copies, and all copies where no memory can be pinned, take the driver's
// pageable path.
void copyToDevice(cudaStream_t stream, void* device, const void* host, size_t bytes);

// Host to host, in parallel (oneTBB), in tasks cut at the destination's huge
// page boundaries: what one core's memcpy cannot fill, first touch included.
void copyHostParallel(void* dst, const void* src, size_t bytes);

// Zeros over `bytes` at `host` in the same tasks: faults an unwritten
// destination's pages in (their first touch costs a copy into them about as
// much as the copy itself) before a copy lands there, off its critical path.
void touchHostParallel(void* host, size_t bytes);

// Allocates the current device's staging ring now (pinning costs tens of ms: at process start,
// not inside the first build's copy-back). Idempotent.
void reserveCopyStaging();

// Frees the current device's staging ring (before its context goes: releaseCuda).
void releaseCopyStaging();

// The ring's shape, for the copy benchmark (bench/gpu/copy_bench.cpp): the
// same copy through a ring of `slots` pinned buffers of `pieceBytes`
// allocated by the caller (cudaMallocHost), with `events` (one a slot).
struct StagingRing {
  int slots = 0;
  size_t pieceBytes = 0;
  unsigned char* const* slot = nullptr;
  const cudaEvent_t* arrived = nullptr;
};
void copyThroughRing(const StagingRing& ring, cudaStream_t stream, void* host, const void* device, size_t bytes,
                     const CopiedPrefix& copied = {}, int spareThreads = 0);

} // namespace cuda
} // namespace hdt
