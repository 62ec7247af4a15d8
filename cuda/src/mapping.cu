// T1: triangles -> root cells. One thread per triangle: the root cells of its
// bounding box (cellRange), each confirmed by the exact overlap test. A count
// pass and a write pass (same loop) place the pairs in (triangle, cell) order
// without atomics; a stable radix sort on the cell bits alone then gives the
// canonical (cell, triangle) order.
#include "device_common.cuh"
#include "phases.hpp"

#include "hdt/build_steps.hpp"

#include <cub/device/device_reduce.cuh>
#include <cub/device/device_scan.cuh>

#include <cmath>
#include <cstring>

namespace hdt {
namespace cuda {
namespace {

struct RootArgs {
  const LatticeTriangle* tris;
  uint32_t count;
  int64_t R;
  int64_t cellSize; // lattice units
  uint64_t firstCell, endCell;
};

// Calls emit(cell - firstCell) for every root cell of the chunk the triangle
// meets (the drivers' shared T1 loop).
template <class Emit>
__device__ __forceinline__ void forEachRootCell(const RootArgs& a, const LatticeTriangle& t, Emit emit) {
  hdt::forEachRootCell(t, a.cellSize, a.R, a.firstCell, a.endCell, emit);
}

__global__ void rootCountKernel(RootArgs a, uint32_t* counts, float* area) {
  const uint32_t i = blockIdx.x * blockDim.x + threadIdx.x;
  if (i >= a.count) return;
  const LatticeTriangle t = a.tris[i];
  uint32_t n = 0;
  forEachRootCell(a, t, [&](uint32_t) { ++n; });
  counts[i] = n;
  if (area) area[i] = float(triangleArea(t)); // only for the memory estimate: float is plenty
}

__global__ void rootWriteKernel(RootArgs a, const uint32_t* offsets, uint32_t* cells, uint32_t* tris) {
  const uint32_t i = blockIdx.x * blockDim.x + threadIdx.x;
  if (i >= a.count) return;
  uint32_t o = offsets[i];
  forEachRootCell(a, a.tris[i], [&](uint32_t cell) {
    cells[o] = cell;
    tris[o] = i;
    ++o;
  });
}

// total pairs = last offset + last count
__global__ void rootTotalKernel(const uint32_t* offsets, const uint32_t* counts, uint32_t n, uint64_t* out) {
  out[0] = uint64_t(offsets[n - 1]) + counts[n - 1];
}

} // namespace

RootMapping mapTrianglesToRootCells(DeviceMemory& mem, HostScalars& scalars, const DeviceMesh& mesh,
                                    const GridSpec& grid, uint64_t firstCell, uint64_t endCell,
                                    bool wantArea) {
  const cudaStream_t s = mem.stream();
  RootArgs a{mesh.triangles, mesh.count, grid.rootGrid,
             int64_t(grid.rootCellVoxels()) * kLatticePerVoxel, firstCell, endCell};
  const unsigned block = 256;
  DeviceBuffer<uint32_t> counts(mem, mesh.count), offsets(mem, mesh.count);
  DeviceBuffer<float> area(mem, wantArea ? mesh.count : 0);
  rootCountKernel<<<blocksFor(mesh.count, block), block, 0, s>>>(a, counts.data(), area.data());
  HDT_CUDA_CHECK_LAUNCH("rootCountKernel");
  runCub(mem, [&](void* temp, size_t& bytes) {
    return cub::DeviceScan::ExclusiveSum(temp, bytes, counts.data(), offsets.data(), mesh.count, s);
  });
  rootTotalKernel<<<1, 1, 0, s>>>(offsets.data(), counts.data(), mesh.count, scalars.device());
  HDT_CUDA_CHECK_LAUNCH("rootTotalKernel");
  if (wantArea) {
    DeviceBuffer<double> sum(mem, 1);
    runCub(mem, [&](void* temp, size_t& bytes) {
      return cub::DeviceReduce::Sum(temp, bytes, area.data(), sum.data(), mesh.count, s);
    });
    HDT_CUDA_CHECK(cudaMemcpyAsync(scalars.device() + 1, sum.data(), sizeof(double), cudaMemcpyDeviceToDevice, s));
  }
  scalars.fetch(s, wantArea ? 2 : 1);

  RootMapping out;
  const uint64_t total = scalars.host()[0];
  if (wantArea) {
    double sumArea;
    static_assert(sizeof(double) == sizeof(uint64_t), "");
    memcpy(&sumArea, &scalars.host()[1], sizeof(double));
    out.area = sumArea;
  }
  if (total > uint64_t(INT32_MAX)) throw DeviceMemoryExhausted(total * 8, mem.budget()); // chunk it
  out.pairs.count = uint32_t(total);
  out.pairs.element = DeviceBuffer<uint32_t>(mem, total);
  out.pairs.triangle = DeviceBuffer<uint32_t>(mem, total);
  rootWriteKernel<<<blocksFor(mesh.count, block), block, 0, s>>>(a, offsets.data(), out.pairs.element.data(),
                                                                 out.pairs.triangle.data());
  HDT_CUDA_CHECK_LAUNCH("rootWriteKernel");
  counts.reset();
  offsets.reset();
  sortPairs(mem, out.pairs.element, out.pairs.triangle, out.pairs.count, bitsFor(endCell - firstCell - 1));
  return out;
}

} // namespace cuda
} // namespace hdt
