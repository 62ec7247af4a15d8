// Copy-back at the interconnect's speed: device memory to pageable host
// memory through a ring of pinned staging buffers. The DMA of the next
// pieces runs while the host copies the last one out of its staging buffer
// (in parallel: one core's memcpy, page faults included, is far slower than
// the link), so the copy costs about max(link, host memcpy) per byte instead
// of the driver's pageable path (one staging thread, no overlap).
#pragma once

#include <cuda_runtime.h>

#include <cstddef>

namespace hdt {
namespace cuda {

// Copies `bytes` from `device` (memory of the current device) to `host` in
// stream order (after the work queued on `stream`) and returns when `host`
// holds them. Small copies, and all copies where no memory can be pinned,
// take the driver's pageable path. Thread-safe: concurrent callers take turns
// on the current device's ring (one a device, for the life of the process).
void copyToHost(cudaStream_t stream, void* host, const void* device, size_t bytes);

// Host to host, in parallel (oneTBB): what one core's memcpy cannot fill,
// fresh pages' first touch included.
void copyHostParallel(void* dst, const void* src, size_t bytes);

// Allocates the current device's staging ring now (pinning costs tens of ms: at process start,
// not inside the first build's copy-back). Idempotent.
void reserveCopyStaging();

} // namespace cuda
} // namespace hdt
