#include "hdt/volume.hpp"

#include "hdt/volume_walk.hpp"

#include <tbb/parallel_reduce.h>
#include <tbb/blocked_range.h>


namespace hdt {

void computeStructureStatistics(Volume& v) {
  struct Counts {
    uint64_t surface = 0, inside = 0;
  };
  const Counts leafCounts = tbb::parallel_reduce(
      tbb::blocked_range<size_t>(0, v.leafWords.size(), 1 << 16), Counts{},
      [&](const tbb::blocked_range<size_t>& r, Counts c) {
        for (size_t i = r.begin(); i != r.end(); ++i) {
          const uint32_t w = v.leafWords[i];
          c.surface += planeCount(w, kSurfacePlane);
          c.inside += planeCount(w, kInsidePlane);
        }
        return c;
      },
      [](Counts a, Counts b) { return Counts{a.surface + b.surface, a.inside + b.inside}; });
  uint64_t inside = leafCounts.inside;
  for (size_t level = 0; level + 1 < v.levelStart.size(); ++level) {
    const uint64_t edge = uint64_t(v.grid.elementVoxels(int(level)));
    for (uint64_t i = v.levelStart[level]; i < v.levelStart[level + 1]; ++i)
      if (elementState(v.elements[i]) == ElementState::Full) inside += edge * edge * edge;
  }
  computeStructureStatistics(v, leafCounts.surface, inside);
}

void computeStructureStatistics(Volume& v, uint64_t surfaceVoxels, uint64_t insideVoxels) {
  Statistics& s = v.stats;
  const uint64_t L = uint64_t(v.grid.leafSize);
  s.treeElements = v.elements.size();
  s.leafGrids = v.leafCount();
  s.leafVoxels = s.leafGrids * L * L * L;
  s.topologyBytes = v.elements.size() * sizeof(ElementWord);
  s.leafBytes = v.leafWords.size() * sizeof(uint32_t);
  s.activeVoxels = surfaceVoxels;
  s.insideVoxels = insideVoxels;
  s.paperBitsPerActiveVoxel =
      s.activeVoxels ? double(s.treeElements) * 20.0 * 8.0 / double(s.activeVoxels) : 0.0;
}

VoxelState voxelAt(const Volume& v, int x, int y, int z) {
  const GridSpec& g = v.grid;
  if (x < 0 || y < 0 || z < 0 || x >= g.resolution || y >= g.resolution || z >= g.resolution)
    return VoxelState::Outside;
  const WalkedElement e = locateElement(v, x, y, z, g.height);
  switch (e.state()) {
  case ElementState::Full: return VoxelState::Inside;
  case ElementState::Boundary:
    return leafVoxel(v.leaf(e.payload()), g.leafSize, x - e.origin[0], y - e.origin[1], z - e.origin[2]);
  default: return VoxelState::Outside; // Empty (a Branch at level h would be malformed)
  }
}

} // namespace hdt
