// T2: level-order branching.
//
// Per level, with the pairs sorted by (element, triangle):
//   rank      inclusive scan of "first pair of its element" flags: the touched
//             elements in order, and each pair's position among them;
//   mark      the first pair of each element writes the element word
//             (Branch -> 8 contiguous children in rank order, or Boundary ->
//             leaf rank at the last level) and the children's coordinates;
//   test      one thread per pair: the exact overlap test of its eight
//             children at once (triangleOverlapsChildren: each separating
//             axis projects the triangle once), a byte;
//   place     exclusive scan of the bytes as eight per-child counters
//             (ChildCounts), then each pair writes its (child, triangle) hits
//             straight to their places in (child, triangle) order: a child's
//             hits come in pair order = triangle order, and the counters give
//             each hit's rank among its child's and the parent's hits before
//             its child's. No sort: one scan of the pairs instead of a radix
//             sort of the hits (several passes over keys and values). When
//             no element can hold 65,536 pairs (fewer triangles than that),
//             the scan is a segmented one of 16-bit counters with the rank and
//             the hit count folded in (SegmentCounts): 24 bytes a pair instead
//             of 32, and no separate rank scan.
// One host synchronisation per level reads the touched and hit counts that
// size the next level.
#include "device_common.cuh"
#include "phases.hpp"

#include "hdt/build_steps.hpp"
#include "hdt/error.hpp"
#include "hdt/root_ranges.hpp" // checkElementLimit

#include <cub/device/device_scan.cuh>
#include <thrust/iterator/counting_iterator.h>
#include <thrust/iterator/transform_iterator.h>

#include <cstddef> // offsetof
#include <string>

namespace hdt {
namespace cuda {
namespace {

constexpr unsigned kBlock = 256;

struct HeadFlag {
  const uint32_t* element;
  __device__ uint32_t operator()(uint32_t i) const { return i == 0 || element[i] != element[i - 1] ? 1u : 0u; }
};

// Per pair (or the sum over pairs), the hits of each of the eight children.
struct alignas(16) ChildCounts {
  uint32_t c[8];
};

struct AddChildCounts {
  __device__ ChildCounts operator()(const ChildCounts& a, const ChildCounts& b) const {
    ChildCounts r;
#pragma unroll
    for (int k = 0; k < 8; ++k) r.c[k] = a.c[k] + b.c[k];
    return r;
  }
};

// Item i < n: pair i's child bits as counters; item n: zeros (so that the
// exclusive scan's entry n is the level's totals).
struct MaskToCounts {
  const uint8_t* masks;
  uint32_t n;
  __device__ ChildCounts operator()(uint32_t i) const {
    const uint32_t m = i < n ? masks[i] : 0u;
    ChildCounts r;
#pragma unroll
    for (int k = 0; k < 8; ++k) r.c[k] = (m >> k) & 1u;
    return r;
  }
};

__global__ void rootCoordsKernel(uint32_t count, uint64_t firstCell, uint64_t R, uint64_t* coords) {
  const uint32_t j = blockIdx.x * blockDim.x + threadIdx.x;
  if (j >= count) return;
  const uint64_t c = firstCell + j;
  coords[j] = packCoord(uint32_t(c % R), uint32_t((c / R) % R), uint32_t(c / (R * R)));
}

// The segmented form: per pair (or over a range of pairs), the hits of each
// child as 16-bit lanes (child k in lane k % 4 of lanes[k / 4]) since the
// range's last first-pair-of-an-element, the first pairs of elements in the
// range (rank) and all the hits in it. The inclusive scan's entry i holds
// pair i's rank (1-based), the hits of its element's pairs up to i by child,
// and every hit up to i. The lanes cannot carry into each other while no
// element has 65,536 pairs (an element's pairs are distinct triangles).
struct alignas(8) SegmentCounts {
  uint64_t lanes[2];
  uint32_t rank, hits;
};
constexpr uint32_t kSegmentMaxTriangles = 65535;
static_assert(sizeof(SegmentCounts) == 24 && offsetof(SegmentCounts, rank) == 16,
              "markLevelKernel reads the rank as every sixth word from the fifth");

struct AddSegmentCounts {
  __device__ SegmentCounts operator()(const SegmentCounts& a, const SegmentCounts& b) const {
    SegmentCounts r;
    r.lanes[0] = b.rank ? b.lanes[0] : a.lanes[0] + b.lanes[0];
    r.lanes[1] = b.rank ? b.lanes[1] : a.lanes[1] + b.lanes[1];
    r.rank = a.rank + b.rank;
    r.hits = a.hits + b.hits;
    return r;
  }
};

__device__ __forceinline__ uint64_t spreadToLanes(uint32_t bits4) {
  return uint64_t(bits4 & 1u) | uint64_t(bits4 >> 1 & 1u) << 16 | uint64_t(bits4 >> 2 & 1u) << 32 |
         uint64_t(bits4 >> 3 & 1u) << 48;
}
__device__ __forceinline__ uint32_t lane(const SegmentCounts& v, int k) {
  return uint32_t(v.lanes[k >> 2] >> (16 * (k & 3))) & 0xffffu;
}

struct MaskToSegmentCounts {
  const uint32_t* element;
  const uint8_t* masks;
  __device__ SegmentCounts operator()(uint32_t i) const {
    const uint32_t m = masks[i];
    SegmentCounts r;
    r.lanes[0] = spreadToLanes(m & 15u);
    r.lanes[1] = spreadToLanes(m >> 4);
    r.rank = i == 0 || element[i] != element[i - 1] ? 1u : 0u;
    r.hits = uint32_t(__popc(m));
    return r;
  }
};

// childCoords == nullptr: the leaf level (Boundary elements, leaf tables).
// With childCoords, segmentStart[r] = the first pair of touched element r.
// rank: pair i's at rank[i * rankStride] (inside SegmentCounts or not).
__global__ void markLevelKernel(uint32_t n, const uint32_t* element, const uint32_t* rank, const uint64_t* coords,
                                ElementWord* words, uint32_t branchBase, uint64_t* childCoords,
                                uint64_t* leafCoord, uint32_t* leafPairStart, uint32_t* segmentStart,
                                uint32_t rankStride) {
  const uint32_t i = blockIdx.x * blockDim.x + threadIdx.x;
  if (i >= n) return;
  const uint32_t e = element[i];
  if (!childCoords && i == n - 1) leafPairStart[rank[size_t(i) * rankStride]] = n;
  if (i > 0 && element[i - 1] == e) return;
  const uint32_t r = rank[size_t(i) * rankStride] - 1;
  const uint64_t c = coords[e];
  if (!childCoords) {
    words[e] = makeElement(ElementState::Boundary, r);
    leafCoord[r] = c;
    leafPairStart[r] = i;
  } else {
    words[e] = makeElement(ElementState::Branch, branchBase + 8 * r);
    segmentStart[r] = i;
#pragma unroll
    for (int k = 0; k < 8; ++k) childCoords[8 * uint64_t(r) + k] = childCoord(c, k);
  }
}

// One thread per pair: the byte of its children that the triangle meets.
__global__ void childTestKernel(uint32_t n, const uint32_t* element, const uint32_t* tri, const uint64_t* coords,
                                const LatticeTriangle* tris, int64_t childSize, uint8_t* masks) {
  const uint32_t i = blockIdx.x * blockDim.x + threadIdx.x;
  if (i >= n) return;
  masks[i] = uint8_t(triangleOverlapsChildren(tris[tri[i]], coords[element[i]], childSize));
}

// Pair i's hit of child k goes after every hit of the parent's children
// before k and after the hits of child k by the parent's pairs before i.
// `before` is the exclusive scan of the pairs' ChildCounts (n + 1 entries);
// a parent's pairs are [segmentStart[r], segmentStart[r + 1]).
__global__ void childWriteKernel(uint32_t n, uint32_t touched, const uint32_t* rank, const uint32_t* segmentStart,
                                 const uint32_t* tri, const uint8_t* masks, const ChildCounts* before,
                                 uint32_t* childElement, uint32_t* childTri) {
  const uint32_t i = blockIdx.x * blockDim.x + threadIdx.x;
  if (i >= n) return;
  const uint32_t m = masks[i];
  if (!m) return;
  const uint32_t r = rank[i] - 1, t = tri[i];
  const uint32_t head = segmentStart[r], end = r + 1 < touched ? segmentStart[r + 1] : n;
  const ChildCounts atHead = before[head], atEnd = before[end], atPair = before[i];
  uint32_t o = 0; // the hits of every parent before this one
#pragma unroll
  for (int k = 0; k < 8; ++k) o += atHead.c[k];
#pragma unroll
  for (int k = 0; k < 8; ++k) {
    if (m >> k & 1u) {
      const uint32_t at = o + atPair.c[k] - atHead.c[k];
      childElement[at] = 8 * r + uint32_t(k);
      childTri[at] = t;
    }
    o += atEnd.c[k] - atHead.c[k];
  }
}

// childWriteKernel's placement from the segmented scan: the hits before
// this element are the hits up to i less the element's own up to i; its
// totals by child are the scan's entry at its last pair.
__global__ void childWriteSegmentKernel(uint32_t n, uint32_t touched, const uint32_t* segmentStart,
                                        const uint32_t* tri, const uint8_t* masks, const SegmentCounts* incl,
                                        uint32_t* childElement, uint32_t* childTri) {
  const uint32_t i = blockIdx.x * blockDim.x + threadIdx.x;
  if (i >= n) return;
  const uint32_t m = masks[i];
  if (!m) return;
  const SegmentCounts own = incl[i];
  const uint32_t r = own.rank - 1, t = tri[i];
  const SegmentCounts total = incl[(r + 1 < touched ? segmentStart[r + 1] : n) - 1];
  uint32_t o = own.hits;
#pragma unroll
  for (int k = 0; k < 8; ++k) o -= lane(own, k);
#pragma unroll
  for (int k = 0; k < 8; ++k) {
    if (m >> k & 1u) {
      const uint32_t at = o + lane(own, k) - 1;
      childElement[at] = 8 * r + uint32_t(k);
      childTri[at] = t;
    }
    o += lane(total, k);
  }
}

__global__ void segmentTotalsKernel(uint32_t n, const SegmentCounts* incl, uint64_t* out) {
  out[0] = incl[n - 1].rank;
  out[1] = incl[n - 1].hits;
}

// totals: the exclusive scan's entry n (the sums over all pairs), or null.
__global__ void levelTotalsKernel(uint32_t n, const uint32_t* rank, const ChildCounts* totals, uint64_t* out) {
  out[0] = rank[n - 1];
  if (totals) {
    uint64_t hits = 0;
    for (int k = 0; k < 8; ++k) hits += totals->c[k];
    out[1] = hits;
  }
}

__global__ void taskCountKernel(uint32_t leaves, const uint32_t* pairStart, uint32_t* counts) {
  const uint32_t i = blockIdx.x * blockDim.x + threadIdx.x;
  if (i >= leaves) return;
  const uint32_t pairs = pairStart[i + 1] - pairStart[i];
  counts[i] = pairs <= kTaskPairs ? 1u : (pairs + kTaskPairs - 1) / kTaskPairs;
}

__global__ void taskWriteKernel(uint32_t leaves, const uint32_t* pairStart, const uint32_t* counts,
                                const uint32_t* offsets, LeafTask* tasks, uint32_t* taskCount) {
  const uint32_t i = blockIdx.x * blockDim.x + threadIdx.x;
  if (i >= leaves) return;
  const uint32_t n = counts[i], o = offsets[i], p0 = pairStart[i], p1 = pairStart[i + 1];
  for (uint32_t k = 0; k < n; ++k) {
    const uint32_t first = p0 + k * kTaskPairs;
    tasks[o + k] = LeafTask{i, first, min(p1, first + kTaskPairs),
                            n == 1 ? 0u : (kTaskSplit | (k == 0 ? kTaskFirst : 0u))};
  }
  if (i == leaves - 1) *taskCount = o + n;
}

// The warps' work list over the leaves (see LeafTask).
void planLeafTasks(DeviceMemory& mem, Leaves& lf, uint32_t leafPairs) {
  const cudaStream_t s = mem.stream();
  lf.taskBound = lf.count + leafPairs / kTaskPairs + 1;
  lf.tasks = DeviceBuffer<LeafTask>(mem, lf.taskBound);
  lf.taskCount = DeviceBuffer<uint32_t>(mem, 1);
  HDT_CUDA_CHECK(cudaMemsetAsync(lf.taskCount.data(), 0, sizeof(uint32_t), s));
  if (lf.count == 0) return;
  DeviceBuffer<uint32_t> counts(mem, lf.count), offsets(mem, lf.count);
  taskCountKernel<<<blocksFor(lf.count, kBlock), kBlock, 0, s>>>(lf.count, lf.pairStart.data(), counts.data());
  HDT_CUDA_CHECK_LAUNCH("taskCountKernel");
  runCub(mem, [&](void* temp, size_t& bytes) {
    return cub::DeviceScan::ExclusiveSum(temp, bytes, counts.data(), offsets.data(), lf.count, s);
  });
  taskWriteKernel<<<blocksFor(lf.count, kBlock), kBlock, 0, s>>>(lf.count, lf.pairStart.data(), counts.data(),
                                                                offsets.data(), lf.tasks.data(), lf.taskCount.data());
  HDT_CUDA_CHECK_LAUNCH("taskWriteKernel");
}

} // namespace

Tree buildTree(DeviceMemory& mem, HostScalars& scalars, const DeviceMesh& mesh, const GridSpec& grid,
               uint64_t firstCell, uint64_t endCell, PairList pairs, bool unchunked,
               const std::function<void(int)>& afterLevel) {
  const cudaStream_t s = mem.stream();
  Tree tree;
  tree.levels.reserve(grid.height + 1);
  {
    Level root;
    root.count = uint32_t(endCell - firstCell);
    root.words = DeviceBuffer<ElementWord>(mem, root.count);
    root.coords = DeviceBuffer<uint64_t>(mem, root.count);
    HDT_CUDA_CHECK(cudaMemsetAsync(root.words.data(), 0, root.words.bytes(), s)); // Empty
    rootCoordsKernel<<<blocksFor(root.count, kBlock), kBlock, 0, s>>>(root.count, firstCell, grid.rootGrid,
                                                                     root.coords.data());
    HDT_CUDA_CHECK_LAUNCH("rootCoordsKernel");
    tree.levels.push_back(std::move(root));
  }
  uint64_t levelStart = 0; // global index of the current level's first element (unchunked)
  for (int level = 0;; ++level) {
    Level& lv = tree.levels.back();
    const bool leafLevel = level == grid.height;
    const uint32_t n = pairs.count;
    const uint64_t nextStart = levelStart + lv.count;

    // The segmented scan gives the ranks too (childTest does not need them).
    const bool segmented = !leafLevel && mesh.count <= kSegmentMaxTriangles && n <= (1u << 29);
    DeviceBuffer<uint32_t> rank(mem, segmented ? 0 : n);
    if (n > 0 && !segmented) {
      auto heads = thrust::make_transform_iterator(thrust::counting_iterator<uint32_t>(0), HeadFlag{pairs.element.data()});
      runCub(mem, [&](void* temp, size_t& bytes) {
        return cub::DeviceScan::InclusiveSum(temp, bytes, heads, rank.data(), n, s);
      });
    }

    if (leafLevel) {
      uint32_t touched = 0;
      if (n > 0) {
        levelTotalsKernel<<<1, 1, 0, s>>>(n, rank.data(), nullptr, scalars.device());
        HDT_CUDA_CHECK_LAUNCH("levelTotalsKernel");
        scalars.fetch(s, 1);
        touched = uint32_t(scalars.host()[0]);
      }
      if (unchunked) checkElementLimit(nextStart, touched, level);
      Leaves& lf = tree.leaves;
      lf.count = touched;
      lf.coord = DeviceBuffer<uint64_t>(mem, touched);
      lf.pairStart = DeviceBuffer<uint32_t>(mem, uint64_t(touched) + 1);
      if (n > 0) {
        markLevelKernel<<<blocksFor(n, kBlock), kBlock, 0, s>>>(n, pairs.element.data(), rank.data(), lv.coords.data(),
                                                               lv.words.data(), 0, nullptr, lf.coord.data(),
                                                               lf.pairStart.data(), nullptr, 1);
        HDT_CUDA_CHECK_LAUNCH("markLevelKernel(leaf)");
      } else {
        HDT_CUDA_CHECK(cudaMemsetAsync(lf.pairStart.data(), 0, sizeof(uint32_t), s));
      }
      lf.triangle = std::move(pairs.triangle);
      lf.pairCount = n;
      rank.reset();
      planLeafTasks(mem, lf, n);
      return tree;
    }

    // Children of the touched elements: tests, per-child counters before each pair.
    DeviceBuffer<uint8_t> masks(mem, n);
    DeviceBuffer<ChildCounts> before(mem, n > 0 && !segmented ? uint64_t(n) + 1 : 0);
    DeviceBuffer<SegmentCounts> incl(mem, segmented ? n : 0);
    uint32_t touched = 0;
    uint64_t hits = 0;
    const int64_t childSize = int64_t(grid.elementVoxels(level + 1)) * kLatticePerVoxel;
    if (n > 0) {
      childTestKernel<<<blocksFor(n, kBlock), kBlock, 0, s>>>(
          n, pairs.element.data(), pairs.triangle.data(), lv.coords.data(), mesh.triangles, childSize, masks.data());
      HDT_CUDA_CHECK_LAUNCH("childTestKernel");
      if (segmented) {
        auto counts = thrust::make_transform_iterator(thrust::counting_iterator<uint32_t>(0),
                                                      MaskToSegmentCounts{pairs.element.data(), masks.data()});
        runCub(mem, [&](void* temp, size_t& bytes) {
          return cub::DeviceScan::InclusiveScan(temp, bytes, counts, incl.data(), AddSegmentCounts{}, n, s);
        });
        segmentTotalsKernel<<<1, 1, 0, s>>>(n, incl.data(), scalars.device());
      } else {
        auto counts =
            thrust::make_transform_iterator(thrust::counting_iterator<uint32_t>(0), MaskToCounts{masks.data(), n});
        runCub(mem, [&](void* temp, size_t& bytes) {
          return cub::DeviceScan::ExclusiveScan(temp, bytes, counts, before.data(), AddChildCounts{}, ChildCounts{},
                                                n + 1, s);
        });
        levelTotalsKernel<<<1, 1, 0, s>>>(n, rank.data(), before.data() + n, scalars.device());
      }
      HDT_CUDA_CHECK_LAUNCH("levelTotalsKernel");
      scalars.fetch(s, 2);
      touched = uint32_t(scalars.host()[0]);
      hits = scalars.host()[1];
    }
    if (unchunked) checkElementLimit(nextStart, touched, level);
    if (hits > uint64_t(INT32_MAX) || 8 * uint64_t(touched) > uint64_t(INT32_MAX))
      throw DeviceMemoryExhausted(hits * 16, mem.budget()); // too large for one piece: chunk it

    Level next;
    next.count = 8 * touched;
    next.words = DeviceBuffer<ElementWord>(mem, next.count);
    next.coords = DeviceBuffer<uint64_t>(mem, next.count);
    HDT_CUDA_CHECK(cudaMemsetAsync(next.words.data(), 0, next.words.bytes(), s));
    PairList child;
    child.count = uint32_t(hits);
    child.element = DeviceBuffer<uint32_t>(mem, hits);
    child.triangle = DeviceBuffer<uint32_t>(mem, hits);
    if (n > 0) {
      const uint32_t branchBase = unchunked ? uint32_t(nextStart) : 0u;
      DeviceBuffer<uint32_t> segmentStart(mem, touched);
      const uint32_t* ranks =
          segmented ? reinterpret_cast<const uint32_t*>(incl.data()) + offsetof(SegmentCounts, rank) / sizeof(uint32_t)
                    : rank.data();
      const uint32_t rankStride = segmented ? uint32_t(sizeof(SegmentCounts) / sizeof(uint32_t)) : 1u;
      markLevelKernel<<<blocksFor(n, kBlock), kBlock, 0, s>>>(n, pairs.element.data(), ranks, lv.coords.data(),
                                                             lv.words.data(), branchBase, next.coords.data(),
                                                             nullptr, nullptr, segmentStart.data(), rankStride);
      HDT_CUDA_CHECK_LAUNCH("markLevelKernel");
      if (segmented) {
        childWriteSegmentKernel<<<blocksFor(n, kBlock), kBlock, 0, s>>>(
            n, touched, segmentStart.data(), pairs.triangle.data(), masks.data(), incl.data(), child.element.data(),
            child.triangle.data());
      } else {
        childWriteKernel<<<blocksFor(n, kBlock), kBlock, 0, s>>>(n, touched, rank.data(), segmentStart.data(),
                                                                pairs.triangle.data(), masks.data(), before.data(),
                                                                child.element.data(), child.triangle.data());
      }
      HDT_CUDA_CHECK_LAUNCH("childWriteKernel");
    }
    pairs = std::move(child);
    levelStart = nextStart;
    tree.levels.push_back(std::move(next));
    if (afterLevel) afterLevel(level);
  }
}

} // namespace cuda
} // namespace hdt
