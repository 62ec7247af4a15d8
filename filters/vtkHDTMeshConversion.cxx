#include "vtkHDTMeshConversion.h"

#include "hdt/error.hpp"
#include "hdt/mesh.hpp"

#include "vtkCellArray.h"
#include "vtkCompositeDataIterator.h"
#include "vtkCompositeDataSet.h"
#include "vtkDoubleArray.h"
#include "vtkFloatArray.h"
#include "vtkIdList.h"
#include "vtkInformation.h"
#include "vtkNew.h"
#include "vtkPoints.h"
#include "vtkPolyData.h"
#include "vtkPolygon.h"
#include "vtkSmartPointer.h"

#include <algorithm>
#include <limits>

namespace
{

// Appends the triangles of one cell array. Offsets/connectivity are read
// straight from the 32- or 64-bit storage.
template <typename ArrayT>
void appendCells(ArrayT* offsets, ArrayT* connectivity, bool strips, uint32_t base,
  vtkPoints* points, hdt::TriangleMesh& mesh, vtkHDTMeshConversionInfo& info)
{
  const vtkIdType cells = offsets->GetNumberOfValues() - 1;
  if (cells <= 0)
  {
    return;
  }
  const auto* off = offsets->GetPointer(0);
  const auto* conn = connectivity->GetPointer(0);
  std::vector<uint32_t>& tris = mesh.triangles;
  auto emit = [&](vtkIdType a, vtkIdType b, vtkIdType c) {
    tris.push_back(base + uint32_t(a));
    tris.push_back(base + uint32_t(b));
    tris.push_back(base + uint32_t(c));
    ++info.Triangles;
  };
  vtkNew<vtkPolygon> polygon; // only for polygons of 5 or more points
  vtkNew<vtkIdList> local;
  for (vtkIdType cell = 0; cell < cells; ++cell)
  {
    const vtkIdType first = vtkIdType(off[cell]);
    const vtkIdType n = vtkIdType(off[cell + 1]) - first;
    const auto* ids = conn + first;
    if (n < 3)
    {
      ++info.SkippedCells;
      continue;
    }
    if (strips)
    {
      // Triangle k of a strip is (k, k+1, k+2), every other one flipped to keep
      // the orientation (which the voxelizer does not need, but keeps the mesh right).
      for (vtkIdType k = 0; k + 2 < n; ++k)
      {
        if (k & 1)
        {
          emit(ids[k + 1], ids[k], ids[k + 2]);
        }
        else
        {
          emit(ids[k], ids[k + 1], ids[k + 2]);
        }
      }
    }
    else if (n <= 4)
    {
      emit(ids[0], ids[1], ids[2]);
      if (n == 4)
      {
        emit(ids[0], ids[2], ids[3]);
      }
    }
    else
    {
      // Ear cutting handles concave polygons; its output ids are 0..n-1.
      polygon->GetPointIds()->SetNumberOfIds(n);
      polygon->GetPoints()->SetNumberOfPoints(n);
      for (vtkIdType i = 0; i < n; ++i)
      {
        polygon->GetPointIds()->SetId(i, vtkIdType(ids[i]));
        polygon->GetPoints()->SetPoint(i, points->GetPoint(vtkIdType(ids[i])));
      }
      if (polygon->Triangulate(local) && local->GetNumberOfIds() >= 3)
      {
        for (vtkIdType i = 0; i + 2 < local->GetNumberOfIds(); i += 3)
        {
          emit(ids[local->GetId(i)], ids[local->GetId(i + 1)], ids[local->GetId(i + 2)]);
        }
      }
      else
      {
        // Degenerate or non-planar beyond repair: a fan still covers it.
        for (vtkIdType i = 1; i + 1 < n; ++i)
        {
          emit(ids[0], ids[i], ids[i + 1]);
        }
      }
    }
  }
}

void appendCellArray(vtkCellArray* cells, bool strips, uint32_t base, vtkPoints* points,
  hdt::TriangleMesh& mesh, vtkHDTMeshConversionInfo& info)
{
  if (!cells || cells->GetNumberOfCells() == 0)
  {
    return;
  }
  if (cells->IsStorage64Bit())
  {
    appendCells(cells->GetOffsetsArray64(), cells->GetConnectivityArray64(), strips, base, points,
      mesh, info);
  }
  else
  {
    appendCells(cells->GetOffsetsArray32(), cells->GetConnectivityArray32(), strips, base, points,
      mesh, info);
  }
}

} // namespace

//------------------------------------------------------------------------------
void vtkHDTMeshConversion::AppendPolyData(
  vtkPolyData* input, hdt::TriangleMesh& mesh, vtkHDTMeshConversionInfo& info)
{
  if (!input)
  {
    return;
  }
  ++info.PolyDataBlocks;
  info.VertexCells += input->GetNumberOfVerts();
  info.LineCells += input->GetNumberOfLines();
  vtkPoints* points = input->GetPoints();
  const vtkIdType np = points ? points->GetNumberOfPoints() : 0;
  if (np == 0 || (input->GetNumberOfPolys() == 0 && input->GetNumberOfStrips() == 0))
  {
    return;
  }
  const size_t base = mesh.pointCount();
  if (base + size_t(np) > size_t(std::numeric_limits<uint32_t>::max()))
  {
    throw hdt::Error(hdt::ErrorKind::OutOfResources,
      "the input has more than 2^32 - 1 points, more than the voxelizer takes");
  }

  // Points: straight copies from float or double storage, tuple access otherwise.
  mesh.points.resize(3 * (base + size_t(np)));
  double* out = mesh.points.data() + 3 * base;
  vtkDataArray* data = points->GetData();
  if (auto* f = vtkArrayDownCast<vtkFloatArray>(data))
  {
    const float* in = f->GetPointer(0);
    for (vtkIdType i = 0; i < 3 * np; ++i)
    {
      out[i] = double(in[i]);
    }
  }
  else if (auto* d = vtkArrayDownCast<vtkDoubleArray>(data))
  {
    std::copy(d->GetPointer(0), d->GetPointer(0) + 3 * np, out);
  }
  else
  {
    for (vtkIdType i = 0; i < np; ++i)
    {
      data->GetTuple(i, out + 3 * i);
    }
  }

  // A cell of n points gives n - 2 triangles (polygons and strips alike).
  vtkIdType expected = 0;
  for (vtkCellArray* cells : { input->GetPolys(), input->GetStrips() })
  {
    expected += std::max<vtkIdType>(
      0, cells->GetNumberOfConnectivityIds() - 2 * cells->GetNumberOfCells());
  }
  mesh.triangles.reserve(mesh.triangles.size() + 3 * size_t(expected));
  appendCellArray(input->GetPolys(), false, uint32_t(base), points, mesh, info);
  appendCellArray(input->GetStrips(), true, uint32_t(base), points, mesh, info);
}

//------------------------------------------------------------------------------
void vtkHDTMeshConversion::AppendDataObject(
  vtkDataObject* input, hdt::TriangleMesh& mesh, vtkHDTMeshConversionInfo& info)
{
  ForEachPolyData(input, info,
    [&](vtkPolyData* pd, unsigned int, const char*) { AppendPolyData(pd, mesh, info); });
}

//------------------------------------------------------------------------------
void vtkHDTMeshConversion::ForEachPolyData(
  vtkDataObject* input, vtkHDTMeshConversionInfo& info, const PolyDataVisitor& visit)
{
  auto countOther = [&info](vtkDataObject* object) {
    ++info.OtherBlocks;
    if (info.FirstOtherBlockType.empty())
    {
      info.FirstOtherBlockType = object->GetClassName();
    }
  };
  if (auto* pd = vtkPolyData::SafeDownCast(input))
  {
    visit(pd, 0, nullptr);
    return;
  }
  auto* composite = vtkCompositeDataSet::SafeDownCast(input);
  if (!composite)
  {
    if (input)
    {
      countOther(input);
    }
    return;
  }
  vtkSmartPointer<vtkCompositeDataIterator> it;
  it.TakeReference(composite->NewIterator());
  it->SkipEmptyNodesOn();
  for (it->InitTraversal(); !it->IsDoneWithTraversal(); it->GoToNextItem())
  {
    vtkDataObject* leaf = it->GetCurrentDataObject();
    if (auto* pd = vtkPolyData::SafeDownCast(leaf))
    {
      const bool named =
        it->HasCurrentMetaData() && it->GetCurrentMetaData()->Has(vtkCompositeDataSet::NAME());
      visit(pd, it->GetCurrentFlatIndex(),
        named ? it->GetCurrentMetaData()->Get(vtkCompositeDataSet::NAME()) : nullptr);
    }
    else if (leaf)
    {
      countOther(leaf);
    }
  }
}
