// A built HDT: the tree, the leaf grids and the statistics of the build.
#pragma once

#include "hdt/config.hpp"
#include "hdt/label_field.hpp"
#include "hdt/types.hpp"
#include "hdt/voxel_arrays.hpp"

#include "hdt/default_init_allocator.hpp"

#include <cstdint>
#include <string>
#include <vector>

namespace hdt {

// The leaf grids' words: resize(n) does not zero them (see above).
using LeafWordVector = std::vector<uint32_t, DefaultInitAllocator<uint32_t>>;

// Wall-clock time of each phase, in milliseconds (paper Fig. 3: T1, T2, T3).
struct PhaseTimes {
  double mapping = 0;   // T1: triangles to root cells
  double branching = 0; // T2: level-order refinement
  double leaf = 0;      // T3: surface voxels of every leaf grid
  double classify = 0;  // inside/outside of leaf voxels and uniform elements
  double total = 0;
};

// The paper's Table 1 and Fig. 3, plus this implementation's real sizes.
struct Statistics {
  uint64_t triangles = 0;            // triangles used (non-degenerate)
  uint64_t degenerateTriangles = 0;  // dropped
  uint64_t treeElements = 0;         // root-grid elements + every octree node
  uint64_t leafGrids = 0;
  uint64_t leafVoxels = 0;           // leafGrids * L^3
  uint64_t activeVoxels = 0;         // surface voxels
  uint64_t insideVoxels = 0;         // inside voxels, uniform Full elements included
  double paperBitsPerActiveVoxel = 0; // treeElements * 20 bytes * 8 / activeVoxels
  uint64_t topologyBytes = 0;        // 4 bytes an element here
  uint64_t leafBytes = 0;            // L^3 / 4 bytes a leaf grid
  PhaseTimes time;
  uint64_t peakHostBytes = 0;
  uint64_t peakDeviceBytes = 0;
  std::string backend;               // "cpu" or "cuda"
  int threads = 0;                   // CPU threads used
  // Winding number: uniform elements refined because w = 1/2 crosses them
  // (winding_tree.hpp); 0 under Parity.
  uint64_t windingRefinedElements = 0;
};

struct Volume {
  GridSpec grid;
  bool surfaceOnly = false;
  bool closedMesh = false;
  InsideTest insideTest = InsideTest::Parity; // the test that ran (Parity or WindingNumber)
  std::vector<ElementWord> elements; // level order, see types.hpp
  // levelStart[k] is the index of the first element of level k; the array has
  // height + 2 entries, the last one equal to elements.size().
  std::vector<uint64_t> levelStart;
  LeafWordVector leafWords;          // leafGrids * leafWordCount(L); resize() leaves them unwritten
  Statistics stats;
  LabelField labels;                 // part labels (hdt/labels.hpp); empty when unlabelled
  std::vector<VoxelArray> arrays;    // mesh data on surface voxels (hdt/transfer.hpp); usually none

  uint64_t leafCount() const { return leafWords.size() / leafWordCount(grid.leafSize); }
  const uint32_t* leaf(uint64_t i) const { return leafWords.data() + i * leafWordCount(grid.leafSize); }
};

// Recomputes the structural statistics (elements, leaves, voxel counts,
// bytes) from a volume's contents; timings and backend are left alone.
void computeStructureStatistics(Volume& volume);
// The same with the voxel counts given (surface; inside: leaf voxels and
// Full elements' voxels), by a driver that counted them on the device.
void computeStructureStatistics(Volume& volume, uint64_t surfaceVoxels, uint64_t insideVoxels);

// Checks everything a consumer relies on: the grid (N = R 2^h L, finite
// placement), the level table, the canonical level-order layout of the
// elements (docs/hdt-format.md rules 13-17), the leaf words (no state 3, no
// Inside in a surface-only volume) and the statistics derived from the
// contents. Throws Error(BadInput) naming the first problem. The .hdt reader
// applies the same checks section by section as it reads; the writer refuses
// a volume that fails them.
// What a volume's structural statistics (elements, leaves, voxel counts,
// bytes) describe: its own contents, or, for one process's piece of a build
// spread over processes (range_exchange.hpp), the whole volume of the job;
// those are not checked against the piece's contents.
enum class StatisticsOf { Contents, WholeJob };
void validateVolume(const Volume& volume, StatisticsOf statistics = StatisticsOf::Contents);

// Voxel state at global voxel (x, y, z), by walking the tree. Slow: for tests,
// dense export and spot checks.
VoxelState voxelAt(const Volume& volume, int x, int y, int z);

} // namespace hdt
