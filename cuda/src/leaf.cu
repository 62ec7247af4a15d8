// T3: the surface voxels of every leaf grid.
//
// One warp per leaf. The leaf's row masks (one L-bit mask per row y + L z)
// live in the warp's slice of shared memory; the warp shares out the leaf's
// (triangle, z-slice) items (warpForEachPairItem), and each item clips the
// slice's rows with the triangle's row-interval clipper (build_steps.hpp:
// clipRowsOfSlice, clipRow, rowBits; the same calls and the same order of
// narrowing as the CPU driver) and ORs the row bits in with shared-memory
// atomics (OR commutes: the result does not depend on scheduling). Finally
// the warp writes every word of the leaf exactly once, coalesced: no global
// atomics, no read-modify-write, no zero fill beforehand.
#include "device_common.cuh"
#include "phases.hpp"

#include "hdt/build_steps.hpp"

namespace hdt {
namespace cuda {
namespace {

constexpr int kWarpsPerBlock = 4;

struct LeafArgs {
  const LatticeTriangle* tris;
  const uint64_t* leafCoord;
  const uint32_t* pairStart;
  const uint32_t* pairTri;
  uint32_t leafCount;
  int64_t resolution;
};

// Voxel ranges of triangle t clamped to the leaf at v0: the CPU driver's
// cellRange on the voxel lattice, then the leaf's extent.
template <int L>
__device__ __forceinline__ void leafVoxelRanges(const LatticeTriangle& t, const int64_t (&v0)[3], int64_t res,
                                                int64_t (&first)[3], int64_t (&last)[3]) {
  int64_t lo[3], hi[3];
  triangleBounds(t, lo, hi);
#pragma unroll
  for (int a = 0; a < 3; ++a) {
    cellRange(lo[a], hi[a], kLatticePerVoxel, res, first[a], last[a]);
    if (first[a] < v0[a]) first[a] = v0[a];
    if (last[a] > v0[a] + L - 1) last[a] = v0[a] + L - 1;
  }
}

template <int L>
__global__ void __launch_bounds__(32 * kWarpsPerBlock) leafSurfaceKernel(LeafArgs a, uint32_t* words) {
  __shared__ uint32_t shared[kWarpsPerBlock][L * L];
  const int warp = threadIdx.x >> 5, lane = threadIdx.x & 31;
  const uint32_t leaf = blockIdx.x * kWarpsPerBlock + warp;
  if (leaf >= a.leafCount) return; // warp-uniform
  uint32_t* rows = shared[warp];
  for (int r = lane; r < L * L; r += 32) rows[r] = 0;
  __syncwarp();

  const uint64_t c = a.leafCoord[leaf];
  const int64_t v0[3] = {int64_t(unpackCoord(c, 0)) * L, int64_t(unpackCoord(c, 1)) * L,
                         int64_t(unpackCoord(c, 2)) * L};
  warpForEachPairItem(
      a.pairStart[leaf], a.pairStart[leaf + 1],
      [&](uint32_t p) { // items: the z slices of the triangle's box in the leaf
        int64_t first[3], last[3];
        leafVoxelRanges<L>(a.tris[a.pairTri[p]], v0, a.resolution, first, last);
        return last[2] >= first[2] ? int(last[2] - first[2] + 1) : 0;
      },
      [&](uint32_t p, int k) {
        const LatticeTriangle t = a.tris[a.pairTri[p]];
        int64_t first[3], last[3];
        leafVoxelRanges<L>(t, v0, a.resolution, first, last);
        RowClipper clipper;
        makeRowClipper(t, clipper);
        const int64_t z = first[2] + k;
        int64_t y0 = first[1], y1 = last[1];
        clipRowsOfSlice(clipper, z, y0, y1);
        for (int64_t y = y0; y <= y1; ++y) {
          int64_t f = first[0], l = last[0];
          clipRow(clipper, y, z, f, l);
          const uint32_t bits = rowBits(v0[0], f, l);
          if (bits) atomicOr(&rows[(y - v0[1]) + L * (z - v0[2])], bits);
        }
      });
  __syncwarp();

  uint32_t* out = words + size_t(leaf) * leafWordCount(L);
  for (int w = lane; w < int(leafWordCount(L)); w += 32) out[w] = spreadBits16(wordBitsFromRows<L>(rows, w)) << 1;
}

template <int L>
void launchLeafSurface(const LeafArgs& a, uint32_t* words, cudaStream_t s) {
  leafSurfaceKernel<L><<<blocksFor(a.leafCount, kWarpsPerBlock), 32 * kWarpsPerBlock, 0, s>>>(a, words);
  HDT_CUDA_CHECK_LAUNCH("leafSurfaceKernel");
}

} // namespace

void writeLeafSurfaces(DeviceMemory& mem, const DeviceMesh& mesh, const GridSpec& grid, const Leaves& leaves,
                       uint32_t* words) {
  if (leaves.count == 0) return;
  const LeafArgs a{mesh.triangles, leaves.coord.data(), leaves.pairStart.data(), leaves.triangle.data(),
                   leaves.count, grid.resolution};
  switch (grid.leafSize) {
  case 8: launchLeafSurface<8>(a, words, mem.stream()); break;
  case 16: launchLeafSurface<16>(a, words, mem.stream()); break;
  case 32: launchLeafSurface<32>(a, words, mem.stream()); break;
  default: throw Error(ErrorKind::InvalidArgument, "leaf size must be 8, 16 or 32");
  }
}

} // namespace cuda
} // namespace hdt
