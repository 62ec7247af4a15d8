// An independent, brute-force dense voxelizer (the test oracle) and a tree
// walker that checks a built hdt::Volume against it.
//
// The reference implements the definitions of the HDT build from scratch; it
// deliberately includes nothing from hdt/geometry.hpp or hdt/build_steps.hpp,
// so a shared bug cannot hide. It works on PreparedMesh::triangles, the same
// lattice integers the builders see, and is exact (int64 / __int128).
//
//   surface   the voxel's closed box meets a triangle: a 13-axis separating-axis
//             test with the 8 box corners and 3 triangle vertices projected on
//             every axis; touching counts as meeting.
//   parity    along +x, +y, +z from the voxel centre: a triangle counts when the
//             centre, perturbed to P + (eps, eps^2) in the (u, w) plane of the
//             ray ((y,z), (z,x), (x,y)), lies strictly inside the triangle's
//             projection, and the plane is crossed strictly beyond the centre.
//   state     Surface if surface; else Inside when the parity says so (closed
//             meshes: the +x parity, the three agree; open: majority of three);
//             else Outside. Surface-only: no Inside at all.
//
// Cost: O(N^3) memory and time plus the triangles' surface and row work; meant
// for N <= 256 (hard limit 1024).
#pragma once

#include "hdt/lattice.hpp"
#include "hdt/mesh.hpp"
#include "hdt/types.hpp"
#include "hdt/volume.hpp"

#include <gtest/gtest.h>

#include <cstdint>
#include <string>
#include <vector>

namespace hdt {
namespace test {

// ---- exact primitives (exposed for the reference's own unit tests) ----------------

// Does the closed box [lo, hi] (lattice units) meet the triangle (closed)?
// The triangle must be non-degenerate.
bool refBoxMeetsTriangle(const LatticeTriangle& t, const int64_t (&lo)[3], const int64_t (&hi)[3]);

// Sign (+1 / -1) of orient2d(A, B, P + (eps, eps^2)); 0 only when A == B.
int refOrientPerturbed(int64_t au, int64_t aw, int64_t bu, int64_t bw, int64_t pu, int64_t pw);

// Does the ray along +axis from (pu, pw) (perturbed) pass through the triangle's
// projection? If so, `num / den` (den > 0) is the axis coordinate of the crossing.
bool refRayCrossing(const LatticeTriangle& t, int axis, int64_t pu, int64_t pw, __int128& num,
                    int64_t& den);

// ---- the reference volume -----------------------------------------------------------

struct ReferenceVoxels {
  int n = 0;
  bool closed = false;
  bool surfaceOnly = false;
  std::vector<uint8_t> state;  // VoxelState per voxel, x fastest
  std::vector<uint8_t> parity; // bit a: parity of crossings along +axis a (not computed when surfaceOnly)
  uint64_t surfaceCount = 0;
  uint64_t insideCount = 0;
  // Non-surface voxels whose three parities are not all equal. Must be 0 for
  // a closed mesh (a self-check of the reference); informative for open ones.
  uint64_t axisDisagreements = 0;
  std::string firstDisagreement; // the first such voxel, for messages

  size_t index(int x, int y, int z) const { return size_t(x) + size_t(n) * (size_t(y) + size_t(n) * size_t(z)); }
  VoxelState at(int x, int y, int z) const { return VoxelState(state[index(x, y, z)]); }
};

ReferenceVoxels referenceVoxelize(const PreparedMesh& mesh, bool surfaceOnly);

// ---- walking a built volume -----------------------------------------------------------

struct ElementInfo {
  uint64_t index = 0; // global element index
  int level = 0;
  int cell[3] = {0, 0, 0}; // element coordinates at its level
  int edge = 0;            // edge length in voxels
  ElementState state = ElementState::Empty;
  int voxel(int a) const { return cell[a] * edge; } // lowest-corner voxel
};

struct TreeView {
  int n = 0;
  std::vector<uint8_t> dense;         // the volume's dense view, VoxelState per voxel
  std::vector<ElementInfo> elements;  // every element reached, level order
  std::vector<std::string> problems;  // structural errors (empty when the tree is well formed)
  uint64_t boundaryCount = 0;
  uint64_t surfaceVoxels = 0, insideVoxels = 0; // counted on the dense view
};

// Walks the tree level by level, validates its structure (levelStart, payload
// ranges, every child block and every leaf used exactly once, the canonical
// order of docs/hdt-format.md: i-th Branch of a level -> children at
// levelStart[k+1] + 8 i, i-th Boundary -> leaf i, Empty/Full payload 0; no
// Boundary above / Branch at the last level; no 2-bit value 3 in a leaf) and
// builds the dense view. Does not use hdt::voxelAt.
TreeView walkVolume(const Volume& volume);

// Where a voxel lives in the tree, for failure messages ("level 2 element
// #123 cell (1,2,3) Boundary leaf #7, leaf voxel (4,5,6)").
std::string describeVoxel(const Volume& volume, int x, int y, int z);

// The comparison the tests run.
//   closed mesh (or surface-only): every voxel of the dense view equals the
//     reference;
//   open mesh: every voxel of every leaf grid equals the reference, and every
//     Full/Empty element equals the reference state at its lowest-corner voxel;
//   always: a Branch/Boundary element's box holds a reference surface voxel, a
//     Full/Empty element's box holds none; surface-only volumes have no Full.
::testing::AssertionResult volumeMatchesReference(const Volume& volume, const TreeView& view,
                                                  const ReferenceVoxels& ref);

const char* stateName(VoxelState s);
const char* stateName(ElementState s);

} // namespace test
} // namespace hdt
