// The winding-number leaf pass on the device (winding_device.hpp), the
// host pass of core/src/winding.cpp (classifyLeavesByCrossings) step by step:
//
//   crossings  each leaf's candidates (the tree's triangles whose node
//              boxes meet the leaf's closed box) listed, one thread per leaf;
//              then one block per leaf, one thread per (candidate, ray line):
//              the crossings with the leaf's +x rays (the parity pass's exact
//              steps), signed by the normal's x component: a row total, a
//              row hit count and a per-voxel delta at the last voxel centre
//              before the crossing (all integer sums: order cannot show);
//   lines      the leaves sorted by line (z, y, then x descending, CUB radix
//              sort), one thread per (line, row): the exclusive suffix sum of
//              the row totals along the line is the count at the row's exit
//              (between the leaves of a line lie only uniform elements,
//              which hold no triangle);
//   counts     one thread per row: N at each voxel = exit + suffix of the
//              deltas, in place as int16; a leaf whose row hit counts or N do
//              not fit 16 bits is marked for the host;
//   uniform    classifyUniform's verdict per element (also the children of
//              split elements), its boxes breadth first, one thread per box;
//   fresh      the leaves refinement creates: N by one ray walk per row,
//              then the same decision.
//   decide     the leaves' boxes breadth first (windingDecideBoxes' steps,
//              winding_leaf.hpp), one thread per box and level, in place.
#include "winding_device.hpp"

#include "check.hpp"
#include "device_memory.hpp"
#include "host_copy.hpp"

#include "hdt/build_steps.hpp"
#include "hdt/geometry.hpp"
#include "hdt/volume.hpp"
#include "hdt/winding_far.hpp"

#include <cub/device/device_radix_sort.cuh>
#include <cub/device/device_scan.cuh>
#include <cub/device/device_select.cuh>
#include <tbb/parallel_for.h>

#include <algorithm>
#include <climits>
#include <chrono>
#include <exception>
#include <cstdio>
#include <cstdlib>
#include <memory>
#include <new>
#include <optional>
#include <thread>
#include <utility>

namespace hdt {
namespace cuda {
namespace {

constexpr unsigned kBlock = 128;
constexpr unsigned kBoxBlock = 64; // the box queues' kernels (double-heavy threads)
// Blocks of kBoxBlock threads an SM that the box kernels are compiled for:
// at most 80 registers a thread (a few hundred bytes spilled) instead of 92
// to 144, and the occupancy won more than the spills cost
// (bench/results/winding.md, session 19).
constexpr int kBoxBlocksPerSM = 12;

unsigned blocks(uint64_t n) { return unsigned((n + kBlock - 1) / kBlock); }

// The bytes the pass holds, counted against the build's DeviceMemory (its
// budget and its peak: Statistics::peakDeviceBytes) as reservations, and
// the pass's own live and peak bytes (the driver's log, the tests).
//
// Why reservations beside cudaMalloc rather than the build's pool
// (DeviceMemory::allocate): pool allocations are ordered on the session's
// stream, which is non-blocking, while the pass launches and copies on the
// legacy default stream; a cudaFreeAsync at scope exit on the session's
// stream would not wait for the pass's kernels. cudaMalloc and cudaFree
// synchronise with every stream, so an Array may go at any scope exit. The
// pool keeps the build's freed memory (release threshold: never), which
// cudaMalloc cannot use but the budget counted as obtainable: when
// cudaMalloc finds no room, the pool's unused memory goes back to the driver
// (DeviceMemory::releaseUnused) and cudaMalloc is tried once more.
class PassMemory {
public:
  explicit PassMemory(DeviceMemory* build) : build_(build) {}
  // Throws bad_alloc (the pass's fallback: the host pass) beyond the budget.
  void reserve(size_t bytes) {
    if (build_) {
      try {
        build_->reserve(bytes);
      } catch (const DeviceMemoryExhausted&) {
        throw std::bad_alloc();
      }
    }
    live_ += bytes;
    peak_ = std::max(peak_, live_);
  }
  void unreserve(size_t bytes) noexcept {
    if (build_) build_->unreserve(bytes);
    live_ -= bytes;
  }
  // cudaMalloc found no room: the build's pool gives back what it holds unused.
  bool releaseUnused() { return build_ && build_->releaseUnused(); }
  // Bytes the budget leaves for further reservations.
  uint64_t room() const {
    if (!build_) return UINT64_MAX;
    return build_->budget() > build_->live() ? build_->budget() - build_->live() : 0;
  }
  uint64_t peak() const { return peak_; }

private:
  DeviceMemory* build_; // null: counted here only (windingCountsOnDevice)
  uint64_t live_ = 0, peak_ = 0;
};

// The PassMemory of the pass call under way on this thread (PassMemoryScope,
// set by each entry point): every Array made within the call, in whichever
// helper, counts against it without the memory being passed through each.
thread_local PassMemory* t_passMemory = nullptr;

class PassMemoryScope {
public:
  explicit PassMemoryScope(PassMemory& m) : previous_(std::exchange(t_passMemory, &m)) {}
  ~PassMemoryScope() { t_passMemory = previous_; }
  PassMemoryScope(const PassMemoryScope&) = delete;
  PassMemoryScope& operator=(const PassMemoryScope&) = delete;

private:
  PassMemory* previous_;
};

// A device array freed on scope exit, its bytes reserved in the call's
// PassMemory; no room (budget or device) throws bad_alloc (the pass then
// returns false and the host pass runs).
template <class T>
class Array {
public:
  explicit Array(size_t n) : n_(n) {
    if (n == 0) return;
    const size_t bytes = n * sizeof(T);
    if (t_passMemory) t_passMemory->reserve(bytes); // may throw bad_alloc
    memory_ = t_passMemory;
    cudaError_t e = cudaMalloc(&p_, bytes);
    if (e == cudaErrorMemoryAllocation && memory_ && memory_->releaseUnused()) {
      (void)cudaGetLastError();
      e = cudaMalloc(&p_, bytes);
    }
    if (e != cudaSuccess) {
      p_ = nullptr;
      if (memory_) memory_->unreserve(bytes);
      memory_ = nullptr;
    }
    if (e == cudaErrorMemoryAllocation) {
      (void)cudaGetLastError(); // not sticky: clear it
      throw std::bad_alloc();
    }
    HDT_CUDA_CHECK(e);
  }
  ~Array() {
    if (p_) cudaFree(p_);
    if (memory_) memory_->unreserve(n_ * sizeof(T));
  }
  Array(const Array&) = delete;
  Array& operator=(const Array&) = delete;
  T* data() const { return p_; }
  size_t size() const { return n_; }
  void zero() const {
    if (n_) HDT_CUDA_CHECK(cudaMemset(p_, 0, n_ * sizeof(T)));
  }
  void upload(const T* host) const {
    if (n_) HDT_CUDA_CHECK(cudaMemcpy(p_, host, n_ * sizeof(T), cudaMemcpyHostToDevice));
  }
  void download(T* host) const {
    if (n_) HDT_CUDA_CHECK(cudaMemcpy(host, p_, n_ * sizeof(T), cudaMemcpyDeviceToHost));
  }

private:
  T* p_ = nullptr;
  size_t n_ = 0;
  PassMemory* memory_ = nullptr; // where its bytes are reserved
};

// The tree's arrays on the device, uploaded once per pass.
struct DeviceTree {
  Array<WindingNode> nodes;
  Array<WindingTriangle> triangles;
  Array<WindingEdge> edges;
  Array<WindingEdgeGroup> groups;
  Array<LatticeTriangle> lattice;
  explicit DeviceTree(const WindingTree& t)
      : nodes(t.nodes.size()), triangles(t.triangles.size()), edges(t.edges.size()), groups(t.edgeGroups.size()),
        lattice(t.lattice.size()) {
    nodes.upload(t.nodes.data());
    triangles.upload(t.triangles.data());
    edges.upload(t.edges.data());
    groups.upload(t.edgeGroups.data());
    lattice.upload(t.lattice.data());
  }
  WindingTreeView view() const {
    return {nodes.data(), triangles.data(), uint32_t(triangles.size()), edges.data(), groups.data(),
            uint32_t(groups.size()), lattice.data(), uint32_t(edges.size())};
  }
};

struct LeafOrigin {
  int o[3];
};

// ---- crossings ------------------------------------------------------------------
//
// Spread over (leaf, candidate triangle, ray line) items: each leaf's
// candidates (windingForEachLeafCandidate, the host's tree walk) are counted
// and then listed at their exclusive sum, one thread a leaf; a block a leaf
// then takes its candidates' lines, one item a thread
// (windingForEachPairLineCrossing, the host's crossings line by line), and
// sums the signed crossings in shared memory with integer atomics (exact and
// order-free: the same sums as one thread adding them in walk order). One
// thread a leaf, walking and crossing serially, left most lanes idle behind
// the leaves with the most crossings.
// Two passes over the same list: the first sums only the row totals (what
// the lines step needs); the second, after the lines step, sums the voxel
// deltas and row hits again and turns them into the counts N in shared
// memory (leafCountsKernel). So the 2 bytes a voxel of deltas are never
// stored and read back (4.4 GB each way at 8192^3 with the hits), and a leaf
// of a held block stores only its inside bits. Leaves larger than
// kSharedLeaf (32: the deltas would not fit shared memory) keep the serial
// kernel and countsKernel.
constexpr int kSharedLeaf = 16;
constexpr unsigned kCrossingBlock = 128;

// Whether candidate i has rays in the leaf at all (pairRayRange): the list
// keeps only those.
__device__ bool candidateHasRays(const WindingTreeView& t, uint32_t i, const LeafOrigin& o, int L) {
  const int64_t v0[3] = {o.o[0], o.o[1], o.o[2]};
  int64_t u0, u1, w0, w1;
  return pairRayRange(t.lattice[i], 0, v0, L, u0, u1, w0, w1);
}

// counts[leaf]: the leaf's candidates with rays in it.
__global__ void candidateCountKernel(WindingTreeView t, const LeafOrigin* origins, uint32_t leafCount, int L,
                                     uint64_t* counts) {
  const uint32_t leaf = blockIdx.x * blockDim.x + threadIdx.x;
  if (leaf >= leafCount) return;
  const LeafOrigin o = origins[leaf];
  uint64_t n = 0;
  windingForEachLeafCandidate(t, o.o, L, [&](uint32_t i) { n += candidateHasRays(t, i, o, L); });
  counts[leaf] = n;
}

// The same candidates listed from offsets[leaf] on.
__global__ void candidateListKernel(WindingTreeView t, const LeafOrigin* origins, uint32_t leafCount, int L,
                                    const uint64_t* offsets, uint32_t* candidates) {
  const uint32_t leaf = blockIdx.x * blockDim.x + threadIdx.x;
  if (leaf >= leafCount) return;
  const LeafOrigin o = origins[leaf];
  uint32_t* out = candidates + offsets[leaf];
  windingForEachLeafCandidate(t, o.o, L, [&](uint32_t i) {
    if (candidateHasRays(t, i, o, L)) *out++ = i;
  });
}

// fn(row, before, sign) for every crossing of the leaf (block blockIdx.x),
// its listed candidates' lines spread over the block's threads, one
// (candidate, line) item a thread.
template <class Fn>
__device__ void forEachBlockLeafCrossing(const WindingTreeView& t, const LeafOrigin* origins, int L,
                                         const uint64_t* offsets, const uint32_t* candidates, Fn&& fn) {
  const uint32_t leaf = blockIdx.x;
  const uint64_t first = offsets[leaf], items = (offsets[leaf + 1] - first) * uint64_t(L);
  const LeafOrigin o = origins[leaf];
  for (uint64_t k = threadIdx.x; k < items; k += blockDim.x) {
    const uint32_t i = candidates[first + k / uint64_t(L)];
    const int sign = windingCrossingSign(t.lattice[i]);
    windingForEachPairLineCrossing(t, i, o.o, L, int(k % uint64_t(L)),
                                   [&](int row, int before) { fn(row, before, sign); });
  }
}

// The first pass (L <= kSharedLeaf): the leaf's row totals, written whole
// (the array needs no zeroing).
__global__ void __launch_bounds__(kCrossingBlock)
    leafRowTotalsKernel(WindingTreeView t, const LeafOrigin* origins, int L, const uint64_t* offsets,
                        const uint32_t* candidates, int32_t* rowTotals) {
  __shared__ int32_t total[kSharedLeaf * kSharedLeaf];
  const uint32_t rows = uint32_t(L * L);
  for (uint32_t k = threadIdx.x; k < rows; k += blockDim.x) total[k] = 0;
  __syncthreads();
  forEachBlockLeafCrossing(t, origins, L, offsets, candidates,
                           [&](int row, int, int sign) { atomicAdd(total + row, sign); });
  __syncthreads();
  const size_t rowBase = size_t(blockIdx.x) * rows;
  for (uint32_t k = threadIdx.x; k < rows; k += blockDim.x) rowTotals[rowBase + k] = total[k];
}

// L > kSharedLeaf: one thread a leaf, serially (the arrays zeroed before).
__global__ void signedCrossingsKernel(WindingTreeView t, const LeafOrigin* origins, uint32_t leafCount, int L,
                                      int32_t* rowTotals, int32_t* rowHits, int16_t* deltas) {
  const uint32_t leaf = blockIdx.x * blockDim.x + threadIdx.x;
  if (leaf >= leafCount) return;
  const size_t rows = size_t(L) * size_t(L);
  int32_t* total = rowTotals + leaf * rows;
  int32_t* hits = rowHits + leaf * rows;
  int16_t* delta = deltas + leaf * rows * size_t(L);
  const LeafOrigin o = origins[leaf];
  windingForEachLeafCrossing(t, o.o, L, [&](int row, int before, int sign) {
    total[row] += sign;
    hits[row] += 1;
    if (before > 0) delta[size_t(row) * size_t(L) + size_t(before - 1)] += int16_t(sign);
  });
}

// ---- lines ----------------------------------------------------------------------

__global__ void lineKeysKernel(const LeafOrigin* origins, uint32_t leafCount, uint64_t* keys, uint32_t* order) {
  const uint32_t leaf = blockIdx.x * blockDim.x + threadIdx.x;
  if (leaf >= leafCount) return;
  const LeafOrigin o = origins[leaf];
  keys[leaf] = (uint64_t(uint32_t(o.o[2])) << 42) | (uint64_t(uint32_t(o.o[1])) << 21) |
               uint64_t(0x1FFFFFu - uint32_t(o.o[0]));
  order[leaf] = leaf;
}

// 1 where a sorted leaf starts a line (a new y, z).
__global__ void lineStartKernel(const uint64_t* sortedKeys, uint32_t leafCount, uint8_t* start) {
  const uint32_t i = blockIdx.x * blockDim.x + threadIdx.x;
  if (i >= leafCount) return;
  start[i] = (i == 0 || (sortedKeys[i] >> 21) != (sortedKeys[i - 1] >> 21)) ? 1 : 0;
}

__global__ void indexKernel(uint32_t n, uint32_t* index) {
  const uint32_t i = blockIdx.x * blockDim.x + threadIdx.x;
  if (i < n) index[i] = i;
}

// One thread per (line, row): totals become the counts beyond each leaf.
// The line's leaves go kSuffixChunk at a time, every load of a chunk issued
// before its stores, so a thread waits on memory once a chunk rather than
// twice a leaf (the walk is otherwise one long chain of dependent loads).
constexpr uint32_t kSuffixChunk = 8;

__global__ void lineSuffixKernel(const uint32_t* __restrict__ lineStarts, uint32_t lines, uint32_t leafCount,
                                 const uint32_t* __restrict__ order, uint32_t rows, int32_t* __restrict__ rowTotals) {
  const uint64_t k = uint64_t(blockIdx.x) * blockDim.x + threadIdx.x;
  if (k >= uint64_t(lines) * rows) return;
  const uint32_t line = uint32_t(k / rows), r = uint32_t(k % rows);
  const uint32_t end = line + 1 < lines ? lineStarts[line + 1] : leafCount;
  int32_t running = 0;
  for (uint32_t i = lineStarts[line]; i < end; i += kSuffixChunk) {
    const uint32_t n = min(kSuffixChunk, end - i);
    size_t at[kSuffixChunk];
    int32_t own[kSuffixChunk];
#pragma unroll
    for (uint32_t j = 0; j < kSuffixChunk; ++j)
      if (j < n) at[j] = size_t(order[i + j]) * rows + r;
#pragma unroll
    for (uint32_t j = 0; j < kSuffixChunk; ++j)
      if (j < n) own[j] = rowTotals[at[j]];
#pragma unroll
    for (uint32_t j = 0; j < kSuffixChunk; ++j) {
      if (j < n) {
        rowTotals[at[j]] = running;
        running += own[j];
      }
    }
  }
}

// ---- counts and decisions -----------------------------------------------------------

// A leaf's threshold when its block holds (blocks below), else this.
constexpr int kNoThreshold = INT_MIN;

// Where a leaf's counts (L^3 of them) start, in leaves: its slot among the
// leaves that keep counts (keepCounts; slots null: every leaf keeps them, in
// leaf order).
__host__ __device__ inline uint64_t countsSlot(const uint32_t* slots, uint32_t leaf) {
  return slots ? slots[leaf] : leaf;
}

// One thread per (leaf, row); fits[leaf] starts at 1 and any row that does
// not fit writes 0 (the same value whatever the order).
// With leafT (L a multiple of 16: a row is whole 16-voxel words), a leaf of
// a held block keeps no counts: its rows give the words' inside bits
// (N >= T, before the surface mask) in insideBits, one 16-bit group a word.
__global__ void countsKernel(uint32_t leafCount, int L, const int32_t* exits, const int32_t* rowHits, int16_t* counts,
                             uint8_t* fits, const int* leafT, uint16_t* insideBits) {
  const uint64_t k = uint64_t(blockIdx.x) * blockDim.x + threadIdx.x;
  const uint64_t rows = uint64_t(L) * uint64_t(L);
  if (k >= uint64_t(leafCount) * rows) return; // k = leaf * rows + row
  bool fit = rowHits[k] <= INT16_MAX; // the deltas could not wrap
  int16_t* c = counts + k * uint64_t(L);
  const int32_t exit = exits[k];
  // The row in registers, loaded and stored 16 bytes at a time (a row is L
  // int16: 16, 32 or 64 bytes, aligned): one thread a row touched the
  // array 2 bytes at a time, 32 rows apart across a warp.
  constexpr int kMaxRow = 32;
  alignas(16) int16_t row[kMaxRow];
  const bool wide = L <= kMaxRow && L % 8 == 0;
  int16_t* r = wide ? row : c;
  if (wide)
    for (int i = 0; i < L / 8; ++i) reinterpret_cast<int4*>(row)[i] = reinterpret_cast<const int4*>(c)[i];
  int32_t suffix = 0;
  for (int x = L - 1; x >= 0 && fit; --x) {
    suffix += r[x];
    const int32_t n = exit + suffix;
    fit = n >= INT16_MIN && n <= INT16_MAX;
    r[x] = int16_t(n);
  }
  const int T = leafT ? leafT[k / rows] : kNoThreshold;
  if (T != kNoThreshold && wide) {
    for (int g = 0; g < L / kVoxelsPerWord; ++g) {
      uint32_t bits = 0;
      for (int x = 0; x < kVoxelsPerWord; ++x) bits |= uint32_t(int(row[g * kVoxelsPerWord + x]) >= T) << x;
      insideBits[k * uint64_t(L / kVoxelsPerWord) + uint64_t(g)] = uint16_t(bits);
    }
  } else if (wide) {
    for (int i = 0; i < L / 8; ++i) reinterpret_cast<int4*>(c)[i] = reinterpret_cast<const int4*>(row)[i];
  }
  if (!fit) fits[k / rows] = 0;
}

// The second pass (L <= kSharedLeaf), after the lines step turned the row
// totals into exits: the leaf's crossings summed again, into row hits and
// voxel deltas in shared memory, then each row's counts N = exit + the deltas
// from the row's far end, as countsKernel computes them from the stored int16
// deltas (the same values wherever the row fits: |delta| <= hits <=
// INT16_MAX, so no int16 wrapped). A leaf whose rows all fit writes its
// counts whole, or with leafT, a leaf of a held block only its inside bits
// (N >= T, one 16-bit group a word, L a multiple of kVoxelsPerWord); any other
// leaf gets fits 0 (the host's leaf: nothing of it is read on the device).
// A row's deltas lie kSharedLeaf + 1 apart in shared memory: one thread a row
// then reads 32 rows from 32 banks.
__global__ void __launch_bounds__(kCrossingBlock)
    leafCountsKernel(WindingTreeView t, const LeafOrigin* origins, int L, const uint64_t* offsets,
                     const uint32_t* candidates, const int32_t* exits, int16_t* counts, const uint32_t* slots,
                     uint8_t* fits, const int* leafT, uint16_t* insideBits) {
  constexpr int kStride = kSharedLeaf + 1;
  __shared__ int32_t hits[kSharedLeaf * kSharedLeaf];
  __shared__ int32_t N[kSharedLeaf * kSharedLeaf * kStride];
  __shared__ int allFit;
  const uint32_t leaf = blockIdx.x, uL = uint32_t(L);
  const uint32_t rows = uL * uL, voxels = rows * uL;
  for (uint32_t k = threadIdx.x; k < rows; k += blockDim.x) hits[k] = 0;
  for (uint32_t k = threadIdx.x; k < rows * kStride; k += blockDim.x) N[k] = 0;
  if (threadIdx.x == 0) allFit = 1;
  __syncthreads();
  forEachBlockLeafCrossing(t, origins, L, offsets, candidates, [&](int row, int before, int sign) {
    atomicAdd(hits + row, 1);
    if (before > 0) atomicAdd(N + row * kStride + before - 1, sign);
  });
  __syncthreads();
  const size_t rowBase = size_t(leaf) * rows;
  for (uint32_t k = threadIdx.x; k < rows; k += blockDim.x) {
    bool fit = hits[k] <= INT16_MAX; // the int16 deltas could not wrap
    int32_t n = exits[rowBase + k];
    for (int x = L - 1; x >= 0; --x) {
      n += N[k * kStride + uint32_t(x)];
      fit = fit && n >= INT16_MIN && n <= INT16_MAX;
      N[k * kStride + uint32_t(x)] = n;
    }
    if (!fit) allFit = 0;
  }
  __syncthreads();
  if (!allFit) {
    if (threadIdx.x == 0) fits[leaf] = 0;
    return;
  }
  auto at = [&](uint32_t v) { return N[(v / uL) * kStride + v % uL]; }; // voxel v = x + L row
  const int T = leafT ? leafT[leaf] : kNoThreshold;
  if (T != kNoThreshold) {
    const uint32_t words = voxels / kVoxelsPerWord;
    for (uint32_t g = threadIdx.x; g < words; g += blockDim.x) {
      uint32_t bits = 0;
      for (uint32_t x = 0; x < kVoxelsPerWord; ++x) bits |= uint32_t(at(g * kVoxelsPerWord + x) >= T) << x;
      insideBits[size_t(leaf) * words + g] = uint16_t(bits);
    }
    return;
  }
  // Two counts a 32-bit store (voxels is even; the leaf's counts start 4-byte
  // aligned).
  uint32_t* pairs = reinterpret_cast<uint32_t*>(counts + countsSlot(slots, leaf) * voxels);
  for (uint32_t k = threadIdx.x; k < voxels / 2; k += blockDim.x)
    pairs[k] = uint32_t(uint16_t(int16_t(at(2 * k)))) | (uint32_t(uint16_t(int16_t(at(2 * k + 1)))) << 16);
}

// The inside plane of every leaf that fits cleared (leafBoxesKernel sets it).
__global__ void clearInsideKernel(uint64_t wordCount, int L, const uint8_t* fits, uint32_t* words) {
  const uint64_t i = uint64_t(blockIdx.x) * blockDim.x + threadIdx.x;
  if (i >= wordCount || !fits[i / leafWordCount(L)]) return;
  words[i] &= kSurfacePlaneBits;
}

// classifyUniform (core/src/winding.cpp) for one element: bit 0 inside, bit 1
// split (voxel centres on both sides of w = 1/2).
__global__ void uniformKernel(WindingTreeView t, const WindingUniformJob* jobs, uint32_t count, uint8_t* verdicts) {
  const uint32_t i = blockIdx.x * blockDim.x + threadIdx.x;
  if (i >= count) return;
  const WindingUniformJob job = jobs[i];
  VoxelBox box;
  for (int a = 0; a < 3; ++a) {
    box.lo[a] = job.origin[a];
    box.hi[a] = job.origin[a] + job.edge;
  }
  bool seen[2] = {false, false};
  windingDecideBox(
      t, box, [](const VoxelBox&) { return false; }, [](const VoxelBox&) { return false; },
      [&](const VoxelBox&, bool inside) { seen[inside] = true; }, [&] { return seen[0] && seen[1]; });
  verdicts[i] = (seen[0] && seen[1]) ? 2 : seen[1] ? 1 : 0;
}

// N at every voxel centre of a leaf without surface voxels (refinement's
// fresh leaves): one ray walk per row. No triangle meets the closed box of
// any of the leaf's voxels, so none lies between two voxel centres of a row
// and the row's +x rays (the same perturbed line) cross the same triangles
// ahead: N is the row's first voxel's count at every voxel of the row.
__global__ void freshCountsKernel(WindingTreeView t, const LeafOrigin* origins, uint32_t leafCount, int L,
                                  int16_t* counts, uint8_t* fits) {
  const uint64_t k = uint64_t(blockIdx.x) * blockDim.x + threadIdx.x;
  const uint64_t rows = uint64_t(L) * uint64_t(L);
  if (k >= uint64_t(leafCount) * rows) return; // k = leaf * L^2 + row
  const uint32_t leaf = uint32_t(k / rows), r = uint32_t(k % rows);
  const LeafOrigin o = origins[leaf];
  const double p[3] = {o.o[0] + 0.5, o.o[1] + double(r % uint32_t(L)) + 0.5, o.o[2] + double(r / uint32_t(L)) + 0.5};
  int64_t P[3];
  int count = 0;
  if (!windingLatticePoint(p, P) || !windingRayCrossings(t, P, count) || count < INT16_MIN || count > INT16_MAX) {
    fits[leaf] = 0;
    return;
  }
  int16_t* row = counts + k * uint64_t(L);
  for (int x = 0; x < L; ++x) row[x] = int16_t(count);
}

// ---- boxes to first order ------------------------------------------------------
//
// Near w = 1/2 a box walk halves down to single voxels, each paying K from
// every edge. A sheet-free box of at most kMaxLinearVoxels voxels can instead
// take K to first order about its centre (windingChainExpansion: K, the whole
// chain's field and H over the box in one pass over the edges) and decide
// each voxel from its N alone (windingLinearVerdict). Close to a rim the
// remainder leaves a wide band unsure; a box with more than kLinearUnsure
// unsure voxels is halved as before (its expansion wasted), otherwise its
// unsure voxels go to the next level as single-voxel boxes (no more than the
// 8 halves the queue is sized for), where each takes K at its centre on a
// thread of its own.
constexpr int kMaxLinearVoxels = 64; // one bit a voxel
constexpr int kLinearUnsure = 8;

struct LinearVerdicts {
  uint64_t inside = 0, unsure = 0; // bit k: voxel k of the box, x fastest
};

__device__ uint32_t boxVoxels(const VoxelBox& b) {
  return uint32_t(b.size(0)) * uint32_t(b.size(1)) * uint32_t(b.size(2));
}

__device__ VoxelBox boxVoxel(const VoxelBox& b, int k) {
  const int sx = b.size(0), sy = b.size(1);
  const int x = b.lo[0] + k % sx, y = b.lo[1] + (k / sx) % sy, z = b.lo[2] + k / (sx * sy);
  return VoxelBox{{x, y, z}, {x + 1, y + 1, z + 1}};
}

// The verdicts over the open voxels of the leaf box b (voxel centres [lo,
// hi], crossing counts N, the leaf's words w). False when the expansion
// cannot be had, leaves the corners no chance (windingFarExpansionUseful) or
// leaves more than kLinearUnsure voxels unsure.
__device__ bool linearVerdicts(const WindingTreeView& t, const double* lo, const double* hi, const VoxelBox& b,
                               const WindingLeafWords& w, const int16_t* N, LinearVerdicts& out) {
  WindingFarExpansion x;
  if (!windingChainExpansion(t, lo, hi, x) || !windingFarExpansionUseful(x, lo, hi)) return false;
  int unsure = 0, k = 0;
  for (int z = b.lo[2]; z < b.hi[2]; ++z)
    for (int y = b.lo[1]; y < b.hi[1]; ++y)
      for (int xx = b.lo[0]; xx < b.hi[0]; ++xx, ++k) {
        const uint32_t v = w.index(xx, y, z);
        if (w.surface(v)) continue;
        const double p[3] = {lo[0] + (xx - b.lo[0]), lo[1] + (y - b.lo[1]), lo[2] + (z - b.lo[2])};
        const int verdict = windingLinearVerdict(t, x, p, int(N[v]));
        if (verdict == kWindingInside) out.inside |= uint64_t(1) << k;
        if (verdict == kWindingUnsure) {
          out.unsure |= uint64_t(1) << k;
          if (++unsure > kLinearUnsure) return false;
        }
      }
  return true;
}

// ---- uniform elements, breadth first ------------------------------------------
//
// classifyUniform's verdict (inside, outside or split) is a function of the
// exact verdicts at the element's voxel centres, and every box verdict below
// is certified, so any order of boxes gives the same answer. Instead of one
// serial windingDecideBox walk per element (a few elements near an open rim
// took most of the time), every box of every element is one thread of one
// level: a box is settled by the carried verdict (carriedBoxVerdict below)
// or halved along each axis longer than one voxel into the next level's
// queue; single voxels take windingInsideAt. seen[job] collects the sides
// met (atomicOr: order free); an element that met both is split and its
// remaining boxes are dropped. An element whose children do not fit the
// queue is marked and decided afterwards by the serial walk (uniformKernel).
constexpr uint32_t kSeenOutside = 1, kSeenInside = 2, kSeenBoth = 3, kQueueFull = 4;
constexpr uint32_t kNoJob = 0xFFFFFFFFu;
constexpr uint32_t kUniformQueue = 1u << 23; // boxes per level (at least twice the jobs)

// A queue's least capacity in boxes: `standard`, or HDT_WINDING_QUEUE_BOXES
// (for tests: small enough that the queues overflow and the fallbacks run).
uint32_t leastQueueBoxes(uint32_t standard) {
  const char* boxes = std::getenv("HDT_WINDING_QUEUE_BOXES");
  return boxes ? uint32_t(std::strtoul(boxes, nullptr, 10)) : standard;
}

struct QueuedBox {
  VoxelBox box;
  uint32_t job;
};

__global__ void __launch_bounds__(kBoxBlock, kBoxBlocksPerSM)
    uniformBoxesKernel(WindingTreeView t, const QueuedBox* in, uint32_t count, QueuedBox* out, uint32_t* outCount,
                       uint32_t capacity, uint32_t* seen) {
  const uint32_t i = blockIdx.x * blockDim.x + threadIdx.x;
  if (i >= count) return;
  const QueuedBox q = in[i];
  if (q.job == kNoJob) return;
  const uint32_t state = *static_cast<volatile uint32_t*>(seen + q.job);
  if ((state & kSeenBoth) == kSeenBoth || (state & kQueueFull)) return;
  const VoxelBox& b = q.box;
  if (b.single()) {
    const bool inside = windingInsideAt(t, b.lo[0] + 0.5, b.lo[1] + 0.5, b.lo[2] + 0.5);
    atomicOr(seen + q.job, inside ? kSeenInside : kSeenOutside);
    return;
  }
  const int v = windingCarriedBoxVerdict(t, b, false);
  if (v != kWindingUnsure) {
    atomicOr(seen + q.job, v == kWindingInside ? kSeenInside : kSeenOutside);
    return;
  }
  bool halve[3];
  uint32_t n = 1;
  for (int a = 0; a < 3; ++a) {
    halve[a] = b.size(a) > 1;
    n *= halve[a] ? 2u : 1u;
  }
  const uint32_t at = atomicAdd(outCount, n);
  if (at + n > capacity) { // the slots it got below capacity are dropped
    atomicOr(seen + q.job, kQueueFull);
    for (uint32_t k = at; k < capacity && k < at + n; ++k) out[k].job = kNoJob;
    return;
  }
  uint32_t k = 0;
  for (int c = 0; c < 8; ++c) {
    VoxelBox s = b;
    bool exists = true;
    for (int a = 0; a < 3; ++a) {
      const int mid = b.lo[a] + b.size(a) / 2;
      if ((c >> a) & 1) {
        exists = exists && halve[a];
        s.lo[a] = mid;
      } else if (halve[a]) {
        s.hi[a] = mid;
      }
    }
    if (exists) out[at + k++] = QueuedBox{s, q.job};
  }
}

// An element whose block holds (jobT[i], a threshold; null: none) takes N at
// one voxel centre against T; the others (and those whose ray walk cannot
// say) are queued whole, in any order.
__global__ void firstBoxesKernel(WindingTreeView t, const WindingUniformJob* jobs, uint32_t count, const int* jobT,
                                 uint32_t* seen, QueuedBox* boxes, uint32_t* queued) {
  const uint32_t i = blockIdx.x * blockDim.x + threadIdx.x;
  if (i >= count) return;
  const WindingUniformJob job = jobs[i];
  if (jobT && jobT[i] != kNoThreshold) {
    const int64_t P[3] = {latticeOfVoxelCentre(job.origin[0] + job.edge / 2),
                          latticeOfVoxelCentre(job.origin[1] + job.edge / 2),
                          latticeOfVoxelCentre(job.origin[2] + job.edge / 2)};
    int N = 0;
    if (windingRayCrossings(t, P, N)) {
      seen[i] = N >= jobT[i] ? kSeenInside : kSeenOutside;
      return;
    }
  }
  QueuedBox q;
  for (int a = 0; a < 3; ++a) {
    q.box.lo[a] = job.origin[a];
    q.box.hi[a] = job.origin[a] + job.edge;
  }
  q.job = i;
  boxes[atomicAdd(queued, 1u)] = q;
}

// ---- leaves, breadth first ----------------------------------------------------------
//
// windingDecideLeaf's boxes (winding_leaf.hpp: windingDecideBoxes' steps) as
// a queue over all leaves, one thread per box and level: a box with no
// non-surface voxel is dropped, a sheet-free box whose threshold holds is
// settled (one atomicOr per word: boxes of a leaf share words), a single
// voxel takes windingInsideWithCount, anything else is halved
// (windingPushHalves, with the gradient bound the children may reuse) into
// the next level. Every verdict is certified, so the bits do not depend on
// the boxes taken (the host starts from the whole leaf too). A leaf whose
// children do not fit the queue is left to the host (fits = 0;
// classifyLeaf rewrites its inside plane).
struct LeafBox {
  VoxelBox box; // leaf-local voxels
  uint32_t leaf;
  double gradient; // a bound on |grad K| over the box (INFINITY: none known)
};

constexpr uint32_t kLeafQueue = 1u << 23; // boxes per level (at least twice the leaves)

// The inside bit of each non-surface voxel of b whose N reaches T.
__device__ void settleLeafBox(uint32_t* words, uint32_t L, const VoxelBox& b, const int16_t* N, int T) {
  uint32_t word = 0xFFFFFFFFu, mask = 0;
  for (int z = b.lo[2]; z < b.hi[2]; ++z)
    for (int y = b.lo[1]; y < b.hi[1]; ++y)
      for (int x = b.lo[0]; x < b.hi[0]; ++x) {
        const uint32_t v = uint32_t(x) + L * (uint32_t(y) + L * uint32_t(z)), w = v / kVoxelsPerWord;
        if (w != word) {
          if (mask) atomicOr(words + word, mask);
          word = w;
          mask = 0;
        }
        const uint32_t shift = 2 * (v % kVoxelsPerWord);
        if (!((words[w] >> (shift + 1)) & 1u) && int(N[v]) >= T) mask |= 1u << shift;
      }
  if (mask) atomicOr(words + word, mask);
}

// The inside bits of the voxels of b whose bits are set in `inside` (bit k:
// voxel k of b, x fastest).
__device__ void settleLeafVoxels(uint32_t* words, const WindingLeafWords& w, const VoxelBox& b, uint64_t inside) {
  uint32_t word = 0xFFFFFFFFu, mask = 0;
  for (uint64_t u = inside; u; u &= u - 1) {
    const VoxelBox one = boxVoxel(b, __ffsll(u) - 1);
    const uint32_t v = w.index(one.lo[0], one.lo[1], one.lo[2]);
    if (v / kVoxelsPerWord != word) {
      if (mask) atomicOr(words + word, mask);
      word = v / kVoxelsPerWord;
      mask = 0;
    }
    mask |= 1u << (2 * (v % kVoxelsPerWord));
  }
  if (mask) atomicOr(words + word, mask);
}

// The whole leaves that fit and that no block settled, queued in any order
// (every verdict is certified).
__global__ void firstLeafBoxesKernel(uint32_t leafCount, int L, const uint8_t* fits, const int* leafT, LeafBox* boxes,
                                     uint32_t* count) {
  const uint32_t i = blockIdx.x * blockDim.x + threadIdx.x;
  if (i >= leafCount || !fits[i] || (leafT && leafT[i] != kNoThreshold)) return;
  boxes[atomicAdd(count, 1u)] = LeafBox{VoxelBox{{0, 0, 0}, {L, L, L}}, i, INFINITY};
}

// Voxels that the count and the strips leave unsure (the centre lies in a
// strip's plane, or w is within the margins of 1/2): windingInsideAt's
// refined sum can open thousands of nodes on one thread (one such voxel held
// a whole level for over 0.5 s, ogre at 1024^3), so they are listed and
// decided on the host after the pass (the same function, the same bits).
struct HardVoxels {
  uint2* items; // (leaf, voxel)
  uint32_t* count;
  uint32_t capacity;
};

constexpr uint32_t kHardVoxels = 1u << 20;

// windingInsideWithCount's first step: the verdict from N and K at p.
__device__ int countedVerdict(const WindingTreeView& t, const double* p, int N) {
  double K = 0, error = 0;
  if (!windingStripSum(t, p, K, error)) return kWindingUnsure;
  const double whole = 4.0 * kWindingPi * double(N);
  const WindingSum s{whole + K, error + 4.0 * kWindingUlp * (fabs(whole) + fabs(K)), true};
  return windingVerdict(s, t.triangleCount);
}

// LINEAR: boxes of at most linearVoxels voxels try the first order before
// they are halved. A template switch, so that the passes without it (the
// surface leaves) do not carry its code and registers.
template <bool LINEAR>
__global__ void __launch_bounds__(kBoxBlock, kBoxBlocksPerSM)
    leafBoxesKernel(WindingTreeView t, const LeafOrigin* origins, int L, const int16_t* counts, const uint32_t* slots,
                    uint8_t* fits, uint32_t* words, const LeafBox* in, uint32_t count, LeafBox* out,
                    uint32_t* outCount, uint32_t capacity, HardVoxels hard, bool allHard, uint32_t linearVoxels) {
  const uint32_t i = blockIdx.x * blockDim.x + threadIdx.x;
  if (i >= count) return;
  const LeafBox q = in[i];
  if (q.leaf == kNoJob || !fits[q.leaf]) return;
  uint32_t* leafWords = words + leafWordOffset(q.leaf, L);
  const int16_t* N = counts + countsSlot(slots, q.leaf) * uint64_t(L) * uint64_t(L) * uint64_t(L);
  const WindingLeafWords w{leafWords, uint32_t(L)};
  const VoxelBox& b = q.box;
  if (!w.open(b)) return;
  double lo[3], hi[3];
  windingBoxCentres(origins[q.leaf].o, b, lo, hi);
  if (b.single()) {
    const uint32_t v = w.index(b.lo[0], b.lo[1], b.lo[2]);
    const int verdict = allHard ? int(kWindingUnsure) : countedVerdict(t, lo, int(N[v]));
    if (verdict == kWindingInside) atomicOr(leafWords + v / kVoxelsPerWord, 1u << (2 * (v % kVoxelsPerWord)));
    if (verdict == kWindingUnsure) {
      const uint32_t at = atomicAdd(hard.count, 1u);
      if (at < hard.capacity) {
        hard.items[at] = make_uint2(q.leaf, v);
      } else {
        fits[q.leaf] = 0; // the host's whole leaf
      }
    }
    return;
  }
  const bool sheet = windingSheetsMeetBox(t, lo, hi);
  double gradient = q.gradient;
  int T = 0;
  if (!sheet && windingBoxThreshold(t, lo, hi, T, gradient)) {
    settleLeafBox(leafWords, uint32_t(L), b, N, T);
    return;
  }
  if constexpr (LINEAR) {
    LinearVerdicts linear;
    if (!sheet && !allHard && boxVoxels(b) <= linearVoxels && linearVerdicts(t, lo, hi, b, w, N, linear)) {
      settleLeafVoxels(leafWords, w, b, linear.inside);
      const uint32_t n = uint32_t(__popcll(linear.unsure));
      const uint32_t at = atomicAdd(outCount, n);
      if (at + n > capacity) {
        fits[q.leaf] = 0;
        for (uint32_t k = at; k < capacity && k < at + n; ++k) out[k].leaf = kNoJob;
        return;
      }
      uint32_t k = 0;
      for (uint64_t u = linear.unsure; u; u &= u - 1)
        out[at + k++] = LeafBox{boxVoxel(b, __ffsll(u) - 1), q.leaf, INFINITY};
      return;
    }
  }
  VoxelBox halves[8];
  double known[8];
  int n = 0;
  windingPushHalves(b, sheet, halves, known, n, gradient);
  const uint32_t at = atomicAdd(outCount, uint32_t(n));
  if (at + uint32_t(n) > capacity) {
    fits[q.leaf] = 0;
    for (uint32_t k = at; k < capacity && k < at + uint32_t(n); ++k) out[k].leaf = kNoJob;
    return;
  }
  for (int k = 0; k < n; ++k) out[at + uint32_t(k)] = LeafBox{halves[k], q.leaf, known[k]};
}

void checkLaunch(const char* name) {
  HDT_CUDA_CHECK_LAUNCH(name);
}

// ---- blocks of leaves ------------------------------------------------------------
//
// The host's blocks (core/src/winding.cpp, coarseThresholds): aligned cubes of
// kBlockLeaves leaf edges a side; a block that no strip sheet meets and whose
// K range holds no tie (windingBoxThreshold over the block's voxel centres)
// certifies one threshold T for every point in it: inside iff N >= T. So a
// leaf in a held block is settled from its counts alone (no K per leaf), and
// a uniform element in one by N at one voxel centre (w is continuous over it
// and never 1/2 in the block). One thread per block; the blocks are those of
// the items asked, deduplicated by a sort. A block past the volume's far side
// is not clipped: its box then holds more points than needed, still certified.
constexpr int kBlockLeaves = 4;
constexpr uint64_t kNoBlock = ~uint64_t(0);

__host__ __device__ uint64_t blockKey(int x, int y, int z, int edge) {
  return (uint64_t(uint32_t(z / edge)) << 42) | (uint64_t(uint32_t(y / edge)) << 21) | uint64_t(uint32_t(x / edge));
}

__global__ void leafBlockKeysKernel(const LeafOrigin* origins, uint32_t n, int edge, uint64_t* keys) {
  const uint32_t i = blockIdx.x * blockDim.x + threadIdx.x;
  if (i < n) keys[i] = blockKey(origins[i].o[0], origins[i].o[1], origins[i].o[2], edge);
}

// Elements larger than a block have none.
__global__ void jobBlockKeysKernel(const WindingUniformJob* jobs, uint32_t n, int edge, uint64_t* keys) {
  const uint32_t i = blockIdx.x * blockDim.x + threadIdx.x;
  if (i >= n) return;
  const WindingUniformJob j = jobs[i];
  keys[i] = j.edge <= edge ? blockKey(j.origin[0], j.origin[1], j.origin[2], edge) : kNoBlock;
}

__global__ void blockThresholdKernel(WindingTreeView t, const uint64_t* keys, uint32_t n, int edge, int* T) {
  const uint32_t i = blockIdx.x * blockDim.x + threadIdx.x;
  if (i >= n) return;
  const uint64_t k = keys[i];
  const uint32_t b[3] = {uint32_t(k & 0x1FFFFFu), uint32_t((k >> 21) & 0x1FFFFFu), uint32_t(k >> 42)};
  double lo[3], hi[3];
  for (int a = 0; a < 3; ++a) {
    lo[a] = double(b[a]) * edge + 0.5;
    hi[a] = double(b[a] + 1) * edge - 0.5;
  }
  double gradient = INFINITY;
  int threshold = 0;
  const bool holds = k != kNoBlock && !windingSheetsMeetBox(t, lo, hi) && windingBoxThreshold(t, lo, hi, threshold, gradient);
  T[i] = holds ? threshold : kNoThreshold;
}

// Each item's block threshold (kNoThreshold: none) by binary search of its
// key among the sorted unique blocks.
__global__ void blockLookupKernel(const uint64_t* itemKeys, uint32_t n, const uint64_t* keys, const int* T,
                                  uint32_t blockCount, int* itemT) {
  const uint32_t i = blockIdx.x * blockDim.x + threadIdx.x;
  if (i >= n) return;
  const uint64_t k = itemKeys[i];
  uint32_t lo = 0, hi = blockCount;
  while (lo < hi) {
    const uint32_t mid = (lo + hi) / 2;
    if (keys[mid] < k) lo = mid + 1;
    else hi = mid;
  }
  itemT[i] = (k != kNoBlock && lo < blockCount && keys[lo] == k) ? T[lo] : kNoThreshold;
}

// itemT[i]: the threshold of item i's block (keys: each item's block key,
// kNoBlock for none), kNoThreshold where it does not hold. Returns the
// number of blocks evaluated.
uint32_t blockThresholds(const WindingTreeView& t, const uint64_t* itemKeys, uint32_t n, int edge, int* itemT) {
  Array<uint64_t> sorted(n), unique(n);
  Array<uint32_t> uniqueCount(1);
  size_t sortBytes = 0, uniqueBytes = 0;
  HDT_CUDA_CHECK(cub::DeviceRadixSort::SortKeys(nullptr, sortBytes, itemKeys, sorted.data(), int(n)));
  HDT_CUDA_CHECK(cub::DeviceSelect::Unique(nullptr, uniqueBytes, sorted.data(), unique.data(), uniqueCount.data(), int(n)));
  Array<uint8_t> temp(std::max<size_t>(std::max(sortBytes, uniqueBytes), 16));
  HDT_CUDA_CHECK(cub::DeviceRadixSort::SortKeys(temp.data(), sortBytes, itemKeys, sorted.data(), int(n)));
  HDT_CUDA_CHECK(cub::DeviceSelect::Unique(temp.data(), uniqueBytes, sorted.data(), unique.data(), uniqueCount.data(), int(n)));
  uint32_t count = 0;
  uniqueCount.download(&count);
  Array<int> T(std::max<uint32_t>(count, 1));
  blockThresholdKernel<<<(count + kBoxBlock - 1) / kBoxBlock, kBoxBlock>>>(t, unique.data(), count, edge, T.data());
  HDT_CUDA_CHECK_LAUNCH("blockThresholdKernel");
  blockLookupKernel<<<blocks(n), kBlock>>>(itemKeys, n, unique.data(), T.data(), count, itemT);
  HDT_CUDA_CHECK_LAUNCH("blockLookupKernel");
  HDT_CUDA_CHECK(cudaStreamSynchronize(0)); // before the temporaries go (not the words' upload)
  return count;
}

// A leaf of a held block: each non-surface voxel inside iff N >= T (one
// thread per word; the word's inside plane rewritten).
// insideBits: the bits countsKernel left (else from the counts).
__global__ void settleBlockLeavesKernel(uint64_t wordCount, int L, const uint8_t* fits, const int* leafT,
                                        const int16_t* counts, const uint32_t* slots, const uint16_t* insideBits,
                                        uint32_t* words) {
  const uint64_t i = uint64_t(blockIdx.x) * blockDim.x + threadIdx.x;
  const uint32_t wc = leafWordCount(L);
  if (i >= wordCount) return;
  const uint64_t leaf = i / wc;
  const int T = leafT[leaf];
  if (!fits[leaf] || T == kNoThreshold) return;
  uint32_t inside = 0;
  if (insideBits) {
    inside = insideBits[i];
  } else {
    const uint64_t voxels = uint64_t(L) * uint64_t(L) * uint64_t(L);
    const int16_t* N = counts + countsSlot(slots, uint32_t(leaf)) * voxels + (i % wc) * kVoxelsPerWord;
    for (uint32_t v = 0; v < kVoxelsPerWord; ++v) inside |= uint32_t(int(N[v]) >= T) << v;
  }
  words[i] = withInsidePlane(words[i], inside);
}


// The device's state between the steps.
// counts: N per voxel (L^3 a leaf) of the leaves that keep them, at their
// slots (countsSlot), allocated by the counts step (keepCounts).
struct CountsOnDevice {
  Array<LeafOrigin> origins;
  Array<int32_t> totals, hits;
  Array<uint8_t> fits;
  std::optional<Array<int16_t>> counts;
  std::optional<Array<uint32_t>> slots; // none: every leaf keeps counts, in leaf order
  uint32_t keptLeaves = 0;
  CountsOnDevice(size_t leaves, int L)
      : origins(leaves), totals(leaves * size_t(L) * size_t(L)), hits(L > kSharedLeaf ? totals.size() : 0),
        fits(leaves) {}
  int16_t* countsData() const { return counts ? counts->data() : nullptr; }
  const uint32_t* slotsData() const { return slots ? slots->data() : nullptr; }
};

// out[i] = in[0] + ... + in[i - 1] for i <= n (CUB, on the legacy stream
// after the kernel that wrote in[0, n)); in[n] is zeroed first, so out[n] is
// the total, returned (the copy waits for the scan: in may go after it).
template <class T>
T exclusiveSumAndTotal(T* in, T* out, uint32_t n) {
  HDT_CUDA_CHECK(cudaMemset(in + n, 0, sizeof(T)));
  size_t bytes = 0;
  HDT_CUDA_CHECK(cub::DeviceScan::ExclusiveSum(nullptr, bytes, in, out, int(n) + 1));
  Array<uint8_t> temp(std::max<size_t>(bytes, 16));
  HDT_CUDA_CHECK(cub::DeviceScan::ExclusiveSum(temp.data(), bytes, in, out, int(n) + 1));
  T total = 0;
  HDT_CUDA_CHECK(cudaMemcpy(&total, out + n, sizeof(T), cudaMemcpyDeviceToHost));
  return total;
}

// 1 for a leaf that keeps its counts (no held block: leafT[leaf] is
// kNoThreshold), 0 for one whose inside bits the counts step writes instead.
__global__ void keepsCountsKernel(const int* leafT, uint32_t n, uint32_t* keeps) {
  const uint32_t i = blockIdx.x * blockDim.x + threadIdx.x;
  if (i < n) keeps[i] = leafT[i] == kNoThreshold ? 1u : 0u;
}

// The counts array: with leafT (the leaves of held blocks store only their
// inside bits, about 90% of them), a slot per leaf that keeps counts from an
// exclusive sum of keepsCountsKernel's flags (CUB), so the array holds those
// leaves only; without, every leaf in leaf order (no slots).
void keepCounts(CountsOnDevice& d, uint32_t leaves, int L, const int* leafT) {
  const uint64_t voxels = uint64_t(L) * uint64_t(L) * uint64_t(L);
  d.keptLeaves = leaves;
  if (leafT) {
    d.slots.emplace(size_t(leaves) + 1);
    Array<uint32_t> keeps(size_t(leaves) + 1);
    keepsCountsKernel<<<blocks(leaves), kBlock>>>(leafT, leaves, keeps.data());
    HDT_CUDA_CHECK_LAUNCH("keepsCountsKernel");
    d.keptLeaves = exclusiveSumAndTotal(keeps.data(), d.slots->data(), leaves);
  }
  d.counts.emplace(std::max<uint64_t>(uint64_t(d.keptLeaves) * voxels, 1));
}

class Events {
public:
  Events() {
    for (cudaEvent_t& e : e_) HDT_CUDA_CHECK(cudaEventCreate(&e));
  }
  ~Events() {
    for (cudaEvent_t& e : e_) cudaEventDestroy(e);
  }
  void mark(int i) { HDT_CUDA_CHECK(cudaEventRecord(e_[i])); }
  double ms(int a, int b) {
    float m = 0;
    HDT_CUDA_CHECK(cudaEventSynchronize(e_[b]));
    HDT_CUDA_CHECK(cudaEventElapsedTime(&m, e_[a], e_[b]));
    return m;
  }

private:
  cudaEvent_t e_[11];
};

// HDT_WINDING_TRACE set: each level's boxes and kernel time on stderr.
bool traceLevels() {
  static const bool on = std::getenv("HDT_WINDING_TRACE") != nullptr;
  return on;
}

class LevelTrace {
public:
  explicit LevelTrace(const char* name) : name_(name), on_(traceLevels()) {
    if (on_) {
      HDT_CUDA_CHECK(cudaEventCreate(&a_));
      HDT_CUDA_CHECK(cudaEventCreate(&b_));
    }
  }
  ~LevelTrace() {
    if (on_) {
      cudaEventDestroy(a_);
      cudaEventDestroy(b_);
    }
  }
  void start() {
    if (on_) HDT_CUDA_CHECK(cudaEventRecord(a_));
  }
  void stop(int level, uint32_t boxes) {
    if (!on_) return;
    HDT_CUDA_CHECK(cudaEventRecord(b_));
    HDT_CUDA_CHECK(cudaEventSynchronize(b_));
    float ms = 0;
    HDT_CUDA_CHECK(cudaEventElapsedTime(&ms, a_, b_));
    std::fprintf(stderr, "winding trace %s level %d: %u boxes, %.3f ms\n", name_, level, boxes, double(ms));
  }

private:
  const char* name_;
  bool on_;
  cudaEvent_t a_ = nullptr, b_ = nullptr;
};

// Bytes a queue slot takes, whichever pass's boxes it holds: a queue grown
// by the uniform pass then serves the leaf pass as it is (each allocation
// costs, about a millisecond at 8192^3's sizes).
constexpr size_t kQueueSlotBytes = std::max(sizeof(LeafBox), sizeof(QueuedBox));

// The two box queues' memory, kept across the passes of one build (the
// uniform pass runs once per refinement level). Each queue is an array of
// its own, grown level by level to what the next level can hold (a box has
// at most kChildBoxes children) up to the pass's limit, so a small build
// holds small queues instead of the limit's 2 x 2^23 slots. A queue grows
// only when the next level is to be written into it: its old boxes were
// consumed by then, so it is freed before the larger one is allocated (no
// copy, never more than two queues held).
class QueueMemory {
public:
  // Before a pass that allocates its own arrays ahead of its queues: queues
  // kept from an earlier pass go when the budget's room beside them is less
  // than they hold (they were cut to a tight budget, and kept they would
  // leave the pass's arrays no room); under a roomy budget they stay.
  void releaseIfTight(uint64_t room) {
    if (room < bytes()) {
      queue_[0].reset();
      queue_[1].reset();
    }
  }
  // Queue q (0 or 1) holding at least `slots` boxes; grown, its boxes are lost.
  template <class T>
  T* hold(int q, uint64_t slots) {
    static_assert(sizeof(T) <= kQueueSlotBytes, "a queue slot holds any box");
    std::unique_ptr<Array<uint8_t>>& a = queue_[q];
    const size_t wanted = size_t(slots) * kQueueSlotBytes;
    if (!a || a->size() < wanted) {
      const auto start = std::chrono::steady_clock::now();
      a.reset();
      a = std::make_unique<Array<uint8_t>>(wanted);
      ++grown_;
      growMs_ += std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - start).count();
    }
    return reinterpret_cast<T*>(a->data());
  }
  // Queue q's boxes (as many as it has slots).
  template <class T>
  T* at(int q) const {
    return reinterpret_cast<T*>(queue_[q]->data());
  }
  // The slots queue q holds now.
  uint64_t slots(int q) const { return queue_[q] ? queue_[q]->size() / kQueueSlotBytes : 0; }
  // Slots either queue may hold within the budget: room for two queues
  // (those held now counted as free: they go first) beside `spare` bytes
  // for what the pass allocates after them.
  uint64_t affordable(uint64_t spare) const {
    const uint64_t room = t_passMemory ? t_passMemory->room() : UINT64_MAX;
    if (room == UINT64_MAX) return UINT64_MAX;
    const uint64_t free = room + bytes();
    return free > spare ? (free - spare) / (2 * kQueueSlotBytes) : 0;
  }
  // The allocations so far and their wall time (HDT_WINDING_TRACE).
  unsigned grown() const { return grown_; }
  double growMs() const { return growMs_; }

private:
  uint64_t bytes() const { return (queue_[0] ? queue_[0]->size() : 0) + (queue_[1] ? queue_[1]->size() : 0); }
  std::unique_ptr<Array<uint8_t>> queue_[2];
  unsigned grown_ = 0;
  double growMs_ = 0;
};

// A queue's limit in boxes: `standard` (or HDT_WINDING_QUEUE_BOXES), cut
// to what the budget affords, at least twice the items queued first. A
// full queue is no error (the items whose boxes do not fit take the
// fallbacks: the serial walk, the host's leaf), so under a small device
// memory budget the pass runs with shorter queues instead of not at all.
uint32_t queueLimit(const QueueMemory& memory, uint32_t items, uint32_t standard, uint64_t spare) {
  const uint64_t wanted = std::min<uint64_t>(leastQueueBoxes(standard), memory.affordable(spare));
  return uint32_t(std::max<uint64_t>(2 * uint64_t(items), wanted));
}

// Bytes kept free beside the queues for the small arrays after them.
constexpr uint64_t kQueueSpareBytes = uint64_t(1) << 20;

// The most boxes one box is split into.
constexpr uint64_t kChildBoxes = 8;
// A queue that grows takes at least this many times what it held (each
// allocation costs: fewer, larger steps).
constexpr uint64_t kQueueGrowth = 8;

// A queue about to take a level of `n` boxes' children: kChildBoxes * n
// (at least kQueueGrowth times what it holds), never beyond `limit`.
uint64_t nextLevelBoxes(uint64_t n, uint64_t held, uint32_t limit) {
  const uint64_t needed = kChildBoxes * n;
  if (needed <= held) return held;
  return std::min<uint64_t>(limit, std::max(needed, kQueueGrowth * held));
}

// The levels of a pass's boxes, the first level's `first` boxes in queue 0:
// launch(in, n, out, capacity, outCount) per level until a level queues no
// box, the next level's queue grown first (nextLevelBoxes) and the queues
// swapping between levels. A level of more than `limit` boxes is cut, its
// items marked by the kernel (the fallbacks). Returns the boxes taken.
template <class Box, class Launch>
uint64_t runQueueLevels(const char* name, uint32_t first, uint32_t limit, QueueMemory& memory, Launch launch) {
  Array<uint32_t> outCount(1);
  uint64_t total = 0;
  LevelTrace trace(name);
  int in = 0;
  for (uint32_t n = first, level = 0; n > 0; ++level) {
    total += n;
    const int out = 1 - in;
    Box* to = memory.hold<Box>(out, nextLevelBoxes(n, memory.slots(out), limit));
    const uint32_t capacity = uint32_t(std::min<uint64_t>(limit, memory.slots(out)));
    outCount.zero();
    trace.start();
    launch(memory.at<Box>(in), n, to, capacity, outCount.data());
    trace.stop(int(level), n);
    outCount.download(&n);
    n = std::min(n, capacity);
    in = out;
  }
  return total;
}

// The fresh leaves' boxes of at most this many voxels try the first order
// (decideLeavesBreadthFirst): kLinearBoxVoxels, or HDT_WINDING_LINEAR_VOXELS
// (0: never, the halving alone; for A/B runs), at most kMaxLinearVoxels.
constexpr uint32_t kLinearBoxVoxels = 64;

uint32_t linearBoxVoxels() {
  const char* voxels = std::getenv("HDT_WINDING_LINEAR_VOXELS");
  const uint32_t n = voxels ? uint32_t(std::strtoul(voxels, nullptr, 10)) : kLinearBoxVoxels;
  return std::min(n, uint32_t(kMaxLinearVoxels));
}

// The leaves' boxes level by level (leafBoxesKernel); returns the boxes taken.
// hard: on return the voxels left to the host (decideHardVoxels).
// leafT: each leaf's block threshold (those with one are settled already), or null.
// linearVoxels: boxes of at most this many voxels try the first order
// (linearVerdicts) before they are halved; 0: never. The fresh leaves of
// refined elements take it: they lie on the w = 1/2 sheet spanning a hole,
// where it settles most boxes. The leaves holding the surface do not: their
// open boxes lie along the rims, where the remainder is wide and most
// expansions would be wasted (bench/results/winding.md, session 18).
uint64_t decideLeavesBreadthFirst(const WindingTreeView& t, const LeafOrigin* origins, uint32_t leaves, int L,
                                  const int16_t* counts, const uint32_t* slots, uint8_t* fits, const int* leafT,
                                  uint32_t* words, QueueMemory& memory, uint32_t linearVoxels,
                                  std::vector<uint2>& hard) {
  Array<uint32_t> hardCount(1);
  Array<uint2> hardItems(kHardVoxels);
  hardCount.zero();
  const uint32_t limit = queueLimit(memory, leaves, kLeafQueue, kQueueSpareBytes);
  const bool allHard = std::getenv("HDT_WINDING_HOST_VOXELS") != nullptr;
  uint32_t first = 0;
  {
    Array<uint32_t> firstCount(1);
    firstCount.zero();
    firstLeafBoxesKernel<<<blocks(leaves), kBlock>>>(leaves, L, fits, leafT, memory.hold<LeafBox>(0, leaves),
                                                     firstCount.data());
    checkLaunch("firstLeafBoxesKernel");
    firstCount.download(&first);
  }
  const HardVoxels hardVoxels{hardItems.data(), hardCount.data(), kHardVoxels};
  const uint64_t total =
      runQueueLevels<LeafBox>("leaves", first, limit, memory,
                              [&](LeafBox* from, uint32_t n, LeafBox* to, uint32_t capacity, uint32_t* toCount) {
        const unsigned grid = (n + kBoxBlock - 1) / kBoxBlock;
        const auto kernel = linearVoxels > 0 ? leafBoxesKernel<true> : leafBoxesKernel<false>;
        kernel<<<grid, kBoxBlock>>>(t, origins, L, counts, slots, fits, words, from, n, to, toCount, capacity,
                                    hardVoxels, allHard, linearVoxels);
        checkLaunch("leafBoxesKernel");
      });
  uint32_t n = 0;
  hardCount.download(&n);
  hard.resize(std::min(n, kHardVoxels));
  if (!hard.empty()) HDT_CUDA_CHECK(cudaMemcpy(hard.data(), hardItems.data(), hard.size() * sizeof(uint2), cudaMemcpyDeviceToHost));
  return total;
}

// The listed voxels by windingInsideAt on the host (in parallel over the list;
// the bits are set afterwards, in list order), in the downloaded words of
// the leaves that fit (the others are the host's whole leaves anyway).
void decideHardVoxels(const WindingTreeView& t, const std::vector<std::array<int, 3>>& origins, int L,
                      const std::vector<uint2>& hard, const std::vector<uint8_t>& fits, uint32_t* words) {
  if (hard.empty()) return;
  std::vector<uint8_t> inside(hard.size(), 0);
  tbb::parallel_for(size_t(0), hard.size(), [&](size_t i) {
    const uint32_t leaf = hard[i].x, v = hard[i].y, uL = uint32_t(L);
    if (!fits[leaf]) return;
    const std::array<int, 3>& o = origins[leaf];
    inside[i] = windingInsideAt(t, o[0] + double(v % uL) + 0.5, o[1] + double((v / uL) % uL) + 0.5,
                                o[2] + double(v / (uL * uL)) + 0.5);
  });
  for (size_t i = 0; i < hard.size(); ++i)
    if (inside[i]) {
      const uint32_t v = hard[i].y;
      words[leafWordOffset(hard[i].x, L) + v / kVoxelsPerWord] |= 1u << (2 * (v % kVoxelsPerWord));
    }
}

// crossings, lines, counts: N per voxel in d.counts.
void uploadOrigins(const std::vector<std::array<int, 3>>& origins, CountsOnDevice& d) {
  std::vector<LeafOrigin> host(origins.size());
  for (size_t i = 0; i < origins.size(); ++i) host[i] = {{origins[i][0], origins[i][1], origins[i][2]}};
  d.origins.upload(host.data());
}

// Each leaf's candidates with rays in it (L <= kSharedLeaf), listed once
// for both passes: list[offsets[leaf], offsets[leaf + 1]).
struct LeafCandidates {
  Array<uint64_t> offsets;
  std::unique_ptr<Array<uint32_t>> list;
  uint64_t pairs = 0;
  explicit LeafCandidates(uint32_t leaves) : offsets(size_t(leaves) + 1) {}
};

// The candidates counted, summed (CUB), listed.
void listLeafCandidates(const WindingTreeView& t, const CountsOnDevice& d, uint32_t leaves, int L,
                        LeafCandidates& c) {
  Array<uint64_t> counts(size_t(leaves) + 1);
  candidateCountKernel<<<blocks(leaves), kBlock>>>(t, d.origins.data(), leaves, L, counts.data());
  checkLaunch("candidateCountKernel");
  c.pairs = exclusiveSumAndTotal(counts.data(), c.offsets.data(), leaves);
  c.list = std::make_unique<Array<uint32_t>>(std::max<uint64_t>(c.pairs, 1));
  candidateListKernel<<<blocks(leaves), kBlock>>>(t, d.origins.data(), leaves, L, c.offsets.data(),
                                                  c.list->data());
  checkLaunch("candidateListKernel");
  if (traceLevels())
    std::fprintf(stderr, "winding trace crossings: %u leaves, %llu (leaf, candidate) pairs\n", leaves,
                 (unsigned long long)c.pairs);
}

// leafT, insideBits: countsKernel's (null: every leaf's counts kept).
// d.origins uploaded already (uploadOrigins).
void computeCounts(const WindingTreeView& t, const std::vector<std::array<int, 3>>& origins, int L,
                   CountsOnDevice& d, Events& ev, const int* leafT = nullptr, uint16_t* insideBits = nullptr) {
  const uint32_t leaves = uint32_t(origins.size());
  const uint32_t rows = uint32_t(L * L);
  std::optional<LeafCandidates> candidates; // L <= kSharedLeaf: the two passes'
  if (L <= kSharedLeaf) {
    ev.mark(1);
    candidates.emplace(leaves);
    listLeafCandidates(t, d, leaves, L, *candidates);
    leafRowTotalsKernel<<<leaves, kCrossingBlock>>>(t, d.origins.data(), L, candidates->offsets.data(),
                                                    candidates->list->data(), d.totals.data());
    checkLaunch("leafRowTotalsKernel");
  } else {
    // The serial kernel's per-voxel deltas go to the counts array (N is
    // computed in place by countsKernel): every leaf keeps counts.
    keepCounts(d, leaves, L, nullptr);
    d.totals.zero();
    d.hits.zero();
    d.counts->zero();
    ev.mark(1);
    signedCrossingsKernel<<<blocks(leaves), kBlock>>>(t, d.origins.data(), leaves, L, d.totals.data(), d.hits.data(),
                                                      d.countsData());
    checkLaunch("signedCrossingsKernel");
  }
  ev.mark(2);
  {
    Array<uint64_t> keys(leaves), sortedKeys(leaves);
    Array<uint32_t> order(leaves), sortedOrder(leaves), index(leaves), starts(leaves), lineCount(1);
    Array<uint8_t> start(leaves);
    lineKeysKernel<<<blocks(leaves), kBlock>>>(d.origins.data(), leaves, keys.data(), order.data());
    checkLaunch("lineKeysKernel");
    size_t bytes = 0;
    HDT_CUDA_CHECK(cub::DeviceRadixSort::SortPairs(nullptr, bytes, keys.data(), sortedKeys.data(), order.data(),
                                                   sortedOrder.data(), int(leaves)));
    size_t selectBytes = 0;
    HDT_CUDA_CHECK(cub::DeviceSelect::Flagged(nullptr, selectBytes, index.data(), start.data(), starts.data(),
                                              lineCount.data(), int(leaves)));
    Array<uint8_t> temp(std::max<size_t>(std::max(bytes, selectBytes), 16));
    HDT_CUDA_CHECK(cub::DeviceRadixSort::SortPairs(temp.data(), bytes, keys.data(), sortedKeys.data(), order.data(),
                                                   sortedOrder.data(), int(leaves)));
    lineStartKernel<<<blocks(leaves), kBlock>>>(sortedKeys.data(), leaves, start.data());
    checkLaunch("lineStartKernel");
    indexKernel<<<blocks(leaves), kBlock>>>(leaves, index.data());
    checkLaunch("indexKernel");
    HDT_CUDA_CHECK(cub::DeviceSelect::Flagged(temp.data(), selectBytes, index.data(), start.data(), starts.data(),
                                              lineCount.data(), int(leaves)));
    uint32_t lines = 0;
    lineCount.download(&lines);
    ev.mark(9);
    if (traceLevels()) std::fprintf(stderr, "winding trace lines: %u leaves on %u lines\n", leaves, lines);
    lineSuffixKernel<<<blocks(uint64_t(lines) * rows), kBlock>>>(starts.data(), lines, leaves,
                                                                  sortedOrder.data(), rows, d.totals.data());
    checkLaunch("lineSuffixKernel");
    ev.mark(3);
    HDT_CUDA_CHECK(cudaStreamSynchronize(0)); // before the temporaries go (not the words' upload)
  }
  HDT_CUDA_CHECK(cudaMemset(d.fits.data(), 1, leaves));
  // After the lines' temporaries: the counts of the leaves that keep them.
  if (candidates) keepCounts(d, leaves, L, leafT);
  ev.mark(10);
  if (candidates) {
    leafCountsKernel<<<leaves, kCrossingBlock>>>(t, d.origins.data(), L, candidates->offsets.data(),
                                                 candidates->list->data(), d.totals.data(), d.countsData(),
                                                 d.slotsData(), d.fits.data(), leafT, insideBits);
    checkLaunch("leafCountsKernel");
  } else {
    countsKernel<<<blocks(uint64_t(leaves) * rows), kBlock>>>(leaves, L, d.totals.data(), d.hits.data(),
                                                              d.countsData(), d.fits.data(), leafT, insideBits);
    checkLaunch("countsKernel");
  }
  ev.mark(4);
  if (candidates) HDT_CUDA_CHECK(cudaStreamSynchronize(0)); // before the candidate list goes (not the words' upload)
}

// The volume's leaf words copied up on a stream of their own (non-blocking:
// the legacy stream's kernels do not wait for it) by a thread of its own,
// while the counts run: the copy is bound by the host threads filling the
// pinned ring, so it hides behind the crossings, lines and counts. wait()
// returns when the words are on the device (rethrowing the copy's error) and
// the copy's own wall time; the destructor waits too (the words must outlive
// the copy).
class WordsUpload {
public:
  WordsUpload(uint32_t* device, const uint32_t* host, size_t words) {
    int gpu = 0;
    HDT_CUDA_CHECK(cudaGetDevice(&gpu));
    HDT_CUDA_CHECK(cudaStreamCreateWithFlags(&stream_, cudaStreamNonBlocking));
    thread_ = std::thread([this, gpu, device, host, words] {
      const auto t0 = std::chrono::steady_clock::now();
      try {
        HDT_CUDA_CHECK(cudaSetDevice(gpu));
        copyToDevice(stream_, device, host, words * sizeof(uint32_t));
      } catch (...) {
        error_ = std::current_exception();
      }
      ms_ = std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count();
    });
  }
  ~WordsUpload() {
    if (thread_.joinable()) thread_.join();
    cudaStreamDestroy(stream_);
  }
  WordsUpload(const WordsUpload&) = delete;
  WordsUpload& operator=(const WordsUpload&) = delete;
  double wait() {
    if (thread_.joinable()) thread_.join();
    if (error_) std::rethrow_exception(error_);
    return ms_;
  }

private:
  cudaStream_t stream_ = nullptr;
  std::thread thread_;
  std::exception_ptr error_;
  double ms_ = 0;
};

} // namespace

struct WindingDevicePass::Impl {
  PassMemory memory; // first: the arrays below give their bytes back to it
  const WindingTree* host = nullptr;
  DeviceTree* tree = nullptr;
  QueueMemory queues;
  int blockEdge = 0; // the blocks' edge in voxels, once known
  explicit Impl(DeviceMemory* build) : memory(build) {}
  ~Impl() { delete tree; }
  const DeviceTree& upload(const WindingTree& t) {
    if (host != &t) {
      delete tree;
      tree = nullptr;
      tree = new DeviceTree(t);
      host = &t;
    }
    return *tree;
  }
};

WindingDevicePass::WindingDevicePass(DeviceMemory* build) : impl_(std::make_unique<Impl>(build)) {}
WindingDevicePass::~WindingDevicePass() = default;

uint64_t WindingDevicePass::peakBytes() const { return impl_->memory.peak(); }

bool WindingDevicePass::leaves(const WindingTree& tree, Volume& volume, const std::vector<std::array<int, 3>>& origins,
                               std::vector<uint32_t>& leftLeaves, WindingDeviceTimes* times, uint32_t* deviceWords,
                               const std::function<void()>& beforeCopyBack) {
  leftLeaves.clear();
  const int L = volume.grid.leafSize;
  const uint32_t leaves = uint32_t(origins.size());
  if (leaves == 0) return true;
  const PassMemoryScope scope(impl_->memory);
  try {
    impl_->queues.releaseIfTight(impl_->memory.room());
    Events ev;
    ev.mark(0);
    const DeviceTree& t = impl_->upload(tree);
    CountsOnDevice d(leaves, L);
    std::vector<uint2> hard;
    // The leaf words: already on the device (read and written in place), or
    // copied up from the volume beside the counts.
    const size_t wordCount = volume.leafWords.size();
    std::optional<Array<uint32_t>> ownWords;
    std::optional<WordsUpload> upload;
    uint32_t* words = deviceWords;
    if (!words) {
      ownWords.emplace(wordCount);
      words = ownWords->data();
      upload.emplace(words, volume.leafWords.data(), wordCount);
    }
    // Each leaf's block threshold first: the counts kernel settles the leaves
    // of held blocks (their counts are not kept where L is a multiple of 16).
    uploadOrigins(origins, d);
    if (impl_->blockEdge == 0) impl_->blockEdge = kBlockLeaves * L;
    const int edge = impl_->blockEdge;
    Array<int> leafT(leaves);
    uint32_t blockCount = 0;
    {
      Array<uint64_t> keys(leaves);
      leafBlockKeysKernel<<<blocks(leaves), kBlock>>>(d.origins.data(), leaves, edge, keys.data());
      checkLaunch("leafBlockKeysKernel");
      blockCount = blockThresholds(t.view(), keys.data(), leaves, edge, leafT.data());
    }
    ev.mark(8);
    const bool fuse = L % kVoxelsPerWord == 0 && L <= 32;
    Array<uint16_t> insideBits(fuse ? wordCount : 0);
    computeCounts(t.view(), origins, L, d, ev, fuse ? leafT.data() : nullptr, fuse ? insideBits.data() : nullptr);
    const auto wait0 = std::chrono::steady_clock::now();
    const double uploadMs = upload ? upload->wait() : 0.0;
    const double uploadWaitMs = std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - wait0).count();
    clearInsideKernel<<<blocks(wordCount), kBlock>>>(wordCount, L, d.fits.data(), words);
    checkLaunch("clearInsideKernel");
    settleBlockLeavesKernel<<<blocks(wordCount), kBlock>>>(wordCount, L, d.fits.data(), leafT.data(), d.countsData(),
                                                          d.slotsData(), fuse ? insideBits.data() : nullptr, words);
    checkLaunch("settleBlockLeavesKernel");
    // Tests: the pass failing for want of memory after it began rewriting the
    // words (the breadth-first queues are its last allocations).
    if (std::getenv("HDT_WINDING_LEAF_PASS_FAILS")) throw std::bad_alloc();
    ev.mark(7);
    const uint64_t boxes =
        decideLeavesBreadthFirst(t.view(), d.origins.data(), leaves, L, d.countsData(), d.slotsData(), d.fits.data(),
                                 leafT.data(), words, impl_->queues, 0, hard);
    ev.mark(5);
    std::vector<uint8_t> fits(leaves);
    d.fits.download(fits.data());
    if (beforeCopyBack) beforeCopyBack();
    copyToHost(0, volume.leafWords.data(), words, wordCount * sizeof(uint32_t));
    ev.mark(6);
    const auto hard0 = std::chrono::steady_clock::now();
    decideHardVoxels(tree.view(), origins, L, hard, fits, volume.leafWords.data());
    const double hardMs = std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - hard0).count();
    for (uint32_t i = 0; i < leaves; ++i)
      if (!fits[i]) leftLeaves.push_back(i);
    if (traceLevels()) {
      std::vector<int> T(leaves);
      leafT.download(T.data());
      const size_t settled = size_t(std::count_if(T.begin(), T.end(), [](int x) { return x != kNoThreshold; }));
      std::fprintf(stderr,
                   "winding trace leaves: %u leaves, %u blocks of %d voxels, %zu leaves settled by them, %.3f ms; "
                   "words up %.3f ms beside the counts, %.3f ms waited for%s; %u leaves keep counts (%.1f MB); "
                   "the pass's device bytes at most %.1f MB so far; box queues allocated %u times so far (%.3f ms)\n",
                   leaves, blockCount, edge, settled, ev.ms(0, 8), uploadMs, uploadWaitMs,
                   upload ? "" : " (kept on the device: none)", d.keptLeaves, double(d.counts->size()) * 2e-6,
                   double(impl_->memory.peak()) * 1e-6, impl_->queues.grown(), impl_->queues.growMs());
      std::fprintf(stderr,
                   "winding trace steps: lines = sort and select %.3f ms + suffixes %.3f ms; counts = the "
                   "lines' temporaries freed %.3f ms + %s %.3f ms\n",
                   ev.ms(2, 9), ev.ms(9, 3), ev.ms(3, 10), L <= kSharedLeaf ? "the second crossings pass" : "countsKernel",
                   ev.ms(10, 4));
    }
    if (times) {
      times->hardVoxels = hard.size();
      times->hardMs = hardMs;
      times->upload = ev.ms(8, 1) + uploadWaitMs; // the words' upload beyond the counts
      times->crossings = ev.ms(1, 2);
      times->lines = ev.ms(2, 3);
      times->counts = ev.ms(3, 4);
      times->blocks = ev.ms(0, 8);
      times->decide = ev.ms(7, 5);
      times->download = ev.ms(5, 6);
      times->boxes = boxes;
    }
    return true;
  } catch (const std::bad_alloc&) {
    return false;
  }
}

bool WindingDevicePass::uniform(const WindingTree& tree, const std::vector<WindingUniformJob>& jobs,
                                std::vector<uint8_t>& verdicts, double* ms, uint64_t* boxes) {
  verdicts.assign(jobs.size(), 0);
  if (jobs.empty()) return true;
  const PassMemoryScope scope(impl_->memory);
  try {
    Events ev;
    ev.mark(0);
    const DeviceTree& t = impl_->upload(tree);
    const uint32_t count = uint32_t(jobs.size());
    Array<WindingUniformJob> d(jobs.size());
    d.upload(jobs.data());
    Array<uint32_t> seen(jobs.size());
    seen.zero();
    // The blocks of the elements that fit in one: the leaves' blocks when the
    // edge is known, else kBlockLeaves of the smallest element's edges (the
    // leaf's, but for a volume with no element at the last level).
    if (impl_->blockEdge == 0) {
      int smallest = INT_MAX;
      for (const WindingUniformJob& j : jobs) smallest = std::min(smallest, j.edge);
      impl_->blockEdge = kBlockLeaves * smallest;
    }
    const int edge = impl_->blockEdge;
    const bool anyInBlock = std::any_of(jobs.begin(), jobs.end(), [&](const WindingUniformJob& j) { return j.edge <= edge; });
    std::unique_ptr<Array<int>> jobT;
    uint32_t first = 0, blockCount = 0;
    if (anyInBlock) {
      jobT = std::make_unique<Array<int>>(count);
      Array<uint64_t> keys(count);
      jobBlockKeysKernel<<<blocks(count), kBlock>>>(d.data(), count, edge, keys.data());
      checkLaunch("jobBlockKeysKernel");
      blockCount = blockThresholds(t.view(), keys.data(), count, edge, jobT->data());
    }
    // After the thresholds' temporaries; spare: the serial walk's copies of
    // the elements whose boxes overflow (at most all of them).
    const uint64_t spare = kQueueSpareBytes + uint64_t(count) * (sizeof(WindingUniformJob) + 1);
    const uint32_t limit = queueLimit(impl_->queues, count, kUniformQueue, spare);
    {
      Array<uint32_t> queued(1);
      queued.zero();
      firstBoxesKernel<<<blocks(count), kBlock>>>(t.view(), d.data(), count, jobT ? jobT->data() : nullptr, seen.data(),
                                                  impl_->queues.hold<QueuedBox>(0, count), queued.data());
      checkLaunch("firstBoxesKernel");
      queued.download(&first);
    }
    if (traceLevels())
      std::fprintf(stderr, "winding trace uniform: %u elements, %u blocks of %d voxels, %u elements queued\n", count,
                   blockCount, edge, first);
    const uint64_t total =
        runQueueLevels<QueuedBox>("uniform", first, limit, impl_->queues,
                                  [&](QueuedBox* from, uint32_t n, QueuedBox* to, uint32_t capacity, uint32_t* toCount) {
          uniformBoxesKernel<<<(n + kBoxBlock - 1) / kBoxBlock, kBoxBlock>>>(t.view(), from, n, to, toCount, capacity,
                                                                             seen.data());
          checkLaunch("uniformBoxesKernel");
        });
    std::vector<uint32_t> state(jobs.size());
    seen.download(state.data());
    std::vector<WindingUniformJob> serial; // whose boxes did not fit the queue
    std::vector<size_t> at;
    for (size_t i = 0; i < jobs.size(); ++i) {
      if (state[i] & kQueueFull) {
        serial.push_back(jobs[i]);
        at.push_back(i);
        continue;
      }
      const bool both = (state[i] & kSeenBoth) == kSeenBoth;
      verdicts[i] = both ? 2 : (state[i] & kSeenInside) ? 1 : 0;
    }
    if (!serial.empty()) {
      Array<WindingUniformJob> sd(serial.size());
      Array<uint8_t> v(serial.size());
      sd.upload(serial.data());
      constexpr unsigned kUniformBlock = 32;
      uniformKernel<<<unsigned((serial.size() + kUniformBlock - 1) / kUniformBlock), kUniformBlock>>>(
          t.view(), sd.data(), uint32_t(serial.size()), v.data());
      checkLaunch("uniformKernel");
      std::vector<uint8_t> sv(serial.size());
      v.download(sv.data());
      for (size_t j = 0; j < serial.size(); ++j) verdicts[at[j]] = sv[j];
    }
    ev.mark(1);
    if (ms) *ms = ev.ms(0, 1);
    if (boxes) *boxes += total;
    return true;
  } catch (const std::bad_alloc&) {
    return false;
  }
}

bool WindingDevicePass::fresh(const WindingTree& tree, int L, const std::vector<std::array<int, 3>>& origins,
                              uint32_t* words, std::vector<uint32_t>& leftLeaves, double* ms) {
  leftLeaves.clear();
  const uint32_t leaves = uint32_t(origins.size());
  if (leaves == 0) return true;
  const PassMemoryScope scope(impl_->memory);
  try {
    impl_->queues.releaseIfTight(impl_->memory.room());
    Events ev;
    ev.mark(0);
    const DeviceTree& t = impl_->upload(tree);
    const uint64_t n = uint64_t(L) * uint64_t(L) * uint64_t(L);
    Array<LeafOrigin> o(leaves);
    Array<int16_t> counts(leaves * n);
    Array<uint8_t> fits(leaves);
    Array<uint32_t> w(uint64_t(leaves) * leafWordCount(L));
    std::vector<LeafOrigin> host(leaves);
    for (size_t i = 0; i < leaves; ++i) host[i] = {{origins[i][0], origins[i][1], origins[i][2]}};
    o.upload(host.data());
    w.zero();
    HDT_CUDA_CHECK(cudaMemset(fits.data(), 1, leaves));
    freshCountsKernel<<<blocks(uint64_t(leaves) * uint64_t(L) * uint64_t(L)), kBlock>>>(t.view(), o.data(), leaves, L, counts.data(),
                                                                 fits.data());
    checkLaunch("freshCountsKernel");
    std::vector<uint2> hard;
    decideLeavesBreadthFirst(t.view(), o.data(), leaves, L, counts.data(), nullptr, fits.data(), nullptr, w.data(),
                             impl_->queues, linearBoxVoxels(), hard);
    std::vector<uint8_t> hostFits(leaves);
    fits.download(hostFits.data());
    copyToHost(0, words, w.data(), w.size() * sizeof(uint32_t));
    ev.mark(1);
    decideHardVoxels(tree.view(), origins, L, hard, hostFits, words);
    for (uint32_t i = 0; i < leaves; ++i)
      if (!hostFits[i]) leftLeaves.push_back(i);
    if (ms) *ms = ev.ms(0, 1);
    return true;
  } catch (const std::bad_alloc&) {
    return false;
  }
}

void windingCountsOnDevice(const WindingTree& tree, int L, const std::vector<std::array<int, 3>>& origins,
                           std::vector<int16_t>& counts, std::vector<uint8_t>& fits) {
  const size_t leaves = origins.size();
  counts.assign(leaves * size_t(L) * size_t(L) * size_t(L), 0);
  fits.assign(leaves, 0);
  if (leaves == 0) return;
  Events ev;
  DeviceTree t(tree);
  CountsOnDevice d(leaves, L);
  uploadOrigins(origins, d);
  computeCounts(t.view(), origins, L, d, ev);
  d.counts->download(counts.data());
  d.fits.download(fits.data());
}

} // namespace cuda
} // namespace hdt
