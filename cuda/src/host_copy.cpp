#include "host_copy.hpp"

#include "check.hpp"

#include "hdt/huge_pages.hpp"

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include <algorithm>
#include <cstdint>
#include <cstring>
#include <map>
#include <mutex>

namespace hdt {
namespace cuda {
namespace {

// Below this the driver's own pageable copy is as fast and needs no ring.
constexpr size_t kDirectBytes = size_t(4) << 20;
// Pieces of the ring: 4 x 16 MiB keeps three DMAs in flight while the host
// copies the fourth, and 64 MiB of pinned memory stays small beside a volume.
constexpr int kSlots = 4;
constexpr size_t kPieceBytes = size_t(16) << 20;
// Each task of the host copy: large enough to amortise scheduling.
constexpr size_t kTaskBytes = size_t(1) << 20;

struct Ring {
  std::mutex mutex;
  uint8_t* slot[kSlots] = {};
  cudaEvent_t arrived[kSlots] = {};

  // Under `mutex`. The ring lives as long as the process (freed by the driver
  // at exit): builds in a long-lived process (ParaView) reuse it. False when
  // the memory cannot be pinned (a locked-memory limit, say): the caller then
  // takes the driver's pageable path rather than failing the build.
  bool allocate() {
    for (int i = 0; i < kSlots; ++i) {
      if (!slot[i] && cudaMallocHost(reinterpret_cast<void**>(&slot[i]), kPieceBytes) != cudaSuccess) {
        slot[i] = nullptr;
        cudaGetLastError(); // not sticky
        return false;
      }
      if (!arrived[i]) HDT_CUDA_CHECK(cudaEventCreateWithFlags(&arrived[i], cudaEventDisableTiming));
    }
    return true;
  }
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

void directCopy(cudaStream_t stream, void* host, const void* device, size_t bytes) {
  HDT_CUDA_CHECK(cudaMemcpyAsync(host, device, bytes, cudaMemcpyDeviceToHost, stream));
  HDT_CUDA_CHECK(cudaStreamSynchronize(stream));
}

} // namespace

void copyHostParallel(void* dstVoid, const void* srcVoid, size_t bytes) {
  auto* dst = static_cast<uint8_t*>(dstVoid);
  const auto* src = static_cast<const uint8_t*>(srcVoid);
  adviseHugePages(dst, bytes);
  tbb::parallel_for(tbb::blocked_range<size_t>(0, (bytes + kTaskBytes - 1) / kTaskBytes),
                    [&](const tbb::blocked_range<size_t>& r) {
                      const size_t begin = r.begin() * kTaskBytes;
                      const size_t end = std::min(bytes, r.end() * kTaskBytes);
                      std::memcpy(dst + begin, src + begin, end - begin);
                    });
}

void reserveCopyStaging() {
  Ring& r = currentRing();
  std::lock_guard<std::mutex> lock(r.mutex);
  r.allocate();
}

void copyToHost(cudaStream_t stream, void* host, const void* device, size_t bytes) {
  if (bytes == 0) return;
  if (bytes < kDirectBytes) return directCopy(stream, host, device, bytes);
  Ring& r = currentRing();
  std::lock_guard<std::mutex> lock(r.mutex);
  if (!r.allocate()) return directCopy(stream, host, device, bytes);
  const size_t pieces = (bytes + kPieceBytes - 1) / kPieceBytes;
  const auto* src = static_cast<const uint8_t*>(device);
  auto* dst = static_cast<uint8_t*>(host);
  adviseHugePages(dst, bytes);
  auto pieceBytes = [&](size_t k) { return std::min(kPieceBytes, bytes - k * kPieceBytes); };
  auto enqueue = [&](size_t k) {
    const int i = int(k % kSlots);
    HDT_CUDA_CHECK(cudaMemcpyAsync(r.slot[i], src + k * kPieceBytes, pieceBytes(k), cudaMemcpyDeviceToHost, stream));
    HDT_CUDA_CHECK(cudaEventRecord(r.arrived[i], stream));
  };
  try {
    for (size_t k = 0; k < std::min<size_t>(pieces, kSlots); ++k) enqueue(k);
    for (size_t k = 0; k < pieces; ++k) {
      const int i = int(k % kSlots);
      HDT_CUDA_CHECK(cudaEventSynchronize(r.arrived[i]));
      copyHostParallel(dst + k * kPieceBytes, r.slot[i], pieceBytes(k));
      if (k + kSlots < pieces) enqueue(k + kSlots); // the slot is free again
    }
  } catch (...) {
    cudaStreamSynchronize(stream); // no DMA into the ring after it is handed on
    throw;
  }
}

} // namespace cuda
} // namespace hdt
