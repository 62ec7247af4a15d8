#include "voxel_counts.hpp"

#include "check.hpp"
#include "device_common.cuh"

#include <algorithm>

namespace hdt {
namespace cuda {
namespace {

constexpr unsigned kCountBlock = 256;

__device__ __forceinline__ uint64_t threadIndex() { return uint64_t(blockIdx.x) * blockDim.x + threadIdx.x; }

// Adds a warp's sum of v to *out (all lanes take part).
__device__ __forceinline__ void warpAdd(unsigned long long v, unsigned long long* out) {
  for (int o = 16; o > 0; o >>= 1) v += __shfl_xor_sync(kFullMask, v, o);
  if (threadIdx.x % 32 == 0 && v) atomicAdd(out, v);
}

__global__ void countFullVoxelsKernel(const ElementWord* words, uint32_t count, uint64_t voxelsPerElement,
                                      unsigned long long* counts) {
  const uint64_t i = threadIndex();
  const bool full = i < count && elementState(words[i]) == ElementState::Full;
  warpAdd(full ? voxelsPerElement : 0ull, counts + 1);
}

// Grid-stride: a thread sums many words before its warp adds once.
__global__ void countLeafVoxelsKernel(const uint32_t* words, uint64_t total, unsigned long long* counts) {
  unsigned long long surface = 0, inside = 0;
  for (uint64_t j = threadIndex(); j < total; j += uint64_t(gridDim.x) * blockDim.x) {
    const uint32_t w = words[j];
    surface += planeCount(w, kSurfacePlane);
    inside += planeCount(w, kInsidePlane);
  }
  warpAdd(surface, counts);
  warpAdd(inside, counts + 1);
}

} // namespace

void countFullVoxels(cudaStream_t s, const ElementWord* words, uint32_t count, uint64_t voxelsPerElement,
                     unsigned long long* counts) {
  if (count == 0) return;
  countFullVoxelsKernel<<<blocksFor(count, kCountBlock), kCountBlock, 0, s>>>(words, count, voxelsPerElement, counts);
  HDT_CUDA_CHECK_LAUNCH("countFullVoxels");
}

void countLeafVoxels(cudaStream_t s, const uint32_t* words, uint64_t total, unsigned long long* counts) {
  if (total == 0) return;
  const uint64_t threads = std::min<uint64_t>(total, uint64_t(kCountBlock) * 4096); // enough blocks to fill the device
  countLeafVoxelsKernel<<<blocksFor(threads, kCountBlock), kCountBlock, 0, s>>>(words, total, counts);
  HDT_CUDA_CHECK_LAUNCH("countLeafVoxels");
}

} // namespace cuda
} // namespace hdt
