// Voxel states over a box of the grid, coarsened by a power of two: what the
// "HDT To Image" filter turns into a vtkImageData (volume rendering, image
// filters, VTI/NRRD export), without the N^3 bytes of the full dense export.
#pragma once

#include "hdt/volume.hpp"

#include <cstdint>
#include <vector>

namespace hdt {

// The state of a block of `voxels` voxels of which `surface` are surface and
// `inside` inside: surface if any voxel is, else inside if more than half
// are, else outside. The hyper tree grid's cut cells (MaxDepth) and the
// coarsened image use this one rule. A correct build never mixes inside and
// outside voxels in a block without a surface voxel between them, so the
// majority only matters for damaged volumes.
inline VoxelState aggregateState(uint64_t voxels, uint64_t surface, uint64_t inside) {
  return surface ? VoxelState::Surface : (2 * inside > voxels ? VoxelState::Inside : VoxelState::Outside);
}

// A box of voxels [lo, hi) per axis, in global voxel indices.
struct VoxelBox {
  int64_t lo[3] = {0, 0, 0};
  int64_t hi[3] = {0, 0, 0};
  int64_t size(int axis) const { return hi[axis] - lo[axis]; }
};

// The smallest box aligned to blocks of 2^level voxels that holds `box`
// clipped to the grid (empty when they do not meet).
VoxelBox alignToBlocks(const Volume& volume, VoxelBox box, int level);

// One state per block of 2^level voxels per axis over `box` (which must be
// aligned: alignToBlocks), x fastest, by aggregateState over the block.
// Throws Error(InvalidArgument) for a level outside [0, log2 N] or a box that
// is not aligned to the blocks or not inside the grid.
std::vector<uint8_t> coarseStates(const Volume& volume, const VoxelBox& box, int level);

} // namespace hdt
