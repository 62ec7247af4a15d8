// Device-side helpers shared by the phase kernels (include from .cu only).
#pragma once

#include "check.hpp"
#include "device_memory.hpp"
#include "phases.hpp"

#include "hdt/build_steps.hpp" // unpackCoord
#include "hdt/types.hpp"

#include <cub/device/device_radix_sort.cuh>

#include <cstdint>
#include <utility>

namespace hdt {
namespace cuda {

constexpr unsigned kFullMask = 0xFFFFFFFFu;

inline unsigned blocksFor(uint64_t threads, unsigned blockSize) {
  return unsigned((threads + blockSize - 1) / blockSize);
}

// Bits needed to hold every value in [0, maxValue].
inline int bitsFor(uint64_t maxValue) {
  int b = 0;
  while (b < 64 && (maxValue >> b) != 0) ++b;
  return b;
}

// Runs a CUB device algorithm the usual two-step way (size query, then run)
// with its temporary storage from the build's pool.
template <class Algorithm>
void runCub(DeviceMemory& mem, Algorithm&& algorithm) {
  size_t bytes = 0;
  HDT_CUDA_CHECK(algorithm(static_cast<void*>(nullptr), bytes));
  DeviceBuffer<uint8_t> temp(mem, bytes > 16 ? bytes : 16);
  HDT_CUDA_CHECK(algorithm(static_cast<void*>(temp.data()), bytes));
}

// Stable LSD radix sort of (key, value) pairs on the low `endBit` key bits.
// Stability is what the canonical order rests on: equal keys keep their
// input order (the triangle order).
template <class K, class V>
void sortPairs(DeviceMemory& mem, DeviceBuffer<K>& keys, DeviceBuffer<V>& values, uint32_t n, int endBit) {
  if (n < 2 || endBit == 0) return;
  DeviceBuffer<K> keysAlt(mem, n);
  DeviceBuffer<V> valuesAlt(mem, n);
  cub::DoubleBuffer<K> k(keys.data(), keysAlt.data());
  cub::DoubleBuffer<V> v(values.data(), valuesAlt.data());
  runCub(mem, [&](void* temp, size_t& bytes) {
    return cub::DeviceRadixSort::SortPairs(temp, bytes, k, v, n, 0, endBit, mem.stream());
  });
  if (k.selector != 0) std::swap(keys, keysAlt);
  if (v.selector != 0) std::swap(values, valuesAlt);
}

// ---- what the leaf kernels (T3, classification) read ------------------------------
struct LeafArgs {
  const LatticeTriangle* tris;
  const uint64_t* leafCoord;
  const uint32_t* pairTri;
  const LeafTask* tasks;
  const uint32_t* taskCount;
  int64_t resolution; // voxels an axis
};

inline LeafArgs leafArgs(const DeviceMesh& mesh, const GridSpec& grid, const Leaves& leaves) {
  return LeafArgs{mesh.triangles,       leaves.coord.data(),          leaves.triangle.data(),
                  leaves.tasks.data(),  leaves.taskCount.data(),      grid.resolution};
}

// A span [first, last] of voxels at or after `base`, within 65536 of it, as
// two 16-bit offsets; every empty span (first > last) as the one value 1.
__host__ __device__ __forceinline__ uint32_t packSpan(int64_t first, int64_t last, int64_t base) {
  return first > last ? 1u : uint32_t(first - base) | (uint32_t(last - base) << 16);
}
// The span clamped to [lo, hi]; empty when first > last.
__device__ __forceinline__ void unpackSpan(uint32_t packed, int32_t base, int32_t lo, int32_t hi, int32_t& first,
                                           int32_t& last) {
  first = max(lo, base + int32_t(packed & 0xFFFFu));
  last = min(hi, base + int32_t(packed >> 16));
}

// First voxel of the leaf at packed leaf coordinate c.
__device__ __forceinline__ void leafOrigin(uint64_t c, int L, int64_t (&v0)[3]) {
  for (int a = 0; a < 3; ++a) v0[a] = int64_t(unpackCoord(c, a)) * L;
}

// ---- warp-cooperative work over the (leaf, triangle) pairs of one leaf -----------
//
// Each pair of a leaf brings a variable number of independent items (slices
// of rows for T3, lines of rays for classification). The warp that owns the
// leaf takes its pairs 32 at a time: every lane counts its pair's items, a
// warp scan lays the counts end to end, and the lanes then take the items 32
// at a time, so a triangle that covers the whole leaf is shared by all 32
// lanes instead of serialising one of them.
//
// Per round of 32 items, each lane whose run of items meets the round marks
// where its run starts in it (one bit, OR-reduced over the warp) and leaves
// its lane and run start in the warp's slots; an item's owner is then the
// last mark at or before it: one reduction, one count-leading-zeros and a
// slot read, instead of a five-step shuffle search (ncu: that search was a
// sixth of T3's instructions).
struct WarpSlots {
  int32_t start[32]; // run start (item number) of the lane that marked slot i
  uint8_t lane[32];  // and that lane
};

template <class Count, class Item>
__device__ __forceinline__ void warpForEachPairItem(uint32_t p0, uint32_t p1, WarpSlots& slots, Count count,
                                                    Item item) {
  const int lane = threadIdx.x & 31;
  const uint32_t upTo = fullRowMask(lane + 1); // bits 0..lane
  for (uint32_t base = p0; base < p1; base += 32) {
    const int c = base + lane < p1 ? count(base + lane) : 0;
    int incl = c;
#pragma unroll
    for (int o = 1; o < 32; o <<= 1) {
      const int v = __shfl_up_sync(kFullMask, incl, o);
      if (lane >= o) incl += v;
    }
    const int total = __shfl_sync(kFullMask, incl, 31);
    const int start = incl - c;
    for (int t0 = 0; t0 < total; t0 += 32) {
      const bool marks = c > 0 && start < t0 + 32 && incl > t0;
      const int at = max(start, t0) - t0;
      __syncwarp(); // the previous round has read the slots
      if (marks) {
        slots.start[at] = start;
        slots.lane[at] = uint8_t(lane);
      }
      const uint32_t m = __reduce_or_sync(kFullMask, marks ? 1u << at : 0u);
      __syncwarp();
      const int t = t0 + lane;
      if (t < total) {
        const int q = 31 - __clz(int(m & upTo)); // the last mark at or before this item
        item(base + slots.lane[q], t - slots.start[q]);
      }
    }
  }
}

} // namespace cuda
} // namespace hdt
