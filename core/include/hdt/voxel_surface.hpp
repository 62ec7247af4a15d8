// The outer surface of a voxelized solid, read straight from the HDT.
//
// A face lies between an occupied cell and an unoccupied one (or the outside
// of the grid). Occupied: not Outside; in surface-only builds, Surface (the
// faces of the surface voxels that face non-surface neighbours). Each face
// carries the state of its occupied cell (Inside or Surface).
//
// Level of detail (maxDepth, the hyper tree grid's depth: 0 = root cells,
// height h = leaf grids, h + log2 L = voxels; -1 or beyond = voxels): the
// surface is that of the grid of cells of edge c = rootCellVoxels >> maxDepth,
// each cell taking the largest state of its voxels (Surface if any voxel is
// Surface, else Inside if any is Inside, else Outside). So a cell at the depth
// limit counts as occupied when any voxel below it is; elements larger than c
// keep their own state. This is the dense volume coarsened by c with max().
//
// In a labelled volume (labels.hpp) each face also carries the part label of
// its occupied cell; a cell coarser than a voxel takes the hyper tree grid's
// label, the majority of its non-Outside voxels (hdt::majorityLabel).
//
// Faces are extracted per leaf grid and per uniform element in parallel, and
// coplanar faces of one state and one label are merged into rectangles
// (greedy, per slice of a leaf grid; an element face bordering only
// unoccupied space is one rectangle). The order of the output depends on the
// volume only.
#pragma once

#include "hdt/volume.hpp"

#include <cstdint>
#include <functional>
#include <vector>

namespace hdt {

// One rectangle in voxel units: the plane `plane` across `axis` (0 x, 1 y,
// 2 z), spanning [u, u + du) x [v, v + dv) of the two other axes in
// increasing order (x: y, z; y: x, z; z: x, y). `outward` is +1 when the
// occupied cell is on the low side (the face looks along +axis), -1 otherwise.
struct SurfaceQuad {
  uint8_t axis = 0;
  int8_t outward = 1;
  uint8_t state = 0;  // VoxelState of the occupied cell
  uint16_t label = 0; // its part label (labelled volumes; 0 otherwise)
  int32_t plane = 0, u = 0, v = 0, du = 0, dv = 0;
};

struct SurfaceOptions {
  int maxDepth = -1; // level of detail, see above
  bool merge = true; // false: one quad per cell face (for checks)
  // Only the faces whose occupied cell lies in root cells [cellsFirst,
  // cellsEnd) (x fastest): a process's piece of a distributed volume. The
  // volume must hold the true contents of the face neighbours of those cells
  // (range_exchange.hpp, the piece volume with its halo).
  uint64_t cellsFirst = 0, cellsEnd = UINT64_MAX;
};

// Quads in voxel units, in a fixed order. Throws Error(InvalidArgument) for a
// volume whose grid cannot be walked (leaf size not 8, 16 or 32).
std::vector<SurfaceQuad> extractSurfaceQuads(const Volume& volume, const SurfaceOptions& options = {});

// The same quads as plain arrays ready for a mesh (a VTK wrapper copies them).
struct VoxelSurface {
  std::vector<float> points;   // 4 corners a quad, xyz, in mesh units (grid origin + voxel size);
                               // counter-clockwise seen from the unoccupied side
  std::vector<uint8_t> states;  // VoxelState a quad
  std::vector<uint16_t> labels; // part label a quad; empty for an unlabelled volume
  size_t quadCount() const { return states.size(); }
};

VoxelSurface extractVoxelSurface(const Volume& volume, const SurfaceOptions& options = {});

// The same arrays written straight into the caller's memory (a VTK array, no
// copy): `allocate` is called once with the quad count and returns room for
// 12 * quads floats, quads states and, when not null, quads labels.
struct SurfaceBuffers {
  float* points = nullptr;
  uint8_t* states = nullptr;
  uint16_t* labels = nullptr;
};
void extractVoxelSurfaceInto(const Volume& volume, const SurfaceOptions& options,
                             const std::function<SurfaceBuffers(size_t quads)>& allocate);

// Cell edge in voxels at a level of detail (see above).
int surfaceCellEdge(const GridSpec& grid, int maxDepth);

} // namespace hdt
