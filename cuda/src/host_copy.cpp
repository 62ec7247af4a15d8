#include "host_copy.hpp"

#include "check.hpp"

#include "hdt/huge_pages.hpp"

#include <tbb/parallel_for.h>
#include <tbb/task_arena.h>

#include <algorithm>
#include <atomic>
#include <cstdint>
#include <cstdlib>
#include <cstring>
#include <exception>
#include <map>
#include <memory>
#include <mutex>
#include <thread>
#include <vector>

namespace hdt {
namespace cuda {
namespace {

// Below this the driver's own pageable copy is as fast and needs no ring.
constexpr size_t kDirectBytes = size_t(4) << 20;
// The process-wide ring: 4 x 16 MiB. The link fills a slot in 0.3 ms, faster
// than the host empties it, so a few slots keep every host thread busy, and
// 64 MiB of pinned memory stays small beside a volume.
constexpr int kSlots = 4;
constexpr size_t kPieceBytes = size_t(16) << 20;

// The ring's memory: one block advised for 2 MiB pages, faulted in, then
// registered with the driver (page-locked). Pinning it takes about half the
// time of cudaMallocHost's 4 x 16 MiB (where the kernel gives huge pages the
// driver pins 32 pages rather than 16,384), its release a third, at the same
// copy speed (bench/results/end-to-end.md).
class PinnedBlock {
public:
  // False (nothing held) when the memory cannot be had or pinned.
  bool allocate(size_t bytes) {
    void* p = std::aligned_alloc(kHugePageBytes, bytes); // bytes: a multiple of 2 MiB
    if (!p) return false;
    adviseHugePages(p, bytes);
#if defined(__linux__) && defined(MADV_POPULATE_WRITE)
    madvise(p, bytes, MADV_POPULATE_WRITE); // a hint: the registration faults in what is left
#endif
    if (cudaHostRegister(p, bytes, cudaHostRegisterDefault) != cudaSuccess) {
      cudaGetLastError(); // not sticky
      std::free(p);
      return false;
    }
    base_ = static_cast<uint8_t*>(p);
    return true;
  }
  void release() {
    if (!base_) return;
    cudaHostUnregister(base_);
    std::free(base_);
    base_ = nullptr;
  }
  uint8_t* base() const { return base_; }

private:
  uint8_t* base_ = nullptr;
};
static_assert(kSlots * kPieceBytes % kHugePageBytes == 0, "the ring is whole huge pages");

struct Ring {
  std::mutex mutex;
  PinnedBlock memory;
  uint8_t* slot[kSlots] = {};
  cudaEvent_t arrived[kSlots] = {};

  // Under `mutex`. The ring lives as long as the process (freed by the driver
  // at exit): builds in a long-lived process (ParaView) reuse it. False when
  // the memory cannot be pinned (a locked-memory limit, say): the caller then
  // takes the driver's pageable path rather than failing the build.
  bool allocate() {
    if (!memory.base()) {
      if (!memory.allocate(kSlots * kPieceBytes)) return false;
      for (int i = 0; i < kSlots; ++i) slot[i] = memory.base() + i * kPieceBytes;
    }
    for (int i = 0; i < kSlots; ++i)
      if (!arrived[i]) HDT_CUDA_CHECK(cudaEventCreateWithFlags(&arrived[i], cudaEventDisableTiming));
    return true;
  }
  StagingRing view() const { return StagingRing{kSlots, kPieceBytes, slot, arrived}; }
};

// One ring a device: its events belong to the device they were made on.
Ring& ringOf(int device) {
  static std::mutex mutex;
  static std::map<int, Ring> rings;
  std::lock_guard<std::mutex> lock(mutex);
  return rings[device];
}

Ring& currentRing() {
  int device = 0;
  HDT_CUDA_CHECK(cudaGetDevice(&device));
  return ringOf(device);
}

void directCopy(cudaStream_t stream, void* host, const void* device, size_t bytes, const CopiedPrefix& copied) {
  HDT_CUDA_CHECK(cudaMemcpyAsync(host, device, bytes, cudaMemcpyDeviceToHost, stream));
  HDT_CUDA_CHECK(cudaStreamSynchronize(stream));
  if (copied) copied(bytes);
}

// [begin, end) of the destination, within one piece of the ring.
struct Task {
  size_t begin, end, piece;
};

// The destination cut at its huge page boundaries and at the pieces' ends:
// a thread then faults in whole pages of its own (two threads filling one
// fresh page wait for each other's fault).
std::vector<Task> cutTasks(uintptr_t dst, size_t bytes, size_t pieceBytes) {
  std::vector<Task> tasks;
  tasks.reserve(bytes / kHugePageBytes + bytes / pieceBytes + 2);
  size_t at = 0;
  while (at < bytes) {
    const size_t piece = at / pieceBytes;
    const size_t pageEnd = ((dst + at) / kHugePageBytes + 1) * kHugePageBytes - dst;
    const size_t end = std::min({bytes, (piece + 1) * pieceBytes, pageEnd});
    tasks.push_back(Task{at, end, piece});
    at = end;
  }
  return tasks;
}

// The copy out of the ring: every host thread takes the next task in order,
// waits for its piece's DMA, copies, and the thread finishing a piece hands
// its slot back to the DMA and reports the copied prefix. Tasks are taken in
// order, so a thread waits only for pieces whose tasks are all in progress
// on running threads: no deadlock whatever the number of threads.
class RingCopy {
public:
  RingCopy(const StagingRing& ring, cudaStream_t stream, uint8_t* dst, const uint8_t* src, size_t bytes,
           const CopiedPrefix& copied, int spareThreads)
      : ring_(ring), stream_(stream), dst_(dst), src_(src), bytes_(bytes), copied_(copied), spare_(spareThreads),
        tasks_(cutTasks(reinterpret_cast<uintptr_t>(dst), bytes, ring.pieceBytes)),
        pieces_((bytes + ring.pieceBytes - 1) / ring.pieceBytes), left_(new std::atomic<size_t>[pieces_]),
        queued_(new std::atomic<bool>[pieces_]), done_(pieces_, false) {
    for (size_t k = 0; k < pieces_; ++k) {
      left_[k].store(0, std::memory_order_relaxed);
      queued_[k].store(false, std::memory_order_relaxed);
    }
    for (const Task& t : tasks_) left_[t.piece].fetch_add(1, std::memory_order_relaxed);
  }

  void run() {
    for (size_t k = 0; k < std::min<size_t>(pieces_, size_t(ring_.slots)); ++k) enqueue(k);
    const int lanes = std::max(1, std::min<int>(tbb::this_task_arena::max_concurrency() - spare_, int(tasks_.size())));
    tbb::parallel_for(0, lanes, [&](int) { lane(); }, tbb::static_partitioner());
    if (error_) std::rethrow_exception(error_);
  }

private:
  size_t pieceBytes(size_t k) const { return std::min(ring_.pieceBytes, bytes_ - k * ring_.pieceBytes); }

  void enqueue(size_t k) {
    std::lock_guard<std::mutex> lock(enqueueMutex_); // a DMA and its event, together
    const int i = int(k % size_t(ring_.slots));
    HDT_CUDA_CHECK(cudaMemcpyAsync(ring_.slot[i], src_ + k * ring_.pieceBytes, pieceBytes(k),
                                   cudaMemcpyDeviceToHost, stream_));
    HDT_CUDA_CHECK(cudaEventRecord(ring_.arrived[i], stream_));
    queued_[k].store(true, std::memory_order_release);
  }

  // False when the copy failed elsewhere: this thread stops.
  bool waitForPiece(size_t k) {
    while (!queued_[k].load(std::memory_order_acquire)) {
      if (failed_.load(std::memory_order_relaxed)) return false;
      std::this_thread::yield();
    }
    // Polled, not cudaEventSynchronize: a waiting thread yields its core (to
    // the consumers of the copied prefix, say) instead of spinning in the driver.
    const cudaEvent_t e = ring_.arrived[k % size_t(ring_.slots)];
    cudaError_t status;
    while ((status = cudaEventQuery(e)) == cudaErrorNotReady) {
      if (failed_.load(std::memory_order_relaxed)) return false;
      std::this_thread::yield();
    }
    HDT_CUDA_CHECK(status);
    return true;
  }

  void pieceDone(size_t k) {
    if (k + size_t(ring_.slots) < pieces_) enqueue(k + size_t(ring_.slots)); // its slot is free again
    std::lock_guard<std::mutex> lock(prefixMutex_);
    done_[k] = true;
    const size_t before = prefix_;
    while (prefix_ < pieces_ && done_[prefix_]) ++prefix_;
    if (copied_ && prefix_ != before) copied_(std::min(bytes_, prefix_ * ring_.pieceBytes));
  }

  void lane() {
    try {
      for (size_t t; !failed_.load(std::memory_order_relaxed) && (t = next_.fetch_add(1)) < tasks_.size();) {
        const Task& task = tasks_[t];
        if (!waitForPiece(task.piece)) return;
        const uint8_t* slot = ring_.slot[task.piece % size_t(ring_.slots)];
        std::memcpy(dst_ + task.begin, slot + (task.begin - task.piece * ring_.pieceBytes), task.end - task.begin);
        if (left_[task.piece].fetch_sub(1, std::memory_order_acq_rel) == 1) pieceDone(task.piece);
      }
    } catch (...) {
      std::lock_guard<std::mutex> lock(prefixMutex_);
      if (!error_) error_ = std::current_exception();
      failed_.store(true);
    }
  }

  const StagingRing ring_;
  const cudaStream_t stream_;
  uint8_t* const dst_;
  const uint8_t* const src_;
  const size_t bytes_;
  const CopiedPrefix& copied_;
  const int spare_; // threads left to others
  const std::vector<Task> tasks_;
  const size_t pieces_;
  std::unique_ptr<std::atomic<size_t>[]> left_; // tasks of each piece not yet copied
  std::unique_ptr<std::atomic<bool>[]> queued_; // each piece's DMA enqueued
  std::atomic<size_t> next_{0};
  std::atomic<bool> failed_{false};
  std::exception_ptr error_;
  std::mutex enqueueMutex_, prefixMutex_;
  std::vector<bool> done_; // under prefixMutex_
  size_t prefix_ = 0;      // pieces [0, prefix_) copied
};

} // namespace

void copyHostParallel(void* dstVoid, const void* srcVoid, size_t bytes) {
  auto* dst = static_cast<uint8_t*>(dstVoid);
  const auto* src = static_cast<const uint8_t*>(srcVoid);
  adviseHugePages(dst, bytes);
  const std::vector<Task> tasks = cutTasks(reinterpret_cast<uintptr_t>(dst), bytes, bytes ? bytes : 1);
  tbb::parallel_for(size_t(0), tasks.size(), [&](size_t i) {
    std::memcpy(dst + tasks[i].begin, src + tasks[i].begin, tasks[i].end - tasks[i].begin);
  });
}

void touchHostParallel(void* hostVoid, size_t bytes) {
  auto* host = static_cast<uint8_t*>(hostVoid);
  adviseHugePages(host, bytes);
  const std::vector<Task> tasks = cutTasks(reinterpret_cast<uintptr_t>(host), bytes, bytes ? bytes : 1);
  tbb::parallel_for(size_t(0), tasks.size(),
                    [&](size_t i) { std::memset(host + tasks[i].begin, 0, tasks[i].end - tasks[i].begin); });
}

void reserveCopyStaging() {
  Ring& r = currentRing();
  std::lock_guard<std::mutex> lock(r.mutex);
  r.allocate();
}

void releaseCopyStaging() {
  Ring& r = currentRing();
  std::lock_guard<std::mutex> lock(r.mutex);
  r.memory.release();
  for (int i = 0; i < kSlots; ++i) {
    if (r.arrived[i]) cudaEventDestroy(r.arrived[i]);
    r.slot[i] = nullptr;
    r.arrived[i] = nullptr;
  }
}

void copyThroughRing(const StagingRing& ring, cudaStream_t stream, void* host, const void* device, size_t bytes,
                     const CopiedPrefix& copied, int spareThreads) {
  if (bytes == 0) return;
  auto* dst = static_cast<uint8_t*>(host);
  adviseHugePages(dst, bytes);
  RingCopy copy(ring, stream, dst, static_cast<const uint8_t*>(device), bytes, copied, spareThreads);
  try {
    copy.run();
  } catch (...) {
    cudaStreamSynchronize(stream); // no DMA into the ring after it is handed on
    throw;
  }
}

void copyToHost(cudaStream_t stream, void* host, const void* device, size_t bytes, const CopiedPrefix& copied,
                int spareThreads) {
  if (bytes == 0) return;
  if (bytes < kDirectBytes) return directCopy(stream, host, device, bytes, copied);
  Ring& r = currentRing();
  std::lock_guard<std::mutex> lock(r.mutex);
  if (!r.allocate()) return directCopy(stream, host, device, bytes, copied);
  copyThroughRing(r.view(), stream, host, device, bytes, copied, spareThreads);
}

void copyToDevice(cudaStream_t stream, void* device, const void* host, size_t bytes) {
  if (bytes == 0) return;
  Ring& r = currentRing();
  std::unique_lock<std::mutex> lock(r.mutex);
  if (bytes < kDirectBytes || !r.allocate()) {
    lock.unlock();
    HDT_CUDA_CHECK(cudaMemcpyAsync(device, host, bytes, cudaMemcpyHostToDevice, stream));
    HDT_CUDA_CHECK(cudaStreamSynchronize(stream));
    return;
  }
  auto* dst = static_cast<uint8_t*>(device);
  const auto* src = static_cast<const uint8_t*>(host);
  // Slot k % kSlots is filled (host threads) while the link drains the
  // others; it is refilled once its copy has arrived.
  for (size_t off = 0, k = 0; off < bytes; off += kPieceBytes, ++k) {
    const int i = int(k % kSlots);
    const size_t n = std::min(kPieceBytes, bytes - off);
    if (k >= size_t(kSlots)) HDT_CUDA_CHECK(cudaEventSynchronize(r.arrived[i]));
    copyHostParallel(r.slot[i], src + off, n);
    HDT_CUDA_CHECK(cudaMemcpyAsync(dst + off, r.slot[i], n, cudaMemcpyHostToDevice, stream));
    HDT_CUDA_CHECK(cudaEventRecord(r.arrived[i], stream));
  }
  HDT_CUDA_CHECK(cudaStreamSynchronize(stream));
}

} // namespace cuda
} // namespace hdt
