// Transferred mesh data (hdt/transfer.hpp) on a converted vtkHyperTreeGrid and
// on the voxel surface.
//
// One vtkFloatArray per hdt::VoxelArray, same name and components:
//   * a cell of one voxel: the voxel's value when it is a surface voxel, NaN
//     otherwise (inside and outside voxels carry no value);
//   * a larger cell (refined, cut by MaxDepth, or a uniform element): per
//     component, the mean of its 8 children's values that are not NaN (a
//     mean of means, not of voxels), NaN when all are NaN;
//   * a quad of the voxel surface: the same NaN-aware mean over the cells
//     behind it (a merged quad averages the cells it merges);
//   * a point of HDT To Image (a block of 2^level voxels): the block's value
//     as a cell of that size.
// Field data "TransferredArrays" (strings) names them.
#pragma once

#include "HDTFiltersModule.h" // export macro

class vtkHyperTreeGrid;
class vtkImageData;
class vtkPolyData;
namespace hdt
{
struct Volume;
}

// Adds the arrays to a grid converted from `volume` by vtkHDTToHyperTreeGrid
// (same tree layout). Does nothing for a volume without arrays.
HDTFILTERS_EXPORT void vtkHDTAddVoxelArrays(const hdt::Volume& volume, vtkHyperTreeGrid* grid);

// Adds the arrays to `surface`, filled by vtkHDTFillVoxelSurface from the same
// volume, depth and root cells. Does nothing for a volume without arrays.
// Adds the arrays as point data to `image`, made by vtkHDTToImage: one point
// per block of 2^level voxels from voxel `lo` (aligned to the blocks), x fastest.
HDTFILTERS_EXPORT void vtkHDTAddVoxelImageArrays(
  const hdt::Volume& volume, const long long lo[3], int level, vtkImageData* image);

HDTFILTERS_EXPORT void vtkHDTAddVoxelSurfaceArrays(const hdt::Volume& volume, int maxDepth,
  vtkPolyData* surface, unsigned long long firstCell = 0, unsigned long long endCell = ~0ull);
