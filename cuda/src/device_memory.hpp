// Device memory of one build: stream-ordered allocations from a per-device
// memory pool, counted against a byte budget.
//
// Why a pool: a level-synchronous build allocates and frees a handful of
// arrays per level. cudaMallocFromPoolAsync serves those from memory the pool
// already holds (no driver call, no device synchronisation), and frees are
// ordered on the build's stream, so a buffer can be released while kernels
// that read it are still queued. The pool keeps what it holds between builds
// up to a retention size (repeated builds, benchmarks); the rest goes back to
// the driver at the end of each build (setCudaPoolRetention).
//
// Why a budget: BuildOptions::deviceMemoryBudget (or the free memory) caps
// live bytes. An allocation beyond it throws DeviceMemoryExhausted before it
// reaches the driver, exactly like a real cudaErrorMemoryAllocation, and the
// driver reacts to both by building in smaller chunks.
#pragma once

#include "check.hpp"

#include <cuda_runtime.h>

#include <cstddef>
#include <cstdint>
#include <utility>

namespace hdt {
namespace cuda {

class DeviceMemory {
public:
  DeviceMemory(int device, cudaStream_t stream, uint64_t budget);
  ~DeviceMemory();
  DeviceMemory(const DeviceMemory&) = delete;
  DeviceMemory& operator=(const DeviceMemory&) = delete;

  // Throws DeviceMemoryExhausted when live + bytes exceeds the budget or the
  // device has no room. Zero bytes gives nullptr.
  void* allocate(size_t bytes);
  void release(void* p, size_t bytes) noexcept;

  // Counts bytes against the budget without allocating them: lets a phase
  // that will later need memory (a chunk's leaf grids) prove now that it fits.
  void reserve(size_t bytes);
  void unreserve(size_t bytes) noexcept { live_ -= bytes; }

  // Hands what the pool holds unused back to the driver (after the stream's
  // frees), for allocations outside the pool (the winding pass's cudaMalloc).
  // False when there was nothing to give back.
  bool releaseUnused();

  cudaStream_t stream() const { return stream_; }
  uint64_t live() const { return live_; }
  uint64_t peak() const { return peak_; }
  uint64_t budget() const { return budget_; }
  void resetPeak() { peak_ = live_; }

  // Bytes an allocation of the pool could get right now: free device memory
  // plus what the pool holds unused.
  static uint64_t obtainable(int device);
  // Grows the device's pool to `bytes` now (mapping memory is what makes a
  // process's first build slow); the pool keeps it for the builds.
  static void prefill(int device, cudaStream_t stream, uint64_t bytes);
  // Destroys the device's pool (its memory goes back to the driver); the next
  // build makes a new one.
  static void releasePool(int device);

private:
  int device_;
  cudaStream_t stream_;
  cudaMemPool_t pool_ = nullptr; // null: pools unsupported, plain cudaMalloc
  uint64_t budget_;
  uint64_t live_ = 0, peak_ = 0;
};

// A typed, move-only device array owned by a DeviceMemory.
template <class T>
class DeviceBuffer {
public:
  DeviceBuffer() = default;
  DeviceBuffer(DeviceMemory& mem, size_t count)
      : mem_(&mem), count_(count), ptr_(static_cast<T*>(mem.allocate(count * sizeof(T)))) {}
  ~DeviceBuffer() { reset(); }
  DeviceBuffer(DeviceBuffer&& o) noexcept { *this = std::move(o); }
  DeviceBuffer& operator=(DeviceBuffer&& o) noexcept {
    if (this != &o) {
      reset();
      mem_ = std::exchange(o.mem_, nullptr);
      count_ = std::exchange(o.count_, 0);
      ptr_ = std::exchange(o.ptr_, nullptr);
    }
    return *this;
  }
  DeviceBuffer(const DeviceBuffer&) = delete;
  DeviceBuffer& operator=(const DeviceBuffer&) = delete;

  void reset() noexcept {
    if (mem_ && ptr_) mem_->release(ptr_, count_ * sizeof(T));
    ptr_ = nullptr;
    count_ = 0;
  }
  T* data() const { return ptr_; }
  size_t size() const { return count_; }
  size_t bytes() const { return count_ * sizeof(T); }

private:
  DeviceMemory* mem_ = nullptr;
  size_t count_ = 0;
  T* ptr_ = nullptr;
};

// A byte reservation (DeviceMemory::reserve) released on scope exit.
class Reservation {
public:
  Reservation(DeviceMemory& mem, size_t bytes) : mem_(mem), bytes_(bytes) { mem.reserve(bytes); }
  ~Reservation() { mem_.unreserve(bytes_); }
  Reservation(const Reservation&) = delete;
  Reservation& operator=(const Reservation&) = delete;

private:
  DeviceMemory& mem_;
  size_t bytes_;
};

} // namespace cuda
} // namespace hdt
