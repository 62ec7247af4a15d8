// T3: the surface voxels of every leaf grid, and for solid builds
// classification pass 1 along x in the same kernel.
//
// One warp per group of consecutive leaf tasks (a task is a leaf, or a part
// of a leaf with very many pairs: LeafTask); each leaf's words are built in
// the warp's slice of shared memory. What depends on a triangle
// and a slice but not on the leaf was evaluated once per triangle
// (TriangleTables); the warp clamps table entries to each pair's leaf and
// does the per-row work, in warp-wide steps over the pairs of all its leaves
// that follow the CPU driver's loops (build_steps.hpp; same calls, same
// narrowing):
//   1. one lane per pair: the triangle's row axis and voxel box (its setup)
//      clamped to the pair's leaf;
//   2. one lane per (pair, k): slice z = k's rows and x span, and row height
//      y = k's x span, from the tables (sliceSpans, columnSpan);
//   3. one lane per (pair, row): the two spans intersected, clipRowByPlane,
//      the run ORed into plane 1 of the leaf's words (forEachXRowRunOf) with
//      shared-memory atomics (OR commutes: scheduling cannot show).
// Flattening to rows keeps all 32 lanes busy however unevenly the triangles
// cover the leaves, and a row costs only its plane step.
//
// With CROSS (solid builds), the warp then runs pass 1 along x on the same
// pairs (docs/design.md, "Classification"; the steps of build_steps.hpp):
// one lane per pair for its LeafCrossings, one lane per (pair, ray line) for
// the hit rays from the line table (raySpanAtW's results), one lane per hit
// ray for the crossing; the row parities and the "voxels before" runs are
// XORed in shared memory, the runs into plane 0 of the same leaf words.
// Finally the warp writes every word of its leaves exactly once, coalesced,
// as it stands (plane 0 cleared under the surface): no global atomics, no
// read-modify-write, no zero fill beforehand (the parts of a split leaf
// merge into zeroed words instead: OR for the surface, XOR for the masks,
// each on its own plane).
#include "device_common.cuh"
#include "phases.hpp"

#include "hdt/build_steps.hpp"

namespace hdt {
namespace cuda {
namespace {

// Tasks (leaves) a warp takes at once. Most leaves have one or two pairs:
// a warp with one leaf ran its per-pair steps with a lane or two busy and
// ended every item loop with a part-filled round. With four leaves the
// pairs of all four share the steps (1 for L = 32, whose words are 8x
// larger). The sizes below were chosen by measurement:
// bench/results/gpu-notes.md ("T3 kernel shape").
#ifndef HDT_CUDA_T3_LEAVES
#define HDT_CUDA_T3_LEAVES 4
#endif
template <int L>
constexpr int leavesPerWarp() {
  return L == 32 ? 1 : HDT_CUDA_T3_LEAVES;
}
// 4 warps a block (2 for L = 32); 10 blocks of 4 warps per SM cap registers
// at 48 (and fill the shared memory: 22 KB a block for L = 16).
template <int L>
constexpr int warpsPerBlock() {
  return L == 32 ? 2 : 4;
}
#ifndef HDT_CUDA_T3_MIN_BLOCKS
#define HDT_CUDA_T3_MIN_BLOCKS 10
#endif

// Pairs a warp holds in shared memory at once (a warp's leaves have a few
// pairs each on the CAD parts).
#ifndef HDT_CUDA_T3_BATCH
#define HDT_CUDA_T3_BATCH 8
#endif
template <int L>
constexpr int batchPairs() {
  return L == 32 ? 8 : HDT_CUDA_T3_BATCH;
}

// A leaf's words are built in shared memory as they will be stored: the
// voxels [lo, hi] of x row `row` (a row is half a word, one word or two) get
// plane `PLANE` set by OR (the surface, plane 1) or flipped by XOR (the
// before-masks, plane 0), one shared atomic a word: no row mask to spread,
// and the words go out as they are (writeLeaf).
template <int L, int PLANE>
__device__ __forceinline__ void runIntoWords(uint32_t* words, int row, int lo, int hi) {
  auto apply = [&](int w, uint32_t bits) {
    if (PLANE == kInsidePlane) atomicXor(&words[w], bits);
    else atomicOr(&words[w], bits << 1);
  };
  if (L == 16) {
    apply(row, fieldRangeBits(lo, hi));
  } else if (L == 8) {
    const int o = (row & 1) * 8;
    apply(row >> 1, fieldRangeBits(lo + o, hi + o));
  } else { // L == 32: words 2 row (x < 16) and 2 row + 1
    if (lo < 16) apply(2 * row, fieldRangeBits(lo, min(hi, 15)));
    if (hi >= 16) apply(2 * row + 1, fieldRangeBits(max(lo, 16) - 16, hi - 16));
  }
}

template <int L>
struct SurfacePairs { // leaf-relative, in each pair's row-axis frame
  static constexpr int B = batchPairs<L>();
  uint32_t setup[B];                    // table index of the pair's triangle
  uint64_t slice[B], height[B];         // table entries of the leaf's first slice and row height
  int32_t baseX[B], baseY[B];           // the triangle box's first x and y
  int8_t leaf[B]; // the pair's leaf among the warp's (0 .. leavesPerWarp - 1)
  int8_t axis[B], x0[B], x1[B], y0[B], y1[B], z0[B], nz[B];
  int8_t sliceY0[B][L]; // rows of each slice that can meet the triangle
  uint8_t sliceRows[B][L];
  int8_t sliceX0[B][L], sliceX1[B][L];   // x span of each slice
  int8_t columnX0[B][L], columnX1[B][L]; // x span of each row height
};

template <int L>
struct CrossPairs { // x rays: u = y, w = z, leaf-relative
  static constexpr int B = batchPairs<L>();
  LeafCrossings crossings[B];
  uint64_t line[B]; // line-table entry of the leaf's first ray line
  int32_t baseU[B];
  int8_t leaf[B], u0[B], u1[B], w0[B], nw[B];
  int8_t spanU0[B][L]; // per (pair, ray line): first hit ray
  uint8_t spanN[B][L]; // and the number of hit rays
};

template <int L, bool CROSS>
struct LeafWarp {
  static constexpr int G = leavesPerWarp<L>();
  union { // the surface steps are done before the crossing steps start
    SurfacePairs<L> s;
    CrossPairs<L> c;
  } p;
  // Each leaf's words: the surface in plane 1 and, with CROSS, the XOR of
  // the before-masks in plane 0.
  alignas(16) uint32_t words[G][leafWordCount(L)];
  uint32_t parity[CROSS ? G : 1][rowWordsFor(L)]; // one bit per x row
  int64_t origin[G][3]; // first voxel of each leaf
  uint32_t end[G];      // end of each leaf's pairs (the leaves' pairs are consecutive)
  WarpSlots slots;
};

struct LeafKernelArgs {
  LeafArgs a;
  const uint32_t* compactOf; // mesh triangle -> table index
  const TriangleSetup* setup;
  const uint64_t *sliceStart, *heightStart, *lineStart;
  const uint2* slices;
  const uint32_t *heights, *lines;
  uint32_t* words;
  uint32_t* parity; // CROSS: row parities along x, or null
};

// The warp's pairs [first, end) a batch at a time, once the previous batch is
// done with the warp's shared arrays: batch(nb, g, j) on every lane, where
// lanes < nb hold a pair, g its leaf (0 .. n - 1) and j its table index.
template <int L, bool CROSS, class Batch>
__device__ __forceinline__ void forEachBatch(const LeafKernelArgs& k, const LeafWarp<L, CROSS>& sh, uint32_t first,
                                             uint32_t end, int n, Batch&& batch) {
  constexpr int B = batchPairs<L>();
  const int lane = threadIdx.x & 31;
  for (uint32_t base = first; base < end; base += B) {
    const int nb = int(min(uint32_t(B), end - base));
    __syncwarp();
    const uint32_t p = base + lane;
    int g = 0;
#pragma unroll
    for (int i = 0; i + 1 < LeafWarp<L, CROSS>::G; ++i) g += (i + 1 < n && p >= sh.end[i]) ? 1 : 0;
    batch(nb, g, lane < nb ? k.compactOf[k.a.pairTri[p]] : 0u);
  }
}

template <int L, bool CROSS>
__device__ __forceinline__ void surfaceSteps(const LeafKernelArgs& k, uint32_t first, uint32_t end, int n,
                                             LeafWarp<L, CROSS>& w) {
  SurfacePairs<L>& sh = w.p.s;
  const int lane = threadIdx.x & 31;
  forEachBatch(k, w, first, end, n, [&](int nb, int g, uint32_t j) {
    if (lane < nb) {
      const TriangleSetup& ts = k.setup[j];
      const int axis = ts.axis;
      int64_t o[3];
      permutedOrigin(w.origin[g], axis, o);
      int32_t f[3], l[3];
      bool any = true;
      for (int d = 0; d < 3; ++d) {
        f[d] = int32_t(max(int64_t(ts.first[d]), o[d]) - o[d]);
        l[d] = int32_t(min(int64_t(ts.last[d]), o[d] + L - 1) - o[d]);
        any = any && f[d] <= l[d];
      }
      sh.setup[lane] = j;
      sh.leaf[lane] = int8_t(g);
      sh.axis[lane] = int8_t(axis);
      sh.x0[lane] = int8_t(f[0]);
      sh.x1[lane] = int8_t(l[0]);
      sh.y0[lane] = int8_t(f[1]);
      sh.y1[lane] = int8_t(any ? l[1] : f[1] - 1);
      sh.z0[lane] = int8_t(f[2]);
      sh.nz[lane] = int8_t(any ? l[2] - f[2] + 1 : 0);
      sh.baseX[lane] = int32_t(ts.first[0] - o[0]);
      sh.baseY[lane] = int32_t(ts.first[1] - o[1]);
      sh.slice[lane] = k.sliceStart[j] + uint64_t(o[2] + f[2] - ts.first[2]);
      sh.height[lane] = k.heightStart[j] + uint64_t(o[1] + f[1] - ts.first[1]);
    }
    __syncwarp();
    warpForEachPairItem(
        0, nb, w.slots, [&](uint32_t j) { return max(int(sh.nz[j]), sh.y1[j] - sh.y0[j] + 1); },
        [&](uint32_t j, int kk) {
          if (kk < sh.nz[j]) {
            const uint2 e = k.slices[sh.slice[j] + kk];
            int32_t ya, yb, xa, xb;
            unpackSpan(e.x, sh.baseY[j], sh.y0[j], sh.y1[j], ya, yb);
            unpackSpan(e.y, sh.baseX[j], sh.x0[j], sh.x1[j], xa, xb);
            const bool hit = ya <= yb && xa <= xb;
            sh.sliceY0[j][kk] = int8_t(hit ? ya : 0);
            sh.sliceRows[j][kk] = uint8_t(hit ? yb - ya + 1 : 0);
            sh.sliceX0[j][kk] = int8_t(hit ? xa : 1);
            sh.sliceX1[j][kk] = int8_t(hit ? xb : 0);
          }
          if (kk <= sh.y1[j] - sh.y0[j]) {
            int32_t xa, xb;
            unpackSpan(k.heights[sh.height[j] + kk], sh.baseX[j], sh.x0[j], sh.x1[j], xa, xb);
            const int dy = sh.y0[j] + kk;
            sh.columnX0[j][dy] = int8_t(xa > xb ? 1 : xa); // empty kept as 1 > 0
            sh.columnX1[j][dy] = int8_t(xa > xb ? 0 : xb);
          }
        });
    __syncwarp();
    warpForEachPairItem(
        0, uint32_t(nb) * L, w.slots,
        [&](uint32_t e) { return int(e % L) < sh.nz[e / L] ? int(sh.sliceRows[e / L][e % L]) : 0; },
        [&](uint32_t e, int r) {
          const uint32_t j = e / L, s = e % L;
          const int axis = sh.axis[j], leaf = sh.leaf[j];
          int64_t o[3];
          permutedOrigin(w.origin[leaf], axis, o);
          const int dy = sh.sliceY0[j][s] + r, dz = sh.z0[j] + int(s);
          int64_t f = o[0] + max(sh.sliceX0[j][s], sh.columnX0[j][dy]);
          int64_t l = o[0] + min(sh.sliceX1[j][s], sh.columnX1[j][dy]);
          clipRowByPlane(k.setup[sh.setup[j]].plane, o[1] + dy, o[2] + dz, f, l);
          uint32_t* words = w.words[leaf];
          forEachXRowRunOf(axis, L, dy, dz, int(f - o[0]), int(l - o[0]), [&](int row, int lo, int hi) {
            runIntoWords<L, kSurfacePlane>(words, row, lo, hi);
          });
        });
  });
}

// Hit rays a lane takes at once: half the rounds of item bookkeeping, and
// two independent crossings in flight; more leave lanes idle at the ends of
// short lines.
#ifndef HDT_CUDA_RAYS_PER_ITEM
#define HDT_CUDA_RAYS_PER_ITEM 2
#endif
constexpr int kRaysPerItem = HDT_CUDA_RAYS_PER_ITEM;

// Pass 1 along x for the warp's pairs (classify.cu's crossingsAlong with the
// hit spans from the line table).
template <int L>
__device__ __forceinline__ void crossingSteps(const LeafKernelArgs& k, uint32_t first, uint32_t end, int n,
                                              LeafWarp<L, true>& w) {
  constexpr int U = rayAxisU(0), W = rayAxisW(0);
  CrossPairs<L>& sh = w.p.c;
  const int lane = threadIdx.x & 31;
  forEachBatch(k, w, first, end, n, [&](int nb, int g, uint32_t j) {
    if (lane < nb) {
      const TriangleSetup& ts = k.setup[j];
      const int64_t(&v0)[3] = w.origin[g];
      const int64_t u0 = max(int64_t(ts.u0), v0[U]), u1 = min(int64_t(ts.u1), v0[U] + L - 1);
      const int64_t w0 = max(int64_t(ts.w0), v0[W]), w1 = min(int64_t(ts.w1), v0[W] + L - 1);
      const bool any = u0 <= u1 && w0 <= w1;
      if (any) makeLeafCrossings(ts.cross, 0, v0, L, sh.crossings[lane]);
      sh.leaf[lane] = int8_t(g);
      sh.u0[lane] = int8_t(any ? u0 - v0[U] : 0);
      sh.u1[lane] = int8_t(any ? u1 - v0[U] : -1);
      sh.w0[lane] = int8_t(any ? w0 - v0[W] : 0);
      sh.nw[lane] = int8_t(any ? w1 - w0 + 1 : 0);
      sh.baseU[lane] = int32_t(ts.u0 - v0[U]);
      sh.line[lane] = any ? k.lineStart[j] + uint64_t(w0 - ts.w0) : 0;
    }
    __syncwarp();
    warpForEachPairItem(
        0, nb, w.slots, [&](uint32_t j) { return int(sh.nw[j]); },
        [&](uint32_t j, int kk) {
          int32_t f, l; // leaf-relative: leafLineRays' narrowing step only
          unpackSpan(k.lines[sh.line[j] + kk], sh.baseU[j], sh.u0[j], sh.u1[j], f, l);
          narrowToLeafCrossings(sh.crossings[j], sh.w0[j] + int(kk), f, l);
          sh.spanU0[j][kk] = int8_t(f <= l ? f : 0);
          sh.spanN[j][kk] = uint8_t(f <= l ? l - f + 1 : 0);
        });
    __syncwarp();
    warpForEachPairItem(
        0, uint32_t(nb) * L, w.slots,
        [&](uint32_t e) {
          return int(e % L) < sh.nw[e / L] ? (int(sh.spanN[e / L][e % L]) + kRaysPerItem - 1) / kRaysPerItem : 0;
        },
        [&](uint32_t e, int r) {
          const uint32_t j = e / L, kk = e % L;
          const int leaf = sh.leaf[j], wl = sh.w0[j] + int(kk), u0 = sh.spanU0[j][kk], nu = sh.spanN[j][kk];
#pragma unroll
          for (int i = 0; i < kRaysPerItem; ++i) {
            const int u = u0 + kRaysPerItem * r + i;
            int before;
            if (u < u0 + nu && crossingInLeaf(sh.crossings[j], u, wl, L, before)) {
              const int row = u + L * wl;
              atomicXor(&w.parity[leaf][row >> 5], 1u << (row & 31));
              if (before > 0) // the voxels before the crossing
                runIntoWords<L, kInsidePlane>(w.words[leaf], row, 0, before - 1);
            }
          }
        });
  });
}

// Every word of one leaf, once: the surface in plane 1 and, with CROSS, the
// masks in plane 0 where not surface; for rows whose exit parity turns out
// 0 that is the final inside plane, so pass 2 leaves them alone. The parts
// of a split leaf merge into zeroed words instead (OR on plane 1, XOR of
// whole masks on plane 0; clearMasksUnderSurface finishes those).
template <int L, bool CROSS>
__device__ __forceinline__ void writeLeaf(const LeafKernelArgs& k, uint32_t leaf, bool split, const uint32_t* words,
                                          const uint32_t* parity) {
  const int lane = threadIdx.x & 31;
  uint32_t* out = k.words + leafWordOffset(leaf, L); // not leafWordsAt: see types.hpp
  if (!split) { // warp-uniform; 16-byte loads and stores (a leaf is 128, 1024 or 8192 bytes)
    const uint4* in4 = reinterpret_cast<const uint4*>(words);
    uint4* out4 = reinterpret_cast<uint4*>(out);
    for (int q = lane; q < int(leafWordCount(L)) / 4; q += 32) {
      uint4 v = in4[q];
      if (CROSS) {
        v.x = withoutInsideUnderSurface(v.x);
        v.y = withoutInsideUnderSurface(v.y);
        v.z = withoutInsideUnderSurface(v.z);
        v.w = withoutInsideUnderSurface(v.w);
      }
      out4[q] = v;
    }
  } else {
    for (int w = lane; w < int(leafWordCount(L)); w += 32) {
      const uint32_t s = words[w] & kSurfacePlaneBits;
      const uint32_t before = CROSS ? words[w] & kInsidePlaneBits : 0u;
      if (s) atomicOr(&out[w], s);
      if (before) atomicXor(&out[w], before);
    }
  }
  if (CROSS && k.parity) {
    constexpr int RW = rowWordsFor(L);
    uint32_t* p = k.parity + size_t(leaf) * RW;
    for (int i = lane; i < RW; i += 32) {
      if (!split) p[i] = parity[i];
      else if (parity[i]) atomicXor(&p[i], parity[i]);
    }
  }
}

template <int L, bool CROSS>
__global__ void __launch_bounds__(32 * warpsPerBlock<L>(), HDT_CUDA_T3_MIN_BLOCKS * 4 / warpsPerBlock<L>())
    leafKernel(LeafKernelArgs k) {
  constexpr int G = leavesPerWarp<L>();
  __shared__ LeafWarp<L, CROSS> shared[warpsPerBlock<L>()];
  const int warp = threadIdx.x >> 5, lane = threadIdx.x & 31;
  const uint32_t tasks = *k.a.taskCount;
  const uint32_t t0 = (blockIdx.x * warpsPerBlock<L>() + warp) * G;
  if (t0 >= tasks) return; // warp-uniform
  // One group of tasks a warp (a grid-stride loop measured slower:
  // bench/results/gpu-notes.md).
  const int n = int(min(uint32_t(G), tasks - t0));
  LeafWarp<L, CROSS>& sh = shared[warp];
  LeafTask task{}; // lane g < n: the warp's task g
  if (lane < n) {
    task = k.a.tasks[t0 + lane];
    leafOrigin(k.a.leafCoord[task.leaf], L, sh.origin[lane]);
    sh.end[lane] = task.end;
  }
  const uint32_t first = __shfl_sync(kFullMask, task.first, 0), end = __shfl_sync(kFullMask, task.end, n - 1);
  for (int q = lane; q < n * int(leafWordCount(L)) / 4; q += 32) // 16-byte stores
    reinterpret_cast<uint4*>(sh.words)[q] = make_uint4(0, 0, 0, 0);
  if (CROSS)
    for (int i = lane; i < n * rowWordsFor(L); i += 32) (&sh.parity[0][0])[i] = 0;
  surfaceSteps<L, CROSS>(k, first, end, n, sh);
  if constexpr (CROSS) crossingSteps<L>(k, first, end, n, sh);
  __syncwarp();
  for (int g = 0; g < n; ++g) {
    const uint32_t leaf = __shfl_sync(kFullMask, task.leaf, g);
    const bool split = __shfl_sync(kFullMask, task.flags, g) & kTaskSplit;
    writeLeaf<L, CROSS>(k, leaf, split, sh.words[g], sh.parity[CROSS ? g : 0]);
  }
}

// Thread per task, on the first part of each split leaf only: zeroes the
// leaf's outputs before its parts merge into them, and finishes the words
// once they have (plane 0 cleared where plane 1 is set).
struct ZeroWord {
  __device__ uint32_t operator()(uint32_t) const { return 0; }
};
struct ClearMasksUnderSurface {
  __device__ uint32_t operator()(uint32_t w) const { return withoutInsideUnderSurface(w); }
};
template <class Op>
__global__ void splitLeafKernel(const LeafTask* tasks, const uint32_t* taskCount, uint32_t* data, uint32_t perLeaf,
                                Op op) {
  const uint32_t t = blockIdx.x * blockDim.x + threadIdx.x;
  if (t >= *taskCount) return;
  const LeafTask task = tasks[t];
  if (!(task.flags & kTaskFirst)) return;
  uint32_t* d = data + size_t(task.leaf) * perLeaf;
  for (uint32_t i = 0; i < perLeaf; ++i) d[i] = op(d[i]);
}

template <class Op>
void forEachSplitLeaf(DeviceMemory& mem, const Leaves& leaves, uint32_t* data, uint32_t perLeaf, Op op) {
  if (leaves.count == 0) return;
  splitLeafKernel<<<blocksFor(leaves.taskBound, 256), 256, 0, mem.stream()>>>(
      leaves.tasks.data(), leaves.taskCount.data(), data, perLeaf, op);
  HDT_CUDA_CHECK_LAUNCH("splitLeafKernel");
}

template <int L>
void launchLeaf(const LeafKernelArgs& k, uint32_t taskBound, bool crossings, cudaStream_t s) {
  const unsigned blocks = blocksFor(taskBound, warpsPerBlock<L>() * leavesPerWarp<L>());
  const unsigned threads = 32 * warpsPerBlock<L>();
  if (crossings) leafKernel<L, true><<<blocks, threads, 0, s>>>(k);
  else leafKernel<L, false><<<blocks, threads, 0, s>>>(k);
  HDT_CUDA_CHECK_LAUNCH("leafKernel");
}

} // namespace

void zeroSplitLeaves(DeviceMemory& mem, const Leaves& leaves, uint32_t* data, uint32_t perLeaf) {
  forEachSplitLeaf(mem, leaves, data, perLeaf, ZeroWord{});
}

void writeLeafSurfaces(DeviceMemory& mem, HostScalars& scalars, const DeviceMesh& mesh, const GridSpec& grid,
                       const Leaves& leaves, uint32_t* words, bool crossings, uint32_t* parityX) {
  if (leaves.count == 0) return;
  const int L = grid.leafSize;
  if (L != 8 && L != 16 && L != 32) throw Error(ErrorKind::InvalidArgument, "leaf size must be 8, 16 or 32");
  const TriangleTables tables = buildTriangleTables(mem, scalars, mesh, grid, leaves, crossings);
  zeroSplitLeaves(mem, leaves, words, leafWordCount(L));
  if (crossings && parityX) zeroSplitLeaves(mem, leaves, parityX, uint32_t(rowWordsFor(L)));
  const LeafKernelArgs k{leafArgs(mesh, grid, leaves),
                         tables.compactOf.data(),
                         tables.setup.data(),
                         tables.sliceStart.data(),
                         tables.heightStart.data(),
                         tables.lineStart.data(),
                         tables.slices.data(),
                         tables.heights.data(),
                         tables.lines.data(),
                         words,
                         parityX};
  switch (L) {
  case 8: launchLeaf<8>(k, leaves.taskBound, crossings, mem.stream()); break;
  case 16: launchLeaf<16>(k, leaves.taskBound, crossings, mem.stream()); break;
  default: launchLeaf<32>(k, leaves.taskBound, crossings, mem.stream()); break;
  }
  if (crossings) forEachSplitLeaf(mem, leaves, words, leafWordCount(L), ClearMasksUnderSurface{});
}

} // namespace cuda
} // namespace hdt
