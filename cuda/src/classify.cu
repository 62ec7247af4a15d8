// Classification: inside/outside by ray parity, the method of docs/design.md
// ("Classification") with the bookkeeping of classify_steps.hpp; this file
// only schedules it on the GPU.
//
//   pass 1   one warp per leaf and ray axis, the three steps of
//            build_steps.hpp (pairRayRange, leafLineRays, crossingInLeaf) as three
//            warp-wide steps, so all lanes stay busy however unevenly the
//            hits fall. Each crossing flips the row's parity bit and XORs
//            its "voxels before the crossing" mask into the row's mask; both
//            are XORs, so scheduling cannot show. The parity bits go to
//            parity[a]; the masks (pass 2's geometry, computed once) go to
//            masks[a]. Along x the T3 kernel (leaf.cu) runs this pass on the
//            same pairs and puts the masks in plane 0 of the leaf words; the
//            kernel here runs y and z of open meshes (with masks) and chunk
//            phase A (parities only, before the leaf words exist);
//   lines    per axis, the leaves sorted by line key (LineKeys) with a radix
//            sort on 3b bits; the suffix XOR (suffixParityStep) as a
//            segmented scan over each warp's 32 sorted leaves (shuffles),
//            in place, recording the entry parity of row 0;
//   pass 2   no geometry left: a row is inside where (exit parity of the row)
//            XOR (its mask); closed meshes use the x rows, open ones the
//            majority of the 3 axes per voxel; plane 0 = inside and not
//            surface. One read and one write per leaf word;
//   uniform  one thread per Empty element: binary search of the first leaf
//            beyond it on its line, per axis; majority -> Full.
#include "device_common.cuh"
#include "phases.hpp"

#include "hdt/build_steps.hpp"

namespace hdt {
namespace cuda {
namespace {

// ---- pass 1 -----------------------------------------------------------------------
constexpr int kCrossWarps = 4;

template <int L>
struct CrossingWarp {
  LatticeTriangle tri[32];                // the batch's triangles
  LeafCrossings crossings[32];            // and their crossings with the leaf's rays
  int32_t u0[32], nu[32], w0[32], nw[32]; // their ray ranges, leaf-relative
  int8_t spanU0[32][L];                   // per (pair, ray line w): first hit ray, leaf-relative
  uint8_t spanN[32][L];                   // and the number of hit rays
  uint32_t masks[L * L];                  // XOR of before-masks per row
  uint32_t parity[rowWordsFor(L)];        // one bit per row
  WarpSlots slots;
};

// The crossings of one task along AXIS, in three warp-wide steps that follow
// the CPU driver's loops (forEachCrossing; same calls):
//   1. one lane per pair: the triangle, its ray ranges in the leaf and its
//      crossings with the leaf's rays as an affine function (LeafCrossings);
//   2. one lane per (pair, ray line w): raySpanAtW, the rays that hit;
//   3. one lane per hit ray: crossingInLeaf (two products, no division),
//      XORed into the row's parity bit
//      and before-mask in shared memory (XOR commutes: scheduling cannot show).
template <int L, int AXIS, bool MASKS>
__device__ __forceinline__ void crossingsAlong(const LeafArgs& a, const LeafTask& task, const int64_t (&v0)[3],
                                               CrossingWarp<L>& sh) {
  constexpr int U = rayAxisU(AXIS), W = rayAxisW(AXIS);
  const int lane = threadIdx.x & 31;
  const uint32_t p1 = task.end;
  for (uint32_t base = task.first; base < p1; base += 32) {
    const int nb = int(min(32u, p1 - base));
    __syncwarp(); // the previous batch is resolved
    if (lane < nb) {
      const LatticeTriangle t = a.tris[a.pairTri[base + lane]];
      int64_t u0, u1, w0, w1;
      const bool any = pairRayRange(t, AXIS, v0, L, u0, u1, w0, w1);
      sh.tri[lane] = t;
      makeLeafCrossings(t, AXIS, v0, L, sh.crossings[lane]);
      sh.u0[lane] = any ? int32_t(u0 - v0[U]) : 0;
      sh.w0[lane] = any ? int32_t(w0 - v0[W]) : 0;
      sh.nu[lane] = any ? int32_t(u1 - u0 + 1) : 0;
      sh.nw[lane] = any ? int32_t(w1 - w0 + 1) : 0;
    }
    __syncwarp();
    warpForEachPairItem(
        0, nb, sh.slots, [&](uint32_t j) { return sh.nw[j]; },
        [&](uint32_t j, int k) {
          const int64_t w = v0[W] + sh.w0[j] + k;
          int64_t f = v0[U] + sh.u0[j], l = f + sh.nu[j] - 1;
          raySpanAtW(sh.tri[j], AXIS, w, f, l);
          int df, dl;
          leafLineRays(sh.crossings[j], v0, AXIS, w, f, l, df, dl);
          sh.spanU0[j][k] = int8_t(df <= dl ? df : 0);
          sh.spanN[j][k] = uint8_t(df <= dl ? dl - df + 1 : 0);
        });
    __syncwarp();
    warpForEachPairItem(
        0, uint32_t(nb) * L, sh.slots,
        [&](uint32_t e) { return int(e % L) < sh.nw[e / L] ? int(sh.spanN[e / L][e % L]) : 0; },
        [&](uint32_t e, int r) {
          const uint32_t j = e / L, k = e % L;
          const int u = sh.spanU0[j][k] + r, w = sh.w0[j] + int(k);
          int before;
          if (crossingInLeaf(sh.crossings[j], u, w, L, before)) {
            const int row = u + L * w;
            atomicXor(&sh.parity[row >> 5], 1u << (row & 31));
            if (MASKS) atomicXor(&sh.masks[row], maskBeforeCrossing(before));
          }
        });
  }
}

// Per task and axis: parity[a] (when given) and, when MASKS, masks[a]. The
// parts of a split leaf XOR theirs into zeroed outputs (XOR commutes).
template <int L, int AXIS, bool MASKS>
__device__ __forceinline__ void leafCrossingsAxis(const LeafArgs& a, const LeafTask& task, const int64_t (&v0)[3],
                                                  CrossingWarp<L>& sh, uint32_t* parity, uint32_t* masks) {
  constexpr int RW = rowWordsFor(L);
  const int lane = threadIdx.x & 31;
  const bool split = task.flags & kTaskSplit;
  const size_t leaf = task.leaf;
  __syncwarp();
  for (int i = lane; i < RW; i += 32) sh.parity[i] = 0;
  if (MASKS)
    for (int r = lane; r < L * L; r += 32) sh.masks[r] = 0;
  crossingsAlong<L, AXIS, MASKS>(a, task, v0, sh);
  __syncwarp();
  if (parity) {
    for (int i = lane; i < RW; i += 32) {
      if (!split) parity[leaf * RW + i] = sh.parity[i];
      else if (sh.parity[i]) atomicXor(&parity[leaf * RW + i], sh.parity[i]);
    }
  }
  if (MASKS) {
    for (int r = lane; r < L * L; r += 32) {
      if (!split) masks[leaf * L * L + r] = sh.masks[r];
      else if (sh.masks[r]) atomicXor(&masks[leaf * L * L + r], sh.masks[r]);
    }
  }
}

// One launch per axis: the three axes in one kernel made it too large for
// the instruction cache (ncu: warps stalled on instruction fetch).
template <int L, int AXIS, bool MASKS>
__global__ void __launch_bounds__(32 * kCrossWarps) leafCrossingsKernel(LeafArgs a, uint32_t* parity, uint32_t* masks) {
  __shared__ CrossingWarp<L> shared[kCrossWarps];
  const int warp = threadIdx.x >> 5;
  const uint32_t t = blockIdx.x * kCrossWarps + warp;
  if (t >= *a.taskCount) return; // warp-uniform
  const LeafTask task = a.tasks[t];
  int64_t v0[3];
  leafOrigin(a.leafCoord[task.leaf], L, v0);
  leafCrossingsAxis<L, AXIS, MASKS>(a, task, v0, shared[warp], parity, masks);
}

// ---- lines ----------------------------------------------------------------------------
__global__ void lineKeysKernel(uint32_t n, const uint64_t* coord, int axis, LineKeys lk, uint64_t* keys,
                               uint32_t* leafOf) {
  const uint32_t i = blockIdx.x * blockDim.x + threadIdx.x;
  if (i >= n) return;
  keys[i] = lk.ofLeaf(coord[i], axis);
  leafOf[i] = i;
}

// Inclusive XOR scan over a warp's lanes: toward lower lanes, the XOR of
// lanes `bound`..lane (shuffle up); toward higher lanes, of lanes lane..`bound`
// (shuffle down). Lanes outside the range take no part in a lane's result.
template <bool kTowardLowerLanes>
__device__ __forceinline__ uint32_t warpXorScan(uint32_t value, int lane, int bound) {
#pragma unroll
  for (int o = 1; o < 32; o <<= 1) {
    const uint32_t x = kTowardLowerLanes ? __shfl_up_sync(kFullMask, value, o) : __shfl_down_sync(kFullMask, value, o);
    if (kTowardLowerLanes ? lane - o >= bound : lane + o <= bound) value ^= x;
  }
  return value;
}

// One warp per window of 32 sorted positions; each line is finished by the
// warp whose window holds its last leaf. All the lines that end in the window
// are done at once: per parity word, one segmented suffix XOR over the lanes
// (a segment runs up to the next line end), so a window with many short lines
// costs one pass, not one pass a line (what bounds the kernel is its random
// parity accesses, not this: bench/results/gpu-notes.md, change 28). Only
// the window's first line can begin in an earlier window; the warp walks
// that one back, 32 leaves a step, with the XOR of its leaves in this window
// as the carry. The positions after the window's last line end belong to a
// line that a later warp finishes.
template <int L>
__device__ __forceinline__ void lineSuffixWalkBack(int64_t top, uint64_t lineKey, const uint64_t* keys,
                                                   const uint32_t* leafOf, LineKeys lk, uint32_t (&carry)[rowWordsFor(L)],
                                                   uint32_t* parity, uint8_t* entry) {
  constexpr int RW = rowWordsFor(L);
  const int lane = threadIdx.x & 31;
  for (;; top -= 32) {
    const int64_t idx = top - lane; // lane 0 is the farthest along the ray
    const bool valid = idx >= 0 && lk.sameLine(keys[idx], lineKey);
    const uint32_t leaf = valid ? leafOf[idx] : 0;
    uint32_t v[RW]; // loaded before any store, as below
#pragma unroll
    for (int k = 0; k < RW; ++k) v[k] = valid ? parity[size_t(leaf) * RW + k] : 0u;
#pragma unroll
    for (int k = 0; k < RW; ++k) {
      const uint32_t incl = warpXorScan<true>(v[k], lane, 0); // XOR of this leaf and those beyond it in the step
      if (valid) {
        parity[size_t(leaf) * RW + k] = carry[k] ^ incl ^ v[k]; // exit: beyond the leaf
        if (k == 0) entry[leaf] = uint8_t((carry[0] ^ incl) & 1u);
      }
      carry[k] ^= __shfl_sync(kFullMask, incl, 31);
    }
    if (!__all_sync(kFullMask, valid)) break; // passed the line's first leaf
  }
}

template <int L>
__global__ void lineSuffixKernel(uint32_t n, const uint64_t* keys, const uint32_t* leafOf, LineKeys lk,
                                 uint32_t* parity, uint8_t* entry) {
  constexpr int RW = rowWordsFor(L);
  const int lane = threadIdx.x & 31;
  const uint64_t window = (uint64_t(blockIdx.x) * blockDim.x + threadIdx.x) >> 5;
  const uint64_t pos = window * 32 + lane;
  const bool inRange = pos < n;
  const uint64_t key = inRange ? keys[pos] : 0;
  const bool isEnd = inRange && (pos + 1 == n || !lk.sameLine(keys[pos + 1], key));
  const unsigned ends = __ballot_sync(kFullMask, isEnd);
  if (ends == 0) return; // warp-uniform: the whole window is inside a line that ends later
  // This lane's segment ends at the first line end at or after it; lanes past
  // the last end belong to a later warp's line.
  const unsigned endsFromHere = ends & ~((1u << lane) - 1u);
  const bool owned = endsFromHere != 0;
  const int segmentEnd = owned ? __ffs(endsFromHere) - 1 : 31;
  const uint32_t leaf = owned ? leafOf[pos] : 0;
  // The first segment continues before the window when the line does.
  const bool walkBack = window > 0 && lk.sameLine(keys[window * 32 - 1], keys[window * 32]);
  // All of the leaf's words are loaded before any is stored: the stores
  // would otherwise keep each load waiting for the previous word's (the
  // compiler cannot tell the leaves apart).
  uint32_t v[RW], carry[RW];
#pragma unroll
  for (int k = 0; k < RW; ++k) v[k] = owned ? parity[size_t(leaf) * RW + k] : 0u;
#pragma unroll
  for (int k = 0; k < RW; ++k) {
    const uint32_t incl = warpXorScan<false>(v[k], lane, segmentEnd); // XOR of this leaf and the later ones of its segment
    if (owned) {
      parity[size_t(leaf) * RW + k] = incl ^ v[k]; // exit: beyond the leaf (the line ends in this window)
      if (k == 0) entry[leaf] = uint8_t(incl & 1u);
    }
    carry[k] = __shfl_sync(kFullMask, incl, 0); // the first segment's XOR in this window
  }
  if (walkBack) lineSuffixWalkBack<L>(int64_t(window * 32) - 1, __shfl_sync(kFullMask, key, 0), keys, leafOf, lk, carry,
                                      parity, entry);
}

// ---- pass 2 -----------------------------------------------------------------------------
// Closed meshes: one thread per 8 leaf words (one 32-byte sector, two 16-byte
// accesses), inside = exit parity of the row XOR the row's mask. T3 left
// plane 0 = the mask where not surface, which is already the answer for rows
// with exit parity 0: only sectors holding a row with exit parity 1 are read
// and, when they change, rewritten whole (about half the leaf words on the
// shared meshes). A sector a thread beat a 16-byte quad a thread
// (bench/results/gpu-notes.md).
template <int L>
__global__ void leafInsideClosedKernel(uint64_t sectorCount, const uint32_t* exitParity, uint4* words) {
  constexpr int RW = rowWordsFor(L);
  constexpr uint32_t kSectors = leafWordCount(L) / 8; // a leaf is 4, 32 or 256 sectors
  const uint64_t g = uint64_t(blockIdx.x) * blockDim.x + threadIdx.x;
  if (g >= sectorCount) return;
  const uint64_t leaf = g / kSectors;
  const int w = int(g % kSectors) * 8;
  // The sector's rows lie in one word of row bits (firstRowOfWord), and the
  // flips are kept as plane-0 fields: one load, a few operations a word.
  const uint32_t rows = exitParity[leaf * RW + (firstRowOfWord(L, w) >> 5)];
  uint32_t flip[8];
  uint32_t any = 0;
#pragma unroll
  for (int k = 0; k < 8; ++k) any |= flip[k] = exitFieldsOfWord(rows, L, w + k);
  if (!any) return; // all eight words are final
  const uint4 a = words[2 * g], b = words[2 * g + 1];
  auto update = [&](uint32_t word, int k) { return classifiedWordFields(word, flip[k]); };
  const uint4 na = make_uint4(update(a.x, 0), update(a.y, 1), update(a.z, 2), update(a.w, 3));
  const uint4 nb = make_uint4(update(b.x, 4), update(b.y, 5), update(b.z, 6), update(b.w, 7));
  if (na.x != a.x || na.y != a.y || na.z != a.z || na.w != a.w || nb.x != b.x || nb.y != b.y || nb.z != b.z ||
      nb.w != b.w) {
    words[2 * g] = na;
    words[2 * g + 1] = nb;
  }
}

// Open meshes: one warp per leaf; the majority of the three axes per voxel.
// Axis a's rows run along a, row (u, w) = u + L w with (u, w) the cyclic
// other axes: voxel (x, y, z) is bit x of x-row y + L z, bit y of y-row
// z + L x and bit z of z-row x + L y. The y and z rows are turned into x
// rows by bit-matrix transposes: the y-rows of slice z, indexed by x, form
// an L x L bit matrix whose transpose, indexed by y, holds the x rows
// (y, z); the z-rows of height y likewise (xRowsOfAxisMatrix, shared with
// the CPU driver). One lane transposes one matrix in registers, then the vote
// is three bitwise operations per word.
constexpr int kOpenWarps = 2;

template <int L>
struct OpenWarp {
  uint32_t m1[L * L], m2[L * L]; // y rows and z rows with their exit parity applied
  uint32_t t1[L * L], t2[L * L]; // the same as x rows (y + L z)
  uint32_t e[3][rowWordsFor(L)];
};

template <int L>
__global__ void __launch_bounds__(32 * kOpenWarps) leafInsideOpenKernel(uint32_t leafCount, const uint32_t* e0,
                                                                        const uint32_t* e1, const uint32_t* e2,
                                                                        const uint32_t* m1, const uint32_t* m2,
                                                                        uint32_t* words) {
  constexpr int RW = rowWordsFor(L);
  __shared__ OpenWarp<L> shared[kOpenWarps];
  const int warp = threadIdx.x >> 5, lane = threadIdx.x & 31;
  const uint32_t leaf = blockIdx.x * kOpenWarps + warp;
  if (leaf >= leafCount) return; // warp-uniform
  OpenWarp<L>& sh = shared[warp];
  for (int i = lane; i < RW; i += 32) {
    sh.e[0][i] = e0[size_t(leaf) * RW + i];
    sh.e[1][i] = e1[size_t(leaf) * RW + i];
    sh.e[2][i] = e2[size_t(leaf) * RW + i];
  }
  __syncwarp();
  for (int r = lane; r < L * L; r += 32) {
    sh.m1[r] = m1[size_t(leaf) * L * L + r] ^ exitRowMask(sh.e[1], r, L);
    sh.m2[r] = m2[size_t(leaf) * L * L + r] ^ exitRowMask(sh.e[2], r, L);
  }
  __syncwarp();
  for (int task = lane; task < 2 * L; task += 32) // one lane a matrix (xRowsOfAxisMatrix)
    xRowsOfAxisMatrix<L>(task < L ? 1 : 2, task % L, task < L ? sh.m1 : sh.m2, task < L ? sh.t1 : sh.t2);
  __syncwarp();
  uint32_t* out = leafWordsAt(words, leaf, L);
  for (int w = lane; w < int(leafWordCount(L)); w += 32) {
    out[w] = classifiedWord(out[w], rowBitsToWordBits(sh.e[0], L, w), wordBitsFromRows(sh.t1, L, w),
                            wordBitsFromRows(sh.t2, L, w));
  }
}

// ---- uniform elements -------------------------------------------------------------------
struct LineView {
  const uint64_t* key;
  const uint32_t* leaf;
  const uint8_t* entry;
};

__global__ void uniformKernel(uint32_t count, ElementWord* words, const uint64_t* coords, uint64_t leavesPerElement,
                              uint64_t leavesPerAxis, LineKeys lk, int axes, LineView t0, LineView t1, LineView t2,
                              uint32_t leafCount) {
  const uint32_t j = blockIdx.x * blockDim.x + threadIdx.x;
  if (j >= count || elementState(words[j]) != ElementState::Empty) return;
  const uint64_t c = coords[j];
  const LineView tables[3] = {t0, t1, t2};
  int votes = 0;
  for (int axis = 0; axis < axes; ++axis) {
    uint64_t key;
    if (!uniformLineKey(lk, c, leavesPerElement, leavesPerAxis, axis, key)) continue; // nothing beyond: parity 0
    const LineView& t = tables[axis];
    uint32_t lo = 0, hi = leafCount; // lower_bound
    while (lo < hi) {
      const uint32_t mid = (lo + hi) >> 1;
      if (t.key[mid] < key) lo = mid + 1; else hi = mid;
    }
    if (lo < leafCount && lk.sameLine(t.key[lo], key)) votes += t.entry[t.leaf[lo]];
  }
  if (majorityInside(votes, axes)) words[j] = makeElement(ElementState::Full, 0);
}

template <int L, int AXIS>
void launchCrossingsAxis(const LeafArgs& a, uint32_t taskBound, uint32_t* parity, uint32_t* masks, cudaStream_t s) {
  const unsigned blocks = blocksFor(taskBound, kCrossWarps), threads = 32 * kCrossWarps;
  if (masks)
    leafCrossingsKernel<L, AXIS, true><<<blocks, threads, 0, s>>>(a, parity, masks);
  else
    leafCrossingsKernel<L, AXIS, false><<<blocks, threads, 0, s>>>(a, parity, nullptr);
  HDT_CUDA_CHECK_LAUNCH("leafCrossingsKernel");
}

template <int L>
void launchCrossings(const LeafArgs& a, uint32_t bound, int firstAxis, int axes, uint32_t* const parity[3],
                     uint32_t* const masks[3], cudaStream_t s) {
  if (firstAxis == 0) launchCrossingsAxis<L, 0>(a, bound, parity[0], masks[0], s);
  if (axes == 3) {
    launchCrossingsAxis<L, 1>(a, bound, parity[1], masks[1], s);
    launchCrossingsAxis<L, 2>(a, bound, parity[2], masks[2], s);
  }
}

template <int L>
void launchInside(uint32_t leafCount, int axes, const uint32_t* const e[3], const uint32_t* const masks[3],
                  uint32_t* words, cudaStream_t s) {
  if (axes == 1) {
    const uint64_t n = uint64_t(leafCount) * leafWordCount(L) / 8; // leaves are 32-byte aligned
    leafInsideClosedKernel<L><<<blocksFor(n, 256), 256, 0, s>>>(n, e[0], reinterpret_cast<uint4*>(words));
  } else {
    leafInsideOpenKernel<L><<<blocksFor(leafCount, kOpenWarps), 32 * kOpenWarps, 0, s>>>(leafCount, e[0], e[1], e[2],
                                                                                        masks[1], masks[2], words);
  }
  HDT_CUDA_CHECK_LAUNCH("leafInsideKernel");
}

template <int L>
void launchSuffix(uint32_t n, const uint64_t* keys, const uint32_t* leafOf, LineKeys lk, uint32_t* parity,
                  uint8_t* entry, cudaStream_t s) {
  const unsigned block = 128;
  lineSuffixKernel<L><<<blocksFor(uint64_t(blocksFor(n, 32)) * 32, block), block, 0, s>>>(n, keys, leafOf, lk, parity,
                                                                                          entry);
  HDT_CUDA_CHECK_LAUNCH("lineSuffixKernel");
}

} // namespace

void leafCrossings(DeviceMemory& mem, const DeviceMesh& mesh, const GridSpec& grid, const Leaves& leaves,
                   int firstAxis, int axes, uint32_t* const parity[3], uint32_t* const masks[3]) {
  if (leaves.count == 0 || firstAxis >= axes) return;
  // Split leaves merge with XOR: their parity and masks start from zero.
  const int L = grid.leafSize;
  for (int a = firstAxis; a < axes; ++a) {
    if (parity[a]) zeroSplitLeaves(mem, leaves, parity[a], uint32_t(rowWordsFor(L)));
    if (masks[a]) zeroSplitLeaves(mem, leaves, masks[a], uint32_t(L * L));
  }
  const LeafArgs a = leafArgs(mesh, grid, leaves);
  const uint32_t bound = leaves.taskBound;
  switch (L) {
  case 8: launchCrossings<8>(a, bound, firstAxis, axes, parity, masks, mem.stream()); break;
  case 16: launchCrossings<16>(a, bound, firstAxis, axes, parity, masks, mem.stream()); break;
  default: launchCrossings<32>(a, bound, firstAxis, axes, parity, masks, mem.stream()); break;
  }
}

LineTable lineParity(DeviceMemory& mem, const GridSpec& grid, const Leaves& leaves, int axis, uint32_t* parity) {
  const cudaStream_t s = mem.stream();
  const uint32_t n = leaves.count;
  const LineKeys lk = lineKeysFor(grid);
  LineTable t;
  t.key = DeviceBuffer<uint64_t>(mem, n);
  t.leaf = DeviceBuffer<uint32_t>(mem, n);
  t.entry = DeviceBuffer<uint8_t>(mem, n);
  if (n == 0) return t;
  lineKeysKernel<<<blocksFor(n, 256), 256, 0, s>>>(n, leaves.coord.data(), axis, lk, t.key.data(), t.leaf.data());
  HDT_CUDA_CHECK_LAUNCH("lineKeysKernel");
  sortPairs(mem, t.key, t.leaf, n, 3 * lk.bits);
  switch (grid.leafSize) {
  case 8: launchSuffix<8>(n, t.key.data(), t.leaf.data(), lk, parity, t.entry.data(), s); break;
  case 16: launchSuffix<16>(n, t.key.data(), t.leaf.data(), lk, parity, t.entry.data(), s); break;
  default: launchSuffix<32>(n, t.key.data(), t.leaf.data(), lk, parity, t.entry.data(), s); break;
  }
  return t;
}

void writeLeafInside(DeviceMemory& mem, const GridSpec& grid, const Leaves& leaves, int axes,
                     const uint32_t* const exitParity[3], const uint32_t* const masks[3], uint32_t* words) {
  if (leaves.count == 0) return;
  switch (grid.leafSize) {
  case 8: launchInside<8>(leaves.count, axes, exitParity, masks, words, mem.stream()); break;
  case 16: launchInside<16>(leaves.count, axes, exitParity, masks, words, mem.stream()); break;
  default: launchInside<32>(leaves.count, axes, exitParity, masks, words, mem.stream()); break;
  }
}

void classifyUniform(DeviceMemory& mem, const GridSpec& grid, int level, Level& lv, int axes,
                     const LineTable* const tables[3], uint32_t leafCount) {
  if (lv.count == 0) return;
  const uint64_t leavesPerElement = uint64_t(grid.elementVoxels(level)) / uint64_t(grid.leafSize);
  const uint64_t leavesPerAxis = uint64_t(grid.resolution / grid.leafSize);
  LineView v[3] = {};
  for (int a = 0; a < axes; ++a) v[a] = LineView{tables[a]->key.data(), tables[a]->leaf.data(), tables[a]->entry.data()};
  uniformKernel<<<blocksFor(lv.count, 256), 256, 0, mem.stream()>>>(lv.count, lv.words.data(), lv.coords.data(),
                                                                   leavesPerElement, leavesPerAxis,
                                                                   lineKeysFor(grid), axes, v[0], v[1], v[2],
                                                                   leafCount);
  HDT_CUDA_CHECK_LAUNCH("uniformKernel");
}

} // namespace cuda
} // namespace hdt
