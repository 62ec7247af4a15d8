// Point and cell arrays of a vtkPolyData / composite input as hdt::MeshArray
// tuples matching the triangle mesh vtkHDTMeshConversion makes of it (for the
// data transfer, hdt/transfer.hpp).
//
// Point arrays: one tuple per point of every polydata that contributes
// triangles, in order. Cell arrays: the tuple of the poly or strip cell each
// triangle comes from (a cell of n points gives n - 2). A block without the
// array contributes NaN tuples.
#pragma once

#include "hdt/transfer.hpp"

#include <string>
#include <vector>

class vtkDataObject;

// Throws hdt::Error(BadInput) when no block has an array of that name, when
// its blocks disagree on the component count, or when triangles cannot be
// matched to cells.
std::vector<hdt::MeshArray> vtkHDTGatherMeshArrays(vtkDataObject* input,
  const std::vector<std::string>& pointArrays, const std::vector<std::string>& cellArrays,
  const hdt::TriangleMesh& mesh);
