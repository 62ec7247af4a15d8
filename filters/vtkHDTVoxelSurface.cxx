#include "vtkHDTVoxelSurface.h"

#include "hdt/huge_pages.hpp"
#include "hdt/voxel_surface.hpp"

#include "vtkCellArray.h"
#include "vtkCellData.h"
#include "vtkDoubleArray.h"
#include "vtkFieldData.h"
#include "vtkFloatArray.h"
#include "vtkIdTypeArray.h"
#include "vtkNew.h"
#include "vtkPoints.h"
#include "vtkPolyData.h"
#include "vtkSMPTools.h"
#include "vtkTypeInt32Array.h"
#include "vtkSmartPointer.h"
#include "vtkUnsignedCharArray.h"
#include "vtkUnsignedShortArray.h"

#include <chrono>
#include <limits>

namespace
{
// Quad i is points 4i .. 4i + 3: offsets 4i, connectivity the identity.
template <class ArrayT>
void setQuadCells(vtkCellArray* cells, vtkIdType quads)
{
  using Value = typename ArrayT::ValueType;
  vtkNew<ArrayT> offsets;
  vtkNew<ArrayT> connectivity;
  offsets->SetNumberOfValues(quads + 1);
  connectivity->SetNumberOfValues(4 * quads);
  Value* off = offsets->GetPointer(0);
  Value* conn = connectivity->GetPointer(0);
  // Fresh memory: huge pages make its first touch cheap (huge_pages.hpp).
  hdt::adviseHugePages(off, sizeof(Value) * size_t(quads + 1));
  hdt::adviseHugePages(conn, sizeof(Value) * size_t(4 * quads));
  vtkSMPTools::For(0, quads + 1, [&](vtkIdType begin, vtkIdType end) {
    for (vtkIdType i = begin; i < end; ++i)
    {
      off[i] = Value(4 * i);
    }
  });
  vtkSMPTools::For(0, 4 * quads, [&](vtkIdType begin, vtkIdType end) {
    for (vtkIdType i = begin; i < end; ++i)
    {
      conn[i] = Value(i);
    }
  });
  cells->SetData(offsets, connectivity);
}
} // namespace

vtkHDTVoxelSurfaceInfo vtkHDTFillVoxelSurface(const hdt::Volume& volume, int maxDepth,
  vtkPolyData* output, unsigned long long firstCell, unsigned long long endCell)
{
  const auto t0 = std::chrono::steady_clock::now();
  hdt::SurfaceOptions options;
  options.maxDepth = maxDepth;
  options.cellsFirst = firstCell;
  options.cellsEnd = endCell;
  // The core writes the points and states straight into the VTK arrays.
  vtkNew<vtkFloatArray> coordinates;
  coordinates->SetNumberOfComponents(3);
  vtkNew<vtkUnsignedCharArray> states;
  states->SetName("VoxelState");
  // Part labels beside the states, named as on the hyper tree grid.
  vtkSmartPointer<vtkUnsignedShortArray> labels;
  if (!volume.labels.empty())
  {
    labels = vtkSmartPointer<vtkUnsignedShortArray>::New();
    labels->SetName("Label");
  }
  vtkIdType quads = 0;
  hdt::extractVoxelSurfaceInto(volume, options, [&](size_t count) {
    quads = vtkIdType(count);
    coordinates->SetNumberOfTuples(4 * quads);
    states->SetNumberOfValues(quads);
    if (labels)
    {
      labels->SetNumberOfValues(quads);
    }
    return hdt::SurfaceBuffers{ coordinates->GetPointer(0), states->GetPointer(0),
      labels ? labels->GetPointer(0) : nullptr };
  });
  vtkNew<vtkPoints> points;
  points->SetData(coordinates);

  vtkNew<vtkCellArray> cells;
  if (4 * quads < vtkIdType(std::numeric_limits<int32_t>::max()))
  {
    setQuadCells<vtkTypeInt32Array>(cells, quads);
  }
  else
  {
    setQuadCells<vtkIdTypeArray>(cells, quads);
  }

  output->Initialize();
  output->SetPoints(points);
  output->SetPolys(cells);
  output->GetCellData()->SetScalars(states);
  if (labels)
  {
    output->GetCellData()->AddArray(labels);
  }

  vtkHDTVoxelSurfaceInfo info;
  info.Quads = quads;
  info.Milliseconds =
    std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count();
  return info;
}

void vtkHDTCopyFieldData(vtkDataObject* htg, vtkPolyData* surface, double milliseconds)
{
  if (htg)
  {
    surface->GetFieldData()->ShallowCopy(htg->GetFieldData());
  }
  vtkNew<vtkDoubleArray> time;
  time->SetName("TimeSurface");
  time->InsertNextValue(milliseconds);
  surface->GetFieldData()->AddArray(time);
}
