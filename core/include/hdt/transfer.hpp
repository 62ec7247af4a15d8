// Mesh data onto surface voxels (issue 17, "data transfer").
//
// A host pass over the surface voxels of a built volume, after the build:
// the same code whichever driver built the volume, so CPU and CUDA builds
// give identical arrays by construction; every voxel's value is a fixed
// function of the mesh and the volume (no reduction whose order depends on
// the thread count; the code base compiles with -ffp-contract=off).
//
// The triangle of a surface voxel (one rule, the surface label rule's):
//   * the candidates are the triangles whose lattice triangle (the snapped,
//     non-degenerate one the drivers saw) touches the voxel's closed cube by
//     the build's own test (triangleOverlapsCube): the triangles that made
//     the voxel a surface voxel;
//   * in a labelled volume, only those of the voxel's label: the overlap
//     policy picks the part (hdt/labels.hpp), then this rule a triangle of it;
//   * of those, the one whose closest point (mesh coordinates, double) is
//     nearest to the voxel centre; equal distances go to the lowest index.
// Values (computed in double, stored as float32, components kept):
//   * cell data: the chosen triangle's tuple;
//   * point data: the barycentric interpolation of its three corners' tuples
//     at the closest point of the chosen triangle to the voxel centre.
// Inside and outside voxels have no value (the arrays hold surface voxels
// only); the hyper tree grid and the voxel surface show them as NaN.
#pragma once

#include "hdt/mesh.hpp"
#include "hdt/volume.hpp"

#include <array>
#include <cstdint>
#include <string>
#include <vector>

namespace hdt {

// An array of the mesh to transfer: one tuple of `components` values per point
// (ArraySource::Point) or per triangle (ArraySource::Cell).
struct MeshArray {
  std::string name;
  ArraySource source = ArraySource::Point;
  uint32_t components = 1;
  std::vector<double> values;
};

// Limits the file format and the filters rely on.
constexpr uint32_t kMaxArrayComponents = 64;
constexpr size_t kMaxArrayNameLength = 255;
constexpr size_t kMaxVoxelArrays = 256;

// Per leaf (leaf order) the surface index of its first surface voxel; one
// more entry at the end, the number of surface voxels.
std::vector<uint64_t> surfaceVoxelStart(const Volume& volume);

// The rank of voxel v (x + L (y + L z)) among the surface voxels of its leaf
// (the voxels before it in voxel order); v itself need not be one.
inline uint32_t surfaceRankInLeaf(const uint32_t* leafWords, uint32_t v) {
  uint32_t rank = 0;
  for (uint32_t w = 0; w < v / kVoxelsPerWord; ++w) rank += planeCount(leafWords[w], kSurfacePlane);
  const uint32_t bits = 2 * (v % kVoxelsPerWord); // fields below v in its word
  const uint32_t below = bits == 0 ? 0u : (leafWords[v / kVoxelsPerWord] & ((1u << bits) - 1u));
  return rank + planeCount(below, kSurfacePlane);
}

// The chosen triangle (index into mesh.triangles / 3) of every surface voxel,
// in surface index order. `mesh` must be the mesh the volume was built from
// (same points, triangles and labels); a surface voxel that no candidate
// touches means it is not, and throws Error(InvalidArgument).
std::vector<uint32_t> chosenTriangles(const TriangleMesh& mesh, const Volume& volume);

// Closest point of triangle (a, b, c) to p, as barycentric weights (wa, wb,
// wc), wa + wb + wc = 1 up to rounding (Ericson, Real-Time Collision
// Detection, 5.1.5: Voronoi regions of the corners, edges and face).
std::array<double, 3> closestPointWeights(const double* p, const double* a, const double* b, const double* c);

// Transfers `arrays` onto the surface voxels of `volume` (appended to
// volume.arrays, in the given order). Throws Error(BadInput) for an array of
// the wrong size, no or too many components, an empty, duplicate (also with
// the volume's arrays) or too long name, more than kMaxVoxelArrays arrays.
void transferArrays(const TriangleMesh& mesh, const std::vector<MeshArray>& arrays, Volume& volume);

// Checks a volume's arrays against its surface voxels (names, components,
// sizes); throws Error(BadInput) naming the first problem. The .hdt writer
// refuses a volume that fails it.
void validateVoxelArrays(const Volume& volume);

// Bytes the transferred arrays take in memory.
uint64_t voxelArrayBytes(const Volume& volume);

// The value of component `component` of array `array` at global voxel
// (x, y, z): NaN for a voxel that is not a surface voxel. Slow: for tests and
// spot checks.
float voxelArrayValue(const Volume& volume, size_t array, uint32_t component, int x, int y, int z);

} // namespace hdt
