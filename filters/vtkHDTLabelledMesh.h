// vtkPolyData / composite input -> hdt::TriangleMesh with part labels
// (hdt/labels.hpp), for vtkHDTVoxelizer's Label By.
//
//   Block: label = the flat index of the composite leaf the triangle comes
//     from (1, 2, ...; a lone vtkPolyData is block 1), named after the
//     block's NAME meta-data;
//   CellArray: the value of an integer cell array of that name (1..65535;
//     0 is reserved for outside) of the cell the triangle comes from.
// The triangles are vtkHDTMeshConversion's (a cell of n points gives n - 2).
#pragma once

#include "vtkHDTMeshConversion.h"

#include <string>

class vtkDataObject;
namespace hdt
{
struct TriangleMesh;
}

// Throws hdt::Error(BadInput) when the input cannot be labelled that way (a
// missing or non-integer array, a label out of range, a flat index > 65535).
void vtkHDTAppendLabelledMesh(vtkDataObject* input, bool byBlock, const std::string& arrayName,
  hdt::TriangleMesh& mesh, vtkHDTMeshConversionInfo& info);
