// Per-triangle tables for the leaf kernels (see TriangleTables in phases.hpp).
//
//   box      the leaves' bounding box (a chunk's leaves lie in a small part
//            of the grid) and which triangles have leaf pairs at all;
//   setup    one thread per triangle: row axis, plane clipper, voxel box in
//            the row-axis frame and the x rays' centre ranges, both clamped
//            to the leaves' box, and the entry counts of its tables;
//   scans    CUB exclusive sums of the counts place each triangle's entries;
//   entries  one thread per few consecutive table entries (each one's
//            triangle from a max-scan of the triangles' first entries):
//            sliceSpans, columnSpan or raySpanAtW on the whole box, as the
//            CPU driver evaluates them on a leaf's part, with the
//            triangle's part of them set up once per thread and triangle.
#include "device_common.cuh"
#include "phases.hpp"

#include "hdt/build_steps.hpp"

#include <cub/device/device_reduce.cuh>
#include <cub/device/device_scan.cuh>
#include <thrust/iterator/transform_iterator.h>

namespace hdt {
namespace cuda {
namespace {

constexpr int kBlock = 256;

struct MaxU32 { // (cub::Max is gone from CUDA 13, cuda::maximum new in 12.x)
  __host__ __device__ uint32_t operator()(uint32_t a, uint32_t b) const { return a > b ? a : b; }
};
struct ToUint32 {
  __host__ __device__ uint32_t operator()(uint8_t v) const { return v; }
};
constexpr int kRayAxis = 0; // the crossings T3 runs with: rays along x
constexpr int kRayU = rayAxisU(kRayAxis), kRayW = rayAxisW(kRayAxis);

// The leaves' bounding box in leaf units: a CUB reduction of per-leaf boxes.
struct LeafBox {
  uint32_t lo[3], hi[3];
};
struct LeafBoxOf {
  __host__ __device__ LeafBox operator()(uint64_t c) const {
    LeafBox b;
    for (int a = 0; a < 3; ++a) b.lo[a] = b.hi[a] = unpackCoord(c, a);
    return b;
  }
};
struct MergeLeafBoxes {
  __host__ __device__ LeafBox operator()(const LeafBox& x, const LeafBox& y) const {
    LeafBox b;
    for (int a = 0; a < 3; ++a) {
      b.lo[a] = x.lo[a] < y.lo[a] ? x.lo[a] : y.lo[a];
      b.hi[a] = x.hi[a] > y.hi[a] ? x.hi[a] : y.hi[a];
    }
    return b;
  }
};

__global__ void markUsedKernel(uint32_t n, const uint32_t* pairTri, uint8_t* used) {
  const uint32_t i = blockIdx.x * blockDim.x + threadIdx.x;
  if (i < n) used[pairTri[i]] = 1; // same value from every writer
}

// The used triangles in index order: triangleOf[compactOf[t]] = t.
__global__ void listUsedKernel(uint32_t n, const uint8_t* used, const uint32_t* compactOf, uint32_t* triangleOf,
                               uint64_t* count) {
  const uint32_t t = blockIdx.x * blockDim.x + threadIdx.x;
  if (t >= n) return;
  if (used[t]) triangleOf[compactOf[t]] = t;
  if (t == n - 1) *count = compactOf[t] + used[t];
}

__global__ void setupKernel(uint32_t m, const uint32_t* triangleOf, const LatticeTriangle* tris,
                            const LeafBox* leafBox, int L, int64_t resolution, bool crossings, TriangleSetup* setup,
                            uint32_t* sliceCount, uint32_t* heightCount, uint32_t* lineCount) {
  const uint32_t i = blockIdx.x * blockDim.x + threadIdx.x;
  if (i >= m) return;
  const LatticeTriangle original = tris[triangleOf[i]];
  const int axis = rowAxisFor(original);
  const LatticeTriangle t = permuteToRowAxis(original, axis);
  TriangleSetup s;
  makePlaneClipper(t, s.plane);
  s.axis = axis;
  // The leaves' box in voxels, in the original frame and in the row-axis one.
  int64_t lo[3], hi[3], plo[3], phi[3];
  for (int a = 0; a < 3; ++a) {
    lo[a] = int64_t(leafBox->lo[a]) * L;
    hi[a] = int64_t(leafBox->hi[a]) * L + L - 1;
  }
  permutedOrigin(lo, axis, plo);
  permutedOrigin(hi, axis, phi);
  int64_t first[3], last[3];
  triangleVoxelBox(t, resolution, first, last);
  bool any = true;
  for (int a = 0; a < 3; ++a) {
    first[a] = max(first[a], plo[a]);
    last[a] = min(last[a], phi[a]);
    any = any && first[a] <= last[a];
    s.first[a] = int32_t(first[a]);
    s.last[a] = int32_t(last[a]);
  }
  sliceCount[i] = any ? uint32_t(last[2] - first[2] + 1) : 0;
  heightCount[i] = any ? uint32_t(last[1] - first[1] + 1) : 0;
  uint32_t lines = 0;
  s.u0 = s.w0 = 1;
  s.u1 = s.w1 = 0;
  if (crossings && any) {
    int64_t tlo[3], thi[3], u0, u1, w0, w1;
    triangleBounds(original, tlo, thi);
    // centreRange clamps to [v0, v0 + L): here the leaves' box.
    centreRange(tlo[kRayU], thi[kRayU], lo[kRayU], int(hi[kRayU] - lo[kRayU] + 1), u0, u1);
    centreRange(tlo[kRayW], thi[kRayW], lo[kRayW], int(hi[kRayW] - lo[kRayW] + 1), w0, w1);
    if (u0 <= u1 && w0 <= w1) {
      s.u0 = int32_t(u0);
      s.u1 = int32_t(u1);
      s.w0 = int32_t(w0);
      s.w1 = int32_t(w1);
      lines = uint32_t(w1 - w0 + 1);
      makeRayCrossingSetup(original, kRayAxis, s.cross);
    }
  }
  lineCount[i] = lines;
  setup[i] = s;
}

// The owner of every entry of a table: each triangle with entries marks its
// first one, and an inclusive max-scan carries the mark over the rest (one
// load an entry instead of a binary search over the starts).
__global__ void markFirstEntriesKernel(uint32_t m, const uint64_t* start, const uint32_t* count, uint32_t* owner) {
  const uint32_t j = blockIdx.x * blockDim.x + threadIdx.x;
  if (j < m && count[j] > 0) owner[start[j]] = j;
}

DeviceBuffer<uint32_t> entryOwners(DeviceMemory& mem, uint32_t m, const uint64_t* start, const uint32_t* count,
                                   uint64_t total) {
  const cudaStream_t s = mem.stream();
  DeviceBuffer<uint32_t> owner(mem, total);
  HDT_CUDA_CHECK(cudaMemsetAsync(owner.data(), 0, total * sizeof(uint32_t), s));
  markFirstEntriesKernel<<<blocksFor(m, kBlock), kBlock, 0, s>>>(m, start, count, owner.data());
  HDT_CUDA_CHECK_LAUNCH("markFirstEntriesKernel");
  uint32_t* o = owner.data();
  runCub(mem, [&](void* temp, size_t& bytes) {
    return cub::DeviceScan::InclusiveScan(temp, bytes, o, o, MaxU32{}, total, s);
  });
  return owner;
}

// One thread per kEntriesPerThread consecutive table entries: each entry's
// triangle (mesh and table index), setup and place k in the triangle's run.
// `Entry` sets up what depends on the triangle alone (prepare: clipper
// parts, edge reciprocals) once for the thread's run of entries of one
// triangle, and evaluates and stores each entry (eval); a triangle's
// entries are consecutive, so most threads prepare once.
constexpr int kEntriesPerThread = 4;
struct EntryArgs {
  const uint32_t* owner;
  const uint64_t* start;
  const uint32_t* triangleOf;
  const LatticeTriangle* tris;
  const TriangleSetup* setup;
};
template <class Entry>
__global__ void entriesKernel(uint64_t total, EntryArgs a, Entry entry) {
  const uint64_t e0 = (uint64_t(blockIdx.x) * blockDim.x + threadIdx.x) * kEntriesPerThread;
  typename Entry::State state;
  uint32_t prepared = 0xFFFFFFFFu; // table index `state` belongs to
  uint64_t start = 0;
#pragma unroll 1
  for (uint64_t e = e0; e < e0 + kEntriesPerThread && e < total; ++e) {
    const uint32_t j = a.owner[e];
    if (j != prepared) {
      entry.prepare(a.tris[a.triangleOf[j]], a.setup[j], state);
      start = a.start[j];
      prepared = j;
    }
    entry.eval(state, int64_t(e - start), e);
  }
}

__device__ __forceinline__ void boxOf(const TriangleSetup& s, int64_t (&first)[3], int64_t (&last)[3]) {
  for (int d = 0; d < 3; ++d) {
    first[d] = s.first[d];
    last[d] = s.last[d];
  }
}

struct SliceEntry { // rows and x span of slice z = first z + k
  uint2* out;
  struct State {
    RowClipper c; // the parts for the rows of a slice and its x span
    int64_t first[3], last[3];
  };
  __device__ void prepare(const LatticeTriangle& original, const TriangleSetup& s, State& st) const {
    const LatticeTriangle t = permuteToRowAxis(original, s.axis);
    for (int part = 0; part < 5; ++part) makeRowClipperPart(t, part, st.c); // rows of a slice
    for (int part = 6; part < 9; ++part) makeRowClipperPart(t, part, st.c); // the slice's x span
    boxOf(s, st.first, st.last);
  }
  __device__ void eval(const State& st, int64_t k, uint64_t e) const {
    int64_t y0, y1, x0, x1;
    sliceSpans(st.c, st.first, st.last, st.first[2] + k, y0, y1, x0, x1);
    out[e] = make_uint2(packSpan(y0, y1, st.first[1]), packSpan(x0, x1, st.first[0]));
  }
};

struct HeightEntry { // x span of row height y = first y + k
  uint32_t* out;
  struct State {
    RowClipper c; // the column parts
    int64_t first[3], last[3];
  };
  __device__ void prepare(const LatticeTriangle& original, const TriangleSetup& s, State& st) const {
    const LatticeTriangle t = permuteToRowAxis(original, s.axis);
    for (int part = 9; part < 12; ++part) makeRowClipperPart(t, part, st.c);
    boxOf(s, st.first, st.last);
  }
  __device__ void eval(const State& st, int64_t k, uint64_t e) const {
    int64_t x0, x1;
    columnSpan(st.c, st.first, st.last, st.first[1] + k, x0, x1);
    out[e] = packSpan(x0, x1, st.first[0]);
  }
};

struct LineEntry { // hit rays of the x-ray line z = w0 + k
  uint32_t* out;
  struct State {
    RaySpanSetup r;
    int32_t u0, u1, w0;
  };
  __device__ void prepare(const LatticeTriangle& original, const TriangleSetup& s, State& st) const {
    makeRaySpanSetup(original, kRayAxis, st.r);
    st.u0 = s.u0;
    st.u1 = s.u1;
    st.w0 = s.w0;
  }
  __device__ void eval(const State& st, int64_t k, uint64_t e) const {
    int64_t f = st.u0, l = st.u1;
    raySpanAtW(st.r, st.w0 + k, f, l);
    out[e] = packSpan(f, l, st.u0);
  }
};

// Fills one table of `total` entries whose triangles start at `start`.
template <class Entry>
void fillTable(DeviceMemory& mem, uint32_t m, const uint64_t* start, const uint32_t* count, uint64_t total,
               EntryArgs a, Entry entry) {
  if (total == 0) return;
  const DeviceBuffer<uint32_t> owner = entryOwners(mem, m, start, count, total);
  a.owner = owner.data();
  a.start = start;
  entriesKernel<<<blocksFor((total + kEntriesPerThread - 1) / kEntriesPerThread, kBlock), kBlock, 0, mem.stream()>>>(
      total, a, entry);
  HDT_CUDA_CHECK_LAUNCH("entriesKernel");
}

// The tables' sizes (into scalars 0..2): last start + last count.
struct CountsAndStarts {
  const uint32_t* count[3];
  const uint64_t* start[3];
};
__global__ void tableTotalsKernel(uint32_t n, CountsAndStarts c, uint64_t* totals) {
  for (int k = 0; k < 3; ++k) totals[k] = c.start[k][n - 1] + c.count[k][n - 1];
}

} // namespace

TriangleTables buildTriangleTables(DeviceMemory& mem, HostScalars& scalars, const DeviceMesh& mesh,
                                   const GridSpec& grid, const Leaves& leaves, bool crossings) {
  const cudaStream_t s = mem.stream();
  const uint32_t n = mesh.count;
  TriangleTables t;
  if (n == 0 || leaves.count == 0 || leaves.pairCount == 0) return t;

  // The triangles with pairs here, and the leaves' box.
  {
    DeviceBuffer<uint8_t> used(mem, n);
    HDT_CUDA_CHECK(cudaMemsetAsync(used.data(), 0, n, s));
    markUsedKernel<<<blocksFor(leaves.pairCount, kBlock), kBlock, 0, s>>>(leaves.pairCount, leaves.triangle.data(),
                                                                            used.data());
    HDT_CUDA_CHECK_LAUNCH("markUsedKernel");
    t.compactOf = DeviceBuffer<uint32_t>(mem, n);
    const uint8_t* u = used.data();
    uint32_t* c = t.compactOf.data();
    auto flags = thrust::make_transform_iterator(u, ToUint32{});
    runCub(mem, [&](void* temp, size_t& bytes) { return cub::DeviceScan::ExclusiveSum(temp, bytes, flags, c, n, s); });
    t.triangleOf = DeviceBuffer<uint32_t>(mem, n);
    listUsedKernel<<<blocksFor(n, kBlock), kBlock, 0, s>>>(n, u, c, t.triangleOf.data(), scalars.device());
    HDT_CUDA_CHECK_LAUNCH("listUsedKernel");
    scalars.fetch(s, 1);
    t.count = uint32_t(scalars.host()[0]);
  }
  const uint32_t m = t.count;
  DeviceBuffer<LeafBox> box(mem, 1);
  {
    auto boxes = thrust::make_transform_iterator(leaves.coord.data(), LeafBoxOf{});
    LeafBox* out = box.data();
    const LeafBox empty{{0xFFFFFFFFu, 0xFFFFFFFFu, 0xFFFFFFFFu}, {0, 0, 0}};
    runCub(mem, [&](void* temp, size_t& bytes) {
      return cub::DeviceReduce::Reduce(temp, bytes, boxes, out, leaves.count, MergeLeafBoxes{}, empty, s);
    });
  }

  t.setup = DeviceBuffer<TriangleSetup>(mem, m);
  t.sliceStart = DeviceBuffer<uint64_t>(mem, m);
  t.heightStart = DeviceBuffer<uint64_t>(mem, m);
  t.lineStart = DeviceBuffer<uint64_t>(mem, m);
  DeviceBuffer<uint32_t> counts[3] = {DeviceBuffer<uint32_t>(mem, m), DeviceBuffer<uint32_t>(mem, m),
                                      DeviceBuffer<uint32_t>(mem, m)};
  setupKernel<<<blocksFor(m, kBlock), kBlock, 0, s>>>(m, t.triangleOf.data(), mesh.triangles, box.data(),
                                                      grid.leafSize, grid.resolution, crossings, t.setup.data(),
                                                      counts[0].data(), counts[1].data(), counts[2].data());
  HDT_CUDA_CHECK_LAUNCH("setupKernel");
  DeviceBuffer<uint64_t>* starts[3] = {&t.sliceStart, &t.heightStart, &t.lineStart};
  for (int k = 0; k < 3; ++k) {
    const uint32_t* in = counts[k].data();
    uint64_t* out = starts[k]->data();
    runCub(mem, [&](void* temp, size_t& bytes) { return cub::DeviceScan::ExclusiveSum(temp, bytes, in, out, m, s); });
  }
  const CountsAndStarts cs{{counts[0].data(), counts[1].data(), counts[2].data()},
                           {t.sliceStart.data(), t.heightStart.data(), t.lineStart.data()}};
  tableTotalsKernel<<<1, 1, 0, s>>>(m, cs, scalars.device());
  HDT_CUDA_CHECK_LAUNCH("tableTotalsKernel");
  scalars.fetch(s, 3);
  const uint64_t total[3] = {scalars.host()[0], scalars.host()[1], scalars.host()[2]};

  t.slices = DeviceBuffer<uint2>(mem, total[0]);
  t.heights = DeviceBuffer<uint32_t>(mem, total[1]);
  t.lines = DeviceBuffer<uint32_t>(mem, total[2]);
  const EntryArgs args{nullptr, nullptr, t.triangleOf.data(), mesh.triangles, t.setup.data()};
  fillTable(mem, m, t.sliceStart.data(), counts[0].data(), total[0], args, SliceEntry{t.slices.data()});
  fillTable(mem, m, t.heightStart.data(), counts[1].data(), total[1], args, HeightEntry{t.heights.data()});
  fillTable(mem, m, t.lineStart.data(), counts[2].data(), total[2], args, LineEntry{t.lines.data()});
  return t;
}

} // namespace cuda
} // namespace hdt
