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
//   compact   exclusive scan of the bytes' popcounts, then each pair writes
//             its (child, triangle) hits in (pair, child) order;
//   sort      stable radix sort on the child index bits only. Inside one
//             child the hits arrive in pair order = triangle order, so the
//             result is (child, triangle) sorted without sorting triangles.
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

#include <string>

namespace hdt {
namespace cuda {
namespace {

constexpr unsigned kBlock = 256;

struct HeadFlag {
  const uint32_t* element;
  __device__ uint32_t operator()(uint32_t i) const { return i == 0 || element[i] != element[i - 1] ? 1u : 0u; }
};

struct MaskCount {
  __device__ uint32_t operator()(uint8_t m) const { return uint32_t(__popc(m)); }
};

__global__ void rootCoordsKernel(uint32_t count, uint64_t firstCell, uint64_t R, uint64_t* coords) {
  const uint32_t j = blockIdx.x * blockDim.x + threadIdx.x;
  if (j >= count) return;
  const uint64_t c = firstCell + j;
  coords[j] = packCoord(uint32_t(c % R), uint32_t((c / R) % R), uint32_t(c / (R * R)));
}

// childCoords == nullptr: the leaf level (Boundary elements, leaf tables).
__global__ void markLevelKernel(uint32_t n, const uint32_t* element, const uint32_t* rank, const uint64_t* coords,
                                ElementWord* words, uint32_t branchBase, uint64_t* childCoords,
                                uint64_t* leafCoord, uint32_t* leafPairStart) {
  const uint32_t i = blockIdx.x * blockDim.x + threadIdx.x;
  if (i >= n) return;
  const uint32_t e = element[i];
  if (!childCoords && i == n - 1) leafPairStart[rank[i]] = n;
  if (i > 0 && element[i - 1] == e) return;
  const uint32_t r = rank[i] - 1;
  const uint64_t c = coords[e];
  if (!childCoords) {
    words[e] = makeElement(ElementState::Boundary, r);
    leafCoord[r] = c;
    leafPairStart[r] = i;
  } else {
    words[e] = makeElement(ElementState::Branch, branchBase + 8 * r);
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

__global__ void childWriteKernel(uint32_t n, const uint32_t* rank, const uint32_t* tri, const uint8_t* masks,
                                 const uint32_t* offsets, uint32_t* childElement, uint32_t* childTri) {
  const uint32_t i = blockIdx.x * blockDim.x + threadIdx.x;
  if (i >= n) return;
  uint32_t m = masks[i];
  uint32_t o = offsets[i];
  const uint32_t first = 8 * (rank[i] - 1), t = tri[i];
  while (m) {
    const int c = __ffs(m) - 1;
    m &= m - 1;
    childElement[o] = first + c;
    childTri[o] = t;
    ++o;
  }
}

__global__ void levelTotalsKernel(uint32_t n, const uint32_t* rank, const uint8_t* masks, const uint32_t* offsets,
                                  uint64_t* out) {
  out[0] = rank[n - 1];
  if (masks) out[1] = uint64_t(offsets[n - 1]) + __popc(masks[n - 1]);
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

    DeviceBuffer<uint32_t> rank(mem, n);
    if (n > 0) {
      auto heads = thrust::make_transform_iterator(thrust::counting_iterator<uint32_t>(0), HeadFlag{pairs.element.data()});
      runCub(mem, [&](void* temp, size_t& bytes) {
        return cub::DeviceScan::InclusiveSum(temp, bytes, heads, rank.data(), n, s);
      });
    }

    if (leafLevel) {
      uint32_t touched = 0;
      if (n > 0) {
        levelTotalsKernel<<<1, 1, 0, s>>>(n, rank.data(), nullptr, nullptr, scalars.device());
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
                                                               lf.pairStart.data());
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

    // Children of the touched elements: tests, counts, offsets.
    DeviceBuffer<uint8_t> masks(mem, n);
    DeviceBuffer<uint32_t> offsets(mem, n);
    uint32_t touched = 0;
    uint64_t hits = 0;
    const int64_t childSize = int64_t(grid.elementVoxels(level + 1)) * kLatticePerVoxel;
    if (n > 0) {
      childTestKernel<<<blocksFor(n, kBlock), kBlock, 0, s>>>(
          n, pairs.element.data(), pairs.triangle.data(), lv.coords.data(), mesh.triangles, childSize, masks.data());
      HDT_CUDA_CHECK_LAUNCH("childTestKernel");
      auto counts = thrust::make_transform_iterator(masks.data(), MaskCount{});
      runCub(mem, [&](void* temp, size_t& bytes) {
        return cub::DeviceScan::ExclusiveSum(temp, bytes, counts, offsets.data(), n, s);
      });
      levelTotalsKernel<<<1, 1, 0, s>>>(n, rank.data(), masks.data(), offsets.data(), scalars.device());
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
      markLevelKernel<<<blocksFor(n, kBlock), kBlock, 0, s>>>(n, pairs.element.data(), rank.data(), lv.coords.data(),
                                                             lv.words.data(), branchBase, next.coords.data(),
                                                             nullptr, nullptr);
      HDT_CUDA_CHECK_LAUNCH("markLevelKernel");
      childWriteKernel<<<blocksFor(n, kBlock), kBlock, 0, s>>>(n, rank.data(), pairs.triangle.data(), masks.data(),
                                                              offsets.data(), child.element.data(),
                                                              child.triangle.data());
      HDT_CUDA_CHECK_LAUNCH("childWriteKernel");
    }
    // The parent level's pair arrays are dead: give them back before the sort
    // needs its double buffers.
    pairs = PairList();
    rank.reset();
    masks.reset();
    offsets.reset();
    sortPairs(mem, child.element, child.triangle, child.count, bitsFor(next.count > 0 ? next.count - 1 : 0));
    pairs = std::move(child);
    levelStart = nextStart;
    tree.levels.push_back(std::move(next));
    if (afterLevel) afterLevel(level);
  }
}

} // namespace cuda
} // namespace hdt
