#include "device_memory.hpp"

#include "hdt/cuda_build.hpp"

#include <atomic>
#include <mutex>
#include <vector>

namespace hdt {
namespace cuda {
namespace {

// One pool per device for the life of the process. Its release threshold is
// "never": memory freed during a build stays in the pool for the next level
// instead of going back to the driver at every stream synchronisation.
struct PoolRegistry {
  std::mutex mutex;
  std::vector<int> state; // 0 unknown, 1 pool created, -1 pools unsupported
  std::vector<cudaMemPool_t> pools;
};

std::atomic<uint64_t> g_retainedBytes{uint64_t(2) << 30};

PoolRegistry& registry() {
  static PoolRegistry r;
  return r;
}

cudaMemPool_t poolFor(int device) {
  PoolRegistry& r = registry();
  std::lock_guard<std::mutex> lock(r.mutex);
  if (size_t(device) >= r.state.size()) {
    r.state.resize(device + 1, 0);
    r.pools.resize(device + 1, nullptr);
  }
  if (r.state[device] == 0) {
    int supported = 0;
    HDT_CUDA_CHECK(cudaDeviceGetAttribute(&supported, cudaDevAttrMemoryPoolsSupported, device));
    if (!supported) {
      r.state[device] = -1;
    } else {
      cudaMemPoolProps props = {};
      props.allocType = cudaMemAllocationTypePinned;
      props.location.type = cudaMemLocationTypeDevice;
      props.location.id = device;
      cudaMemPool_t pool;
      HDT_CUDA_CHECK(cudaMemPoolCreate(&pool, &props));
      uint64_t threshold = UINT64_MAX;
      HDT_CUDA_CHECK(cudaMemPoolSetAttribute(pool, cudaMemPoolAttrReleaseThreshold, &threshold));
      r.pools[device] = pool;
      r.state[device] = 1;
    }
  }
  return r.pools[device];
}

} // namespace

DeviceMemory::DeviceMemory(int device, cudaStream_t stream, uint64_t budget)
    : device_(device), stream_(stream), pool_(poolFor(device)), budget_(budget) {}

DeviceMemory::~DeviceMemory() {
  // Every buffer is released by now (they are owned by objects that die
  // first); once the stream has run the frees, hand back what the pool holds
  // beyond what the next build will likely want again. Only when it holds
  // more: cudaMemPoolTrimTo(pool, UINT64_MAX) released everything, and warm
  // builds then mapped their leaf words afresh each time
  // (bench/results/gpu-notes.md, the pool trim).
  if (!pool_ || cudaStreamSynchronize(stream_) != cudaSuccess) return;
  uint64_t reserved = 0;
  const uint64_t keep = g_retainedBytes.load();
  if (cudaMemPoolGetAttribute(pool_, cudaMemPoolAttrReservedMemCurrent, &reserved) == cudaSuccess && reserved > keep)
    cudaMemPoolTrimTo(pool_, keep);
}

uint64_t DeviceMemory::obtainable(int device) {
  size_t freeBytes = 0, totalBytes = 0;
  HDT_CUDA_CHECK(cudaMemGetInfo(&freeBytes, &totalBytes));
  uint64_t idle = 0;
  if (cudaMemPool_t pool = poolFor(device)) {
    uint64_t reserved = 0, used = 0;
    HDT_CUDA_CHECK(cudaMemPoolGetAttribute(pool, cudaMemPoolAttrReservedMemCurrent, &reserved));
    HDT_CUDA_CHECK(cudaMemPoolGetAttribute(pool, cudaMemPoolAttrUsedMemCurrent, &used));
    idle = reserved > used ? reserved - used : 0;
  }
  return uint64_t(freeBytes) + idle;
}

void* DeviceMemory::allocate(size_t bytes) {
  if (bytes == 0) return nullptr;
  if (live_ + bytes > budget_) throw DeviceMemoryExhausted(live_ + bytes, budget_);
  void* p = nullptr;
  const cudaError_t e = pool_ ? cudaMallocFromPoolAsync(&p, bytes, pool_, stream_) : cudaMalloc(&p, bytes);
  if (e == cudaErrorMemoryAllocation) {
    cudaGetLastError(); // not sticky
    throw DeviceMemoryExhausted(live_ + bytes, budget_);
  }
  HDT_CUDA_CHECK(e);
  live_ += bytes;
  if (live_ > peak_) peak_ = live_;
  return p;
}

void DeviceMemory::release(void* p, size_t bytes) noexcept {
  if (!p) return;
  // A failing free can only follow an earlier, reported fault; nothing to add.
  if (pool_) {
    cudaFreeAsync(p, stream_);
  } else {
    cudaFree(p);
  }
  live_ -= bytes;
}

void DeviceMemory::reserve(size_t bytes) {
  if (live_ + bytes > budget_) throw DeviceMemoryExhausted(live_ + bytes, budget_);
  live_ += bytes;
  if (live_ > peak_) peak_ = live_;
}

bool DeviceMemory::releaseUnused() {
  // Any failure here only means nothing was given back (a fault shows at the
  // caller's next checked call).
  uint64_t reserved = 0, used = 0;
  if (!pool_ || cudaStreamSynchronize(stream_) != cudaSuccess ||
      cudaMemPoolGetAttribute(pool_, cudaMemPoolAttrReservedMemCurrent, &reserved) != cudaSuccess ||
      cudaMemPoolGetAttribute(pool_, cudaMemPoolAttrUsedMemCurrent, &used) != cudaSuccess || reserved <= used)
    return false;
  return cudaMemPoolTrimTo(pool_, 0) == cudaSuccess;
}

} // namespace cuda

void setCudaPoolRetention(uint64_t bytes) { cuda::g_retainedBytes.store(bytes); }

namespace cuda {
void DeviceMemory::prefill(int device, cudaStream_t stream, uint64_t bytes) {
  cudaMemPool_t pool = poolFor(device);
  if (!pool || bytes == 0) return;
  uint64_t reserved = 0;
  HDT_CUDA_CHECK(cudaMemPoolGetAttribute(pool, cudaMemPoolAttrReservedMemCurrent, &reserved));
  if (reserved >= bytes) return;
  void* p = nullptr;
  if (cudaMallocFromPoolAsync(&p, bytes - reserved, pool, stream) != cudaSuccess) {
    cudaGetLastError(); // no room: the build grows the pool itself
    return;
  }
  HDT_CUDA_CHECK(cudaFreeAsync(p, stream)); // back to the pool, which keeps it (release threshold: never)
  HDT_CUDA_CHECK(cudaStreamSynchronize(stream));
}
void DeviceMemory::releasePool(int device) {
  PoolRegistry& r = registry();
  std::lock_guard<std::mutex> lock(r.mutex);
  if (size_t(device) >= r.state.size() || r.state[device] != 1) return;
  cudaMemPoolDestroy(r.pools[device]);
  r.pools[device] = nullptr;
  r.state[device] = 0;
}
} // namespace cuda

} // namespace hdt
