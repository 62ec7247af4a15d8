// vtkPolyData (or a composite of them) -> hdt::TriangleMesh, shared by
// vtkHDTVoxelizer and the benchmark driver.
//
// Reads the points and the polys / strips cell arrays directly (no
// vtkTriangleFilter pass): triangles as they are, quads as two triangles,
// larger polygons by ear-cutting (vtkPolygon::Triangulate, so concave ones come
// out right), strips as their triangles. Vertices and lines have no area and are
// only counted. Cells with fewer than 3 points, or polygons that cannot be
// triangulated, are counted as skipped.
#pragma once

#include "HDTFiltersModule.h" // export macro
#include "vtkType.h"

#include <functional>
#include <string>

class vtkDataObject;
class vtkPolyData;
namespace hdt
{
struct TriangleMesh;
}

struct vtkHDTMeshConversionInfo
{
  vtkIdType Triangles = 0;       // triangles appended
  vtkIdType VertexCells = 0;     // verts (ignored)
  vtkIdType LineCells = 0;       // lines (ignored)
  vtkIdType SkippedCells = 0;    // polys / strips with < 3 points or no triangulation
  vtkIdType PolyDataBlocks = 0;  // vtkPolyData pieces read
  vtkIdType OtherBlocks = 0;     // composite leaves that are not vtkPolyData (ignored)
  std::string FirstOtherBlockType; // class name of the first of them
};

class HDTFILTERS_EXPORT vtkHDTMeshConversion
{
public:
  // Appends one polydata's polygons and strips to `mesh` (points are appended
  // too; indices are offset). Throws hdt::Error(OutOfResources) past 2^32 - 1
  // points.
  static void AppendPolyData(vtkPolyData* input, hdt::TriangleMesh& mesh,
    vtkHDTMeshConversionInfo& info);

  // A vtkPolyData or every vtkPolyData leaf of a vtkCompositeDataSet, as one
  // mesh. Other data objects count as OtherBlocks.
  static void AppendDataObject(vtkDataObject* input, hdt::TriangleMesh& mesh,
    vtkHDTMeshConversionInfo& info);

  // Calls `visit` for `input` when it is a vtkPolyData (flat index 0, no name)
  // or for every non-empty vtkPolyData leaf of a vtkCompositeDataSet, in
  // order, with its flat index and its NAME (null when it has none). Other
  // data objects count as OtherBlocks in `info`.
  using PolyDataVisitor = std::function<void(vtkPolyData*, unsigned int flatIndex, const char* name)>;
  static void ForEachPolyData(
    vtkDataObject* input, vtkHDTMeshConversionInfo& info, const PolyDataVisitor& visit);
};
