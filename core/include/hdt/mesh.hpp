// Triangle meshes as the library takes them, and their preparation on the lattice.
#pragma once

#include "hdt/config.hpp"
#include "hdt/huge_pages.hpp"
#include "hdt/label_field.hpp"
#include "hdt/lattice.hpp"

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <map>
#include <string>
#include <vector>

namespace hdt {

// An indexed triangle soup: 3 coordinates a point, 3 point indices a triangle.
struct TriangleMesh {
  std::vector<double> points;
  std::vector<uint32_t> triangles;
  // Optional part labels (hdt/labels.hpp): empty, or one label >= 1 per
  // triangle; names of labels, when the source has them.
  std::vector<Label> triangleLabels;
  std::map<Label, std::string> labelNames;

  size_t pointCount() const { return points.size() / 3; }
  size_t triangleCount() const { return triangles.size() / 3; }
};

// Lattice triangles; resize leaves new ones unwritten and large arrays get
// 2 MiB pages: prepareMesh writes them in parallel right after sizing, where
// a value-initialising resize would zero MBs in one thread first.
using LatticeTriangles = std::vector<LatticeTriangle, HugePageScratchAllocator<LatticeTriangle>>;

// The mesh snapped to the lattice of a placed grid, ready for either driver.
struct PreparedMesh {
  GridSpec grid;
  LatticeTriangles triangles;             // non-degenerate ones only, input order
  size_t inputTriangles = 0;
  size_t degenerateTriangles = 0;         // zero area after snapping: dropped
  // Kept triangles with the same three lattice corners (in any order) as
  // another kept one: each copy beyond the first counts. Duplicates cancel in
  // the inside parity, so a doubled closed mesh has nothing inside.
  size_t duplicateTriangles = 0;
  // Every edge is shared by an even number of triangles. Then all three ray
  // directions agree and the classifier needs only one of them.
  bool closed = false;
  bool surfaceOnly = false;               // from BuildConfig: skip classification
  // The inside test asked for (BuildConfig) and the one the drivers run:
  // Auto resolved by `closed` (resolveInsideTest, winding_tree.hpp).
  InsideTest requestedInsideTest = InsideTest::Parity;
  InsideTest insideTest = InsideTest::Parity;
};

// Whether a build of `mesh` ends with the winding-number pass (a solid build
// under WindingNumber): its drivers then build the surface only (the parity
// passes would be discarded) and leave the rest of the progress to the pass.
inline bool windingPassFollows(const PreparedMesh& mesh) {
  return !mesh.surfaceOnly && mesh.insideTest == InsideTest::WindingNumber;
}

// Coordinate `axis` of point x snapped to the lattice of grid g: the only
// geometry the drivers see (prepareMesh), shared with the data transfer
// (hdt/transfer.hpp), which must test the same lattice triangles. Points
// outside the grid (unreferenced ones) are clamped harmlessly.
inline int32_t snapToLattice(double x, const GridSpec& g, int axis) {
  const double q = (x - g.origin[size_t(axis)]) * (double(kLatticePerVoxel) / g.voxelSize);
  const double limit = double(int64_t(g.resolution) * kLatticePerVoxel);
  // std::llround of c >= 0 (halves away from zero), without its library call
  // so that loops of it vectorise: c - trunc(c) is exact.
  const double c = std::min(std::max(q, 0.0), limit), whole = std::trunc(c);
  return int32_t(whole) + int32_t(c - whole >= 0.5);
}

// Bounds of all points referenced by triangles. Throws Error(BadInput) for an
// empty mesh, an index out of range or a non-finite coordinate.
void meshBounds(const TriangleMesh& mesh, std::array<double, 3>& lo, std::array<double, 3>& hi);

// Validates the mesh and configuration, places the grid and snaps the mesh.
// Throws Error with a message that says what is wrong.
PreparedMesh prepareMesh(const TriangleMesh& mesh, const BuildConfig& config);

// Wall time of prepareMesh's steps in ms, for benchmarks (bench/gpu/e2e_bench.cpp).
struct PrepareTimes {
  double bounds = 0;              // configuration and mesh checks, bounds, grid placement
  double numbers = 0;             // points snapped to the lattice, numbers for the distinct lattice points
  double closedAndDuplicates = 0; // the non-degenerate triangles, in order; edges and corners as point numbers, bucketed
};
PreparedMesh prepareMesh(const TriangleMesh& mesh, const BuildConfig& config, PrepareTimes* times);

// Host bytes that prepareMesh's large arrays (its scratch and the lattice
// triangles) take at most at once for a mesh of this size: reserved as warm
// pages beforehand (warm_pages.hpp), its first call in a process runs as fast
// as a warm one.
size_t prepareMeshWarmBytes(size_t triangles, size_t points);

struct Volume;

// Things about a finished build its user should hear about although nothing
// failed: duplicated triangles, a closed mesh with no inside voxel. One
// sentence each; empty when all is well. The CLI prints them, the VTK filter
// emits them with vtkWarningMacro.
std::vector<std::string> buildWarnings(const PreparedMesh& mesh, const Volume& volume);

} // namespace hdt
