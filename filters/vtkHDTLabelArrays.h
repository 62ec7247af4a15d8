// Part labels (hdt/labels.hpp) on a converted vtkHyperTreeGrid.
//
// Cell data "Label" (unsigned short) for every cell: a cell of single voxels
// has its voxel's label; a larger cell (refined, cut by MaxDepth or a uniform
// octant) the majority label of the non-Outside voxels below it, ties to the
// lowest label, and 0 when all of them are outside.
// Field data, one tuple per label that has a voxel or a name (ascending):
// LabelIds, LabelNames, LabelSurfaceVoxels, LabelInsideVoxels, LabelVolume
// (mesh units cubed) and LabelSurfaceArea (estimate), as hdt::labelStatistics.
#pragma once

#include "HDTFiltersModule.h" // export macro

class vtkFieldData;
class vtkHyperTreeGrid;
namespace hdt
{
struct Volume;
}

// Adds the arrays to a grid converted from `volume` by vtkHDTToHyperTreeGrid
// (same tree layout). Does nothing for an unlabelled volume.
HDTFILTERS_EXPORT void vtkHDTAddLabelArrays(const hdt::Volume& volume, vtkHyperTreeGrid* grid);

// The field data part alone.
HDTFILTERS_EXPORT void vtkHDTAddLabelFieldData(const hdt::Volume& volume, vtkFieldData* fieldData);
