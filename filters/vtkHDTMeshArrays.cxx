// Input arrays as per-point / per-triangle tuples (vtkHDTMeshArrays.h).
#include "vtkHDTMeshArrays.h"

#include "vtkHDTMeshConversion.h"

#include "hdt/error.hpp"

#include "vtkCellArray.h"
#include "vtkCellData.h"
#include "vtkDataArray.h"
#include "vtkPointData.h"
#include "vtkPolyData.h"

#include <limits>

namespace
{

// The blocks vtkHDTMeshConversion::AppendPolyData takes triangles from.
bool contributes(vtkPolyData* pd)
{
  return pd->GetNumberOfPoints() > 0 && (pd->GetNumberOfPolys() > 0 || pd->GetNumberOfStrips() > 0);
}

// Components of the array of that name in the blocks that have it (0: none).
uint32_t componentsOf(vtkDataObject* input, const std::string& name, bool cells)
{
  uint32_t components = 0;
  vtkHDTMeshConversionInfo info;
  vtkHDTMeshConversion::ForEachPolyData(input, info, [&](vtkPolyData* pd, unsigned int, const char*) {
    vtkDataArray* a = cells ? pd->GetCellData()->GetArray(name.c_str()) : pd->GetPointData()->GetArray(name.c_str());
    if (!a || !contributes(pd))
    {
      return;
    }
    const uint32_t c = uint32_t(a->GetNumberOfComponents());
    if (components && c != components)
    {
      throw hdt::Error(hdt::ErrorKind::BadInput,
        "Arrays To Transfer: '" + name + "' has " + std::to_string(components) + " components in one block and " +
          std::to_string(c) + " in another");
    }
    components = c;
  });
  if (!components)
  {
    throw hdt::Error(hdt::ErrorKind::BadInput,
      std::string("Arrays To Transfer: the input has no numeric ") + (cells ? "cell" : "point") + " array '" +
        name + "' on its polygons");
  }
  return components;
}

void appendTuples(vtkDataArray* a, vtkIdType tuple, size_t count, hdt::MeshArray& out)
{
  const double nan = std::numeric_limits<double>::quiet_NaN();
  for (size_t k = 0; k < count; ++k)
  {
    for (uint32_t j = 0; j < out.components; ++j)
    {
      out.values.push_back(a ? a->GetComponent(tuple, int(j)) : nan);
    }
  }
}

hdt::MeshArray gather(vtkDataObject* input, const std::string& name, bool cells, const hdt::TriangleMesh& mesh)
{
  hdt::MeshArray out;
  out.name = name;
  out.source = cells ? hdt::ArraySource::Cell : hdt::ArraySource::Point;
  out.components = componentsOf(input, name, cells);
  vtkHDTMeshConversionInfo info;
  vtkHDTMeshConversion::ForEachPolyData(input, info, [&](vtkPolyData* pd, unsigned int, const char*) {
    if (!contributes(pd))
    {
      return;
    }
    if (!cells)
    {
      vtkDataArray* a = pd->GetPointData()->GetArray(name.c_str());
      for (vtkIdType p = 0; p < pd->GetNumberOfPoints(); ++p)
      {
        appendTuples(a, p, 1, out);
      }
      return;
    }
    vtkDataArray* a = pd->GetCellData()->GetArray(name.c_str());
    // Cell ids of vtkPolyData: verts, lines, polys, strips.
    vtkIdType cell = pd->GetNumberOfVerts() + pd->GetNumberOfLines();
    for (vtkCellArray* list : { pd->GetPolys(), pd->GetStrips() })
    {
      for (vtkIdType c = 0; c < list->GetNumberOfCells(); ++c, ++cell)
      {
        const vtkIdType n = list->GetCellSize(c);
        if (n >= 3)
        {
          appendTuples(a, cell, size_t(n - 2), out);
        }
      }
    }
  });
  const size_t tuples = cells ? mesh.triangleCount() : mesh.pointCount();
  if (out.values.size() != tuples * out.components)
  {
    throw hdt::Error(hdt::ErrorKind::BadInput,
      "Arrays To Transfer: '" + name + "': a polygon did not triangulate into n - 2 triangles; cannot match "
                                       "triangles to cells");
  }
  return out;
}

} // namespace

std::vector<hdt::MeshArray> vtkHDTGatherMeshArrays(vtkDataObject* input,
  const std::vector<std::string>& pointArrays, const std::vector<std::string>& cellArrays,
  const hdt::TriangleMesh& mesh)
{
  std::vector<hdt::MeshArray> out;
  for (const std::string& name : pointArrays)
  {
    out.push_back(gather(input, name, false, mesh));
  }
  for (const std::string& name : cellArrays)
  {
    out.push_back(gather(input, name, true, mesh));
  }
  return out;
}
