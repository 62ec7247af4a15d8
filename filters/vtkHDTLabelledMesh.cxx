// Labels per triangle from the block or a cell array (vtkHDTLabelledMesh.h).
#include "vtkHDTLabelledMesh.h"

#include "hdt/error.hpp"
#include "hdt/mesh.hpp"

#include "vtkCellArray.h"
#include "vtkCellData.h"
#include "vtkCompositeDataIterator.h"
#include "vtkCompositeDataSet.h"
#include "vtkDataArray.h"
#include "vtkInformation.h"
#include "vtkPolyData.h"
#include "vtkSmartPointer.h"

#include <algorithm>

namespace
{

// The triangles vtkHDTMeshConversion makes of each poly and strip cell:
// max(0, n - 2), polys first; label per cell appended per triangle.
void labelByCellArray(vtkPolyData* pd, const std::string& name, size_t first, hdt::TriangleMesh& mesh)
{
  vtkDataArray* a = pd->GetCellData()->GetArray(name.c_str());
  if (!a || a->GetNumberOfComponents() != 1 || a->GetDataType() == VTK_FLOAT || a->GetDataType() == VTK_DOUBLE)
  {
    throw hdt::Error(hdt::ErrorKind::BadInput,
      "Label By: the input has no integer cell array '" + name + "' with one component");
  }
  // Cell ids of vtkPolyData: verts, lines, polys, strips.
  vtkIdType cell = pd->GetNumberOfVerts() + pd->GetNumberOfLines();
  for (vtkCellArray* cells : { pd->GetPolys(), pd->GetStrips() })
  {
    for (vtkIdType c = 0; c < cells->GetNumberOfCells(); ++c, ++cell)
    {
      const vtkIdType n = cells->GetCellSize(c);
      if (n < 3)
      {
        continue;
      }
      const double value = a->GetTuple1(cell);
      if (!(value >= 1 && value <= 65535))
      {
        throw hdt::Error(hdt::ErrorKind::BadInput,
          "Label By: cell " + std::to_string(cell) + " has the label " + std::to_string(int64_t(value)) +
            " in '" + name + "' (labels are 1 to 65535; 0 means outside)");
      }
      mesh.triangleLabels.insert(mesh.triangleLabels.end(), size_t(n - 2), hdt::Label(value));
    }
  }
  if (mesh.triangleLabels.size() != mesh.triangleCount() || first > mesh.triangleLabels.size())
  {
    throw hdt::Error(hdt::ErrorKind::BadInput,
      "Label By: a polygon did not triangulate into n - 2 triangles; cannot match triangles to cells");
  }
}

void appendOne(vtkPolyData* pd, bool byBlock, const std::string& arrayName, hdt::Label block,
  hdt::TriangleMesh& mesh, vtkHDTMeshConversionInfo& info)
{
  const size_t first = mesh.triangleCount();
  vtkHDTMeshConversion::AppendPolyData(pd, mesh, info);
  if (byBlock)
  {
    mesh.triangleLabels.resize(mesh.triangleCount(), block);
  }
  else
  {
    labelByCellArray(pd, arrayName, first, mesh);
  }
}

} // namespace

void vtkHDTAppendLabelledMesh(vtkDataObject* input, bool byBlock, const std::string& arrayName,
  hdt::TriangleMesh& mesh, vtkHDTMeshConversionInfo& info)
{
  // A lone polydata is block 1; a composite's blocks are their flat indices.
  const bool composite = vtkCompositeDataSet::SafeDownCast(input) != nullptr;
  vtkHDTMeshConversion::ForEachPolyData(
    input, info, [&](vtkPolyData* pd, unsigned int flat, const char* name) {
      const unsigned int block = composite ? flat : 1;
      if (byBlock && (block < 1 || block > 65535))
      {
        throw hdt::Error(hdt::ErrorKind::BadInput,
          "Label By Block: flat block index " + std::to_string(block) +
            " is beyond the 65535 labels");
      }
      appendOne(pd, byBlock, arrayName, hdt::Label(block), mesh, info);
      if (byBlock && name)
      {
        mesh.labelNames[hdt::Label(block)] = name;
      }
    });
}
