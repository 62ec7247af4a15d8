// Arrays carried by the surface voxels of a volume: mesh point and cell data
// transferred onto them (hdt/transfer.hpp).
//
// One tuple per surface voxel, surface voxels numbered in leaf order and, in
// a leaf, in voxel order v = x + L (y + L z) (the leaf words' order): the
// "surface index" (surfaceVoxelStart gives each leaf's first one). Inside and
// outside voxels carry no value; consumers show them as NaN (hdt/transfer.hpp).
#pragma once

#include <cstdint>
#include <string>
#include <vector>

namespace hdt {

// Where a transferred array came from on the mesh.
enum class ArraySource : uint8_t { Point = 0, Cell = 1 };

struct VoxelArray {
  std::string name;
  ArraySource source = ArraySource::Point;
  uint32_t components = 1;
  std::vector<float> values; // surface voxels * components, tuples in surface index order
};

} // namespace hdt
