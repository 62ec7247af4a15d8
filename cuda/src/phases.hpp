// The device phases of one chunk of the root grid, as host-callable
// functions (kernels and CUB calls live in the .cu files).
//
// A chunk is a range [firstCell, endCell) of root-cell indices (x fastest).
// Unchunked builds are the chunk [0, R^3). Element indices inside a chunk are
// chunk-local per level; a Branch payload is `branchBase + 8 * rank`, where the
// caller passes the global index of the next level's first element when the
// chunk is the whole grid, and 0 when payloads are renumbered on the host.
#pragma once

#include "device_memory.hpp"

#include "hdt/build_steps.hpp" // PlaneClipper
#include "hdt/classify_steps.hpp"
#include "hdt/config.hpp"
#include "hdt/lattice.hpp"
#include "hdt/types.hpp"

#include <cuda_runtime.h>

#include <cstdint>
#include <functional>
#include <vector>

namespace hdt {
namespace cuda {

struct DeviceMesh {
  const LatticeTriangle* triangles = nullptr;
  uint32_t count = 0;
};

// Pinned host scalars for the few values the host must read back (counts
// that size the next allocations): one small copy and one stream sync each.
class HostScalars {
public:
  HostScalars();
  ~HostScalars();
  HostScalars(const HostScalars&) = delete;
  HostScalars& operator=(const HostScalars&) = delete;
  uint64_t* host() const { return host_; }
  uint64_t* device() const { return device_; }
  // Copies the first n device scalars to the host and waits for them.
  void fetch(cudaStream_t stream, int n);

private:
  uint64_t* host_ = nullptr;
  uint64_t* device_ = nullptr;
};

// Sorted (element, triangle) pairs of one level, element chunk-local.
struct PairList {
  DeviceBuffer<uint32_t> element;
  DeviceBuffer<uint32_t> triangle;
  uint32_t count = 0;
};

struct Level {
  uint32_t count = 0;              // elements of this level in the chunk
  DeviceBuffer<ElementWord> words; // final words except Empty -> Full
  DeviceBuffer<uint64_t> coords;   // packed cell coordinates at this level
};

// A warp's share of the per-leaf work (T3, classification pass 1): the pairs
// [first, end) of one leaf. A leaf with more than kTaskPairs pairs (a dense
// cluster of small triangles: thousands in one leaf at 1024^3 on some scans)
// is split over several tasks so that it does not serialise one warp; the
// parts of a split leaf merge their results with atomics into outputs zeroed
// beforehand (flags: kTaskSplit on every part, kTaskFirst on the first).
struct LeafTask {
  uint32_t leaf, first, end, flags;
};
constexpr uint32_t kTaskPairs = 32;
constexpr uint32_t kTaskSplit = 1, kTaskFirst = 2;

struct Leaves {
  uint32_t count = 0;
  DeviceBuffer<uint64_t> coord;     // packed leaf coordinates (leaf units)
  DeviceBuffer<uint32_t> pairStart; // count + 1 offsets into triangle
  DeviceBuffer<uint32_t> triangle;  // triangles of the (leaf, triangle) pairs
  DeviceBuffer<LeafTask> tasks;     // in leaf order
  DeviceBuffer<uint32_t> taskCount; // one device scalar: tasks in use
  uint32_t taskBound = 0;           // host upper bound of taskCount (grid sizes)
  uint32_t pairCount = 0;           // (leaf, triangle) pairs
};

// ---- T1 (mapping.cu) ---------------------------------------------------------
struct RootMapping {
  PairList pairs;
  double area = 0; // surface area of the mesh in voxel^2 (for the estimate)
};
RootMapping mapTrianglesToRootCells(DeviceMemory& mem, HostScalars& scalars, const DeviceMesh& mesh,
                                    const GridSpec& grid, uint64_t firstCell, uint64_t endCell,
                                    bool wantArea);

// ---- T2 (branching.cu) -------------------------------------------------------
struct Tree {
  std::vector<Level> levels; // height + 1
  Leaves leaves;
};
// Consumes the root pairs. When `unchunked`, Branch payloads are global and
// the 2^30-element limit is checked here with the CPU driver's message;
// otherwise payloads are chunk-local (base 0) and the host checks the joined
// tree. `afterLevel(level)` runs after each branching level (progress).
Tree buildTree(DeviceMemory& mem, HostScalars& scalars, const DeviceMesh& mesh, const GridSpec& grid,
               uint64_t firstCell, uint64_t endCell, PairList rootPairs, bool unchunked,
               const std::function<void(int)>& afterLevel);

// ---- per-triangle tables for the leaf kernels (triangle_tables.cu) -----------------
// T3's slice and row-height spans (sliceSpans, columnSpan) and the x rays'
// hit spans (raySpanAtW) depend on the triangle and the slice, height or ray
// line only, not on the leaf: narrowing commutes with clamping to a leaf
// (build_steps.hpp). A triangle meets 2 to 200 leaves at 8192^3 and its
// slices are the same in each, so they are evaluated once per triangle here
// (about 10x fewer evaluations than per (leaf, triangle) pair on CAD parts)
// and the leaf kernels clamp table entries. Spans are packed as two 16-bit
// offsets from the start of the triangle's range (packSpan).
struct TriangleSetup {
  PlaneClipper plane;        // in the triangle's row-axis frame (rowAxisFor)
  int32_t first[3], last[3]; // voxel box in that frame, clamped to the leaves' box (may be empty)
  int32_t axis;              // row axis
  int32_t u0, u1, w0, w1;    // x rays (crossings): centre ranges along y and z, clamped likewise
  RayCrossingSetup cross;    // x rays: the triangle's part of LeafCrossings
};
struct TriangleTables {
  uint32_t count = 0;                   // triangles with pairs among the leaves
  DeviceBuffer<uint32_t> compactOf;    // per mesh triangle: its index below (if it has pairs)
  DeviceBuffer<uint32_t> triangleOf;   // per table triangle: its mesh triangle (sized for all)
  DeviceBuffer<TriangleSetup> setup;
  DeviceBuffer<uint64_t> sliceStart, heightStart, lineStart; // per triangle: its first entry
  DeviceBuffer<uint2> slices;      // per (triangle, slice z): rows (y), x span
  DeviceBuffer<uint32_t> heights;  // per (triangle, row height y): x span
  DeviceBuffer<uint32_t> lines;    // per (triangle, ray line z): hit rays (y); only with crossings
};
// Tables of the triangles that have pairs among `leaves`, over the leaves'
// bounding box (a chunk's tables cover only its own part of the grid).
TriangleTables buildTriangleTables(DeviceMemory& mem, HostScalars& scalars, const DeviceMesh& mesh,
                                   const GridSpec& grid, const Leaves& leaves, bool crossings);

// Zeroes `perLeaf` elements at leaf * perLeaf of every split leaf (before
// its parts merge into them with atomics). In leaf.cu.
void zeroSplitLeaves(DeviceMemory& mem, const Leaves& leaves, uint32_t* data, uint32_t perLeaf);

// ---- T3 (leaf.cu) -------------------------------------------------------------
// Writes every word of every leaf grid once: the surface plane (plane 1).
// With `crossings` (solid builds) the same kernel also runs classification
// pass 1 along x (see leafCrossings): the before-masks go to plane 0 of the
// same words, written in the same store, and the row parities to
// `parityX` when it is not null. The leaf's pairs and words are then read
// and written once for both.
void writeLeafSurfaces(DeviceMemory& mem, HostScalars& scalars, const DeviceMesh& mesh, const GridSpec& grid,
                       const Leaves& leaves, uint32_t* words, bool crossings, uint32_t* parityX);

// ---- classification (classify.cu) ---------------------------------------------
// Pass 1: per leaf, ray axis and row, the crossings inside the leaf:
// parity[a] (leaves * rowWords, one bit per row; skipped when null) and,
// where masks[a] is not null, the XOR of the crossings' "voxels before"
// masks per row, pass 2's geometry (leaves * L * L). Runs the axes
// [firstAxis, axes): 1 when T3 has done axis 0 (whose masks T3 puts in
// plane 0 of the leaf words).
void leafCrossings(DeviceMemory& mem, const DeviceMesh& mesh, const GridSpec& grid, const Leaves& leaves,
                   int firstAxis, int axes, uint32_t* const parity[3], uint32_t* const masks[3]);

// The leaves of a chunk sorted by line along one axis, with the entry parity
// of every leaf. Turns parity[a] (pass 1) into the exit parity in place.
struct LineTable {
  DeviceBuffer<uint64_t> key;  // sorted line keys (LineKeys)
  DeviceBuffer<uint32_t> leaf; // leaf of each key
  DeviceBuffer<uint8_t> entry; // per leaf: entry parity of row 0
};
LineTable lineParity(DeviceMemory& mem, const GridSpec& grid, const Leaves& leaves, int axis, uint32_t* parity);

// Pass 2: inside bits (plane 0) of every leaf voxel that is not surface,
// from the exit parity and pass 1's masks; no geometry.
void writeLeafInside(DeviceMemory& mem, const GridSpec& grid, const Leaves& leaves, int axes,
                     const uint32_t* const exitParity[3], const uint32_t* const masks[3], uint32_t* words);

// Uniform elements of one level: Empty -> Full where the majority of the
// axes' parities at the element's lowest-corner voxel centre is odd.
void classifyUniform(DeviceMemory& mem, const GridSpec& grid, int level, Level& lv, int axes,
                     const LineTable* const tables[3], uint32_t leafCount);

// The line-key layout of a grid (classify_steps.hpp), as the CPU driver's.
inline LineKeys lineKeysFor(const GridSpec& g) { return LineKeys{lineFieldBits(uint64_t(g.resolution / g.leafSize))}; }

} // namespace cuda
} // namespace hdt
