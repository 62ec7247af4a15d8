// T3: the surface voxels of every leaf grid.
//
// One warp per leaf task (a leaf, or a part of a leaf with very many pairs:
// LeafTask); the leaf's row masks (one L-bit mask per row y + L z) live in
// the warp's slice of shared memory. The task's (leaf, triangle) pairs are
// taken B at a time, in three warp-wide steps that follow the CPU driver's
// loops exactly (build_steps.hpp; same calls, same narrowing):
//   1. one lane per pair: the triangle's row axis (rowAxisFor: the rows
//      across which its shadow is smallest) and its voxel ranges in the leaf;
//      then one lane per (pair, part) for its RowClipper in that frame
//      (makeRowClipperPart), kept in shared memory for the batch;
//   2. one lane per (pair, k): for slice z = k, clipRowsOfSlice (the rows
//      that can meet the triangle) and clipSliceSpan (the slice's x span);
//      for row height y = k, clipColumnSpan (the height's x span);
//   3. one lane per (pair, row): the two spans intersected, clipRowByPlane,
//      rowBits, ORed into the leaf's x-row masks (forEachXRowOf) with
//      shared-memory atomics (OR commutes: scheduling cannot show).
// Flattening to rows keeps all 32 lanes busy however unevenly the triangles
// cover the leaf, and a row costs only its plane step: the twelve other axes
// were settled per slice and per height in step 2. With the clipper in shared
// memory, a lane holds no clipper in registers, which is what limited
// occupancy. Finally the warp writes every word of the leaf exactly once,
// coalesced: no global atomics, no read-modify-write, no zero fill beforehand
// (the parts of a split leaf OR their words into zeroed ones instead).
#include "device_common.cuh"
#include "phases.hpp"

#include "hdt/build_steps.hpp"

namespace hdt {
namespace cuda {
namespace {

constexpr int kWarpsPerBlock = 4;
// 8 blocks of 4 warps per SM caps registers at 64: a few spills, but 32
// warps instead of 24 hide more of the row steps' latency (measured: 8.0 vs 8.75 ms).
#ifndef HDT_CUDA_T3_MIN_BLOCKS
#define HDT_CUDA_T3_MIN_BLOCKS 8
#endif

// Warp per split-leaf first part: zero the leaf's slice of `data`.
__global__ void zeroSplitKernel(const LeafTask* tasks, const uint32_t* taskCount, uint32_t* data, uint32_t perLeaf) {
  const uint32_t t = (blockIdx.x * blockDim.x + threadIdx.x) >> 5;
  if (t >= *taskCount) return;
  const LeafTask task = tasks[t];
  if (!(task.flags & kTaskFirst)) return;
  for (uint32_t i = threadIdx.x & 31; i < perLeaf; i += 32) data[size_t(task.leaf) * perLeaf + i] = 0;
}

// Pairs whose clippers are in shared memory at once. 4 or 6 (more resident
// warps, fewer lanes busy in the per-pair steps) measured slower at 8192^3:
// dragon T3 3.7 -> 4.2 / 4.8 ms, cycloidal-drive about the same.
constexpr int kBatch = 8;

template <int L>
struct SurfaceWarp {
  RowClipper clip[kBatch];
  LatticeTriangle tri[kBatch]; // in the frame of its row axis
  int8_t axis[kBatch]; // row axis of each pair; the fields below are in its frame
  int32_t x0[kBatch], x1[kBatch], y0[kBatch], y1[kBatch], z0[kBatch], nz[kBatch]; // leaf-relative
  int8_t sliceY0[kBatch][L];  // shadow rows of each slice, leaf-relative
  uint8_t sliceRows[kBatch][L];
  int8_t sliceX0[kBatch][L], sliceX1[kBatch][L];   // x span of each slice (e x Y axes)
  int8_t columnX0[kBatch][L], columnX1[kBatch][L]; // x span of each row height (e x Z axes)
  uint32_t rows[L * L];
};

template <int L>
__device__ __forceinline__ void leafSurface(const LeafArgs& a, const LeafTask& task, SurfaceWarp<L>& sh,
                                            uint32_t* words) {
  const int lane = threadIdx.x & 31;
  const uint32_t leaf = task.leaf;
  for (int r = lane; r < L * L; r += 32) sh.rows[r] = 0;

  int64_t v0[3];
  leafOrigin(a.leafCoord[leaf], L, v0);
  const uint32_t p1 = task.end;
  for (uint32_t base = task.first; base < p1; base += kBatch) {
    const int nb = int(min(uint32_t(kBatch), p1 - base));
    __syncwarp(); // the previous batch is done with the shared clippers
    if (lane < nb) { // in the frame of the triangle's row axis (rowAxisFor)
      const LatticeTriangle original = a.tris[a.pairTri[base + lane]];
      const int axis = rowAxisFor(original);
      const LatticeTriangle t = permuteToRowAxis(original, axis);
      int64_t o[3], first[3], last[3];
      permutedOrigin(v0, axis, o);
      leafVoxelRanges(t, o, L, a.resolution, first, last);
      sh.tri[lane] = t;
      sh.axis[lane] = int8_t(axis);
      sh.x0[lane] = int32_t(first[0] - o[0]);
      sh.x1[lane] = int32_t(last[0] - o[0]);
      sh.y0[lane] = int32_t(first[1] - o[1]);
      sh.y1[lane] = int32_t(last[1] - o[1]);
      sh.z0[lane] = int32_t(first[2] - o[2]);
      sh.nz[lane] = last[2] >= first[2] ? int32_t(last[2] - first[2] + 1) : 0;
    }
    __syncwarp();
    // The clippers, one lane per (pair, part): at most 4 rounds for 8 pairs
    // instead of 13 parts in a row on one lane per pair.
    for (int item = lane; item < nb * kRowClipperParts; item += 32)
      makeRowClipperPart(sh.tri[item / kRowClipperParts], item % kRowClipperParts, sh.clip[item / kRowClipperParts]);
    __syncwarp();
    warpForEachPairItem(
        0, nb, [&](uint32_t j) { return max(sh.nz[j], sh.y1[j] - sh.y0[j] + 1); },
        [&](uint32_t j, int k) {
          int64_t o[3];
          permutedOrigin(v0, sh.axis[j], o);
          const int64_t x0 = o[0] + sh.x0[j], x1 = o[0] + sh.x1[j];
          if (k < sh.nz[j]) {
            const int64_t z = o[2] + sh.z0[j] + k;
            int64_t ya = o[1] + sh.y0[j], yb = o[1] + sh.y1[j];
            clipRowsOfSlice(sh.clip[j], z, ya, yb);
            int64_t f = x0, l = x1;
            if (ya <= yb) clipSliceSpan(sh.clip[j], z, f, l);
            const bool rows = ya <= yb && f <= l;
            sh.sliceY0[j][k] = int8_t(rows ? ya - o[1] : 0);
            sh.sliceRows[j][k] = uint8_t(rows ? yb - ya + 1 : 0);
            sh.sliceX0[j][k] = int8_t(rows ? f - o[0] : 1); // within the leaf when rows
            sh.sliceX1[j][k] = int8_t(rows ? l - o[0] : 0);
          }
          if (k <= sh.y1[j] - sh.y0[j]) {
            const int dy = sh.y0[j] + k;
            int64_t f = x0, l = x1;
            clipColumnSpan(sh.clip[j], o[1] + dy, f, l);
            sh.columnX0[j][dy] = int8_t(f > l ? 1 : f - o[0]); // empty kept as 1 > 0
            sh.columnX1[j][dy] = int8_t(f > l ? 0 : l - o[0]);
          }
        });
    __syncwarp();
    warpForEachPairItem(
        0, uint32_t(nb) * L,
        [&](uint32_t e) { return int(e % L) < sh.nz[e / L] ? int(sh.sliceRows[e / L][e % L]) : 0; },
        [&](uint32_t e, int r) {
          const uint32_t j = e / L, s = e % L;
          const int axis = sh.axis[j];
          int64_t o[3];
          permutedOrigin(v0, axis, o);
          const int dy = sh.sliceY0[j][s] + r, dz = sh.z0[j] + int(s);
          int64_t f = o[0] + max(sh.sliceX0[j][s], sh.columnX0[j][dy]);
          int64_t l = o[0] + min(sh.sliceX1[j][s], sh.columnX1[j][dy]);
          clipRowByPlane(sh.clip[j], o[1] + dy, o[2] + dz, f, l);
          forEachXRowOf(axis, L, dy, dz, rowBits(o[0], f, l),
                        [&](int row, uint32_t bits) { atomicOr(&sh.rows[row], bits); });
        });
  }
  __syncwarp();

  uint32_t* out = words + size_t(leaf) * leafWordCount(L);
  for (int w = lane; w < int(leafWordCount(L)); w += 32) {
    const uint32_t v = spreadBits16(wordBitsFromRows(sh.rows, L, w)) << 1;
    if (!(task.flags & kTaskSplit)) {
      out[w] = v;
    } else if (v) {
      atomicOr(&out[w], v);
    }
  }
}

template <int L>
__global__ void __launch_bounds__(32 * kWarpsPerBlock, HDT_CUDA_T3_MIN_BLOCKS) leafSurfaceKernel(LeafArgs a, uint32_t* words) {
  __shared__ SurfaceWarp<L> shared[kWarpsPerBlock];
  const int warp = threadIdx.x >> 5;
  const uint32_t t = blockIdx.x * kWarpsPerBlock + warp;
  if (t >= *a.taskCount) return; // warp-uniform
  // One task a warp: a grid-stride loop over tasks measured slower here and
  // in classification (dragon 8192^3: T3 3.8 -> 4.0 ms, pass 1 1.9 -> 2.0).
  leafSurface<L>(a, a.tasks[t], shared[warp], words);
}


template <int L>
void launchLeafSurface(const LeafArgs& a, uint32_t taskBound, uint32_t* words, cudaStream_t s) {
  leafSurfaceKernel<L><<<blocksFor(taskBound, kWarpsPerBlock), 32 * kWarpsPerBlock, 0, s>>>(a, words);
  HDT_CUDA_CHECK_LAUNCH("leafSurfaceKernel");
}

} // namespace

void zeroSplitLeaves(DeviceMemory& mem, const Leaves& leaves, uint32_t* data, uint32_t perLeaf) {
  if (leaves.count == 0) return;
  zeroSplitKernel<<<blocksFor(uint64_t(leaves.taskBound) * 32, 256), 256, 0, mem.stream()>>>(
      leaves.tasks.data(), leaves.taskCount.data(), data, perLeaf);
  HDT_CUDA_CHECK_LAUNCH("zeroSplitKernel");
}

void writeLeafSurfaces(DeviceMemory& mem, const DeviceMesh& mesh, const GridSpec& grid, const Leaves& leaves,
                       uint32_t* words) {
  if (leaves.count == 0) return;
  zeroSplitLeaves(mem, leaves, words, leafWordCount(grid.leafSize));
  const LeafArgs a = leafArgs(mesh, grid, leaves);
  const uint32_t bound = leaves.taskBound;
  switch (grid.leafSize) {
  case 8: launchLeafSurface<8>(a, bound, words, mem.stream()); break;
  case 16: launchLeafSurface<16>(a, bound, words, mem.stream()); break;
  case 32: launchLeafSurface<32>(a, bound, words, mem.stream()); break;
  default: throw Error(ErrorKind::InvalidArgument, "leaf size must be 8, 16 or 32");
  }
}

} // namespace cuda
} // namespace hdt
