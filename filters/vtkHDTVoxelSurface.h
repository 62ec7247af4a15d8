// The voxel surface of an hdt::Volume (hdt/voxel_surface.hpp) as vtkPolyData:
// quads with cell data "VoxelState" (1 inside, 2 surface: the state of the
// occupied cell the face bounds) and, for a labelled volume, "Label"
// (unsigned short, that cell's part label, as on the hyper tree grid). Shared by vtkHDTVoxelizer and vtkHDTReader
// (their second output port). Internal to HDT::Filters like the conversion.
#pragma once

class vtkDataObject;
class vtkPolyData;
namespace hdt
{
struct Volume;
}

struct vtkHDTVoxelSurfaceInfo
{
  double Milliseconds = 0;
  long long Quads = 0;
};

/**
 * Replaces the contents of `output` with the surface of `volume` at level of
 * detail `maxDepth` (the hyper tree grid's depth; -1 = full). The core's
 * arrays are copied as they are: 4 points a quad, 32-bit cell storage when it
 * fits. Only the faces of root cells [firstCell, endCell): a rank's piece
 * (vtkHDTDistributedBuild.h). Throws what the core throws (hdt::Error, std::bad_alloc).
 */
vtkHDTVoxelSurfaceInfo vtkHDTFillVoxelSurface(const hdt::Volume& volume, int maxDepth,
  vtkPolyData* output, unsigned long long firstCell = 0, unsigned long long endCell = ~0ull);

/**
 * Gives `surface` the field data of `htg` (the build statistics; arrays are
 * shared, not copied) and a "TimeSurface" array holding `milliseconds`.
 */
void vtkHDTCopyFieldData(vtkDataObject* htg, vtkPolyData* surface, double milliseconds);
