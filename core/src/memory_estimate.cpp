// The host memory model behind the CPU driver's refusal of oversized builds.
//
// Each part follows the data structures of cpu_builder.cpp and hdt_file.cpp:
//   root grid   per cell: the element word (4 B), its packed coordinates (8 B)
//               and, for untouched cells, a UniformElement (24 B) in a vector
//               that grows by doubling (x 1.5 on average, x 2 at worst)
//   tree        per leaf: the leaf level's cells (8 per touched parent, about
//               2 per leaf on a surface) and the levels above, as above
//   leaves      per leaf: L^3 / 4 bytes of states, coordinates and pair start,
//               and per classified ray axis the entry/exit rows and line entry
//   pairs       8 B per (leaf, triangle) pair, gathered from per-thread vectors
//               and sorted: about 3 copies at the peak, plus the rank array
//   triangles   the prepared lattice triangles (36 B) and their edge list
//   reading     the mesh file's scene and copies while it is read and snapped
//   compression writing the .hdt keeps the volume and zstd's output buffer
//               (resident: the compressed size, taken as 1/4 of the leaf bytes)
// The leaf and pair counts come from the surface: a planar piece of area A
// with unit normal n crosses about A (|nx| + |ny| + |nz|) / L^2 cubes of edge
// L, plus the cubes its edges reach into; every triangle touches at least one.
#include "hdt/builder.hpp"

#include "hdt/build_steps.hpp"

#include <algorithm>
#include <cmath>

namespace hdt {

HostMemoryEstimate estimateHostMemory(const PreparedMesh& mesh) {
  const GridSpec& g = mesh.grid;
  const double L = g.leafSize, perVoxel = double(kLatticePerVoxel);
  double projected = 0, perimeter = 0; // voxel units
  for (const LatticeTriangle& t : mesh.triangles) {
    int64_t n[3];
    triangleNormal(t, n); // twice the area times the unit normal
    projected += 0.5 * (std::fabs(double(n[0])) + std::fabs(double(n[1])) + std::fabs(double(n[2])));
    for (int j = 0; j < 3; ++j) {
      double d2 = 0;
      for (int a = 0; a < 3; ++a) {
        const double d = double(t.v[(j + 1) % 3][a]) - double(t.v[j][a]);
        d2 += d * d;
      }
      perimeter += std::sqrt(d2);
    }
  }
  projected /= perVoxel * perVoxel;
  perimeter /= perVoxel;
  const double triangles = double(mesh.triangles.size());
  // Cubes of edge L the surface meets (closed cubes: touching counts, and
  // curved or folded surfaces meet a little more than a plane: factor 1.1), and
  // the pairs: each triangle meets the cubes its area crosses, those its edges
  // run into, and at least one.
  const double leafCells = std::pow(double(g.resolution) / L, 3);
  const double leaves = std::min(leafCells, 1.1 * projected / (L * L) + 8);
  const double pairs = 1.1 * projected / (L * L) + perimeter / L + triangles;

  HostMemoryEstimate e;
  e.leafGrids = leaves;
  e.leafPairs = pairs;
  const double axes = mesh.closed ? 1 : 3;
  const double rowBytes = std::ceil(L * L / 32) * 4;
  const double cellBytes = 4 + 8 + 24 * 1.2; // element, coordinates, uniform entry and its growth slack
  e.rootGrid = uint64_t(std::pow(double(g.rootGrid), 3) * cellBytes);
  e.tree = uint64_t(leaves * 2.7 * cellBytes);
  const double leafStates = L * L * L / 4;
  e.leaves = uint64_t(leaves * (leafStates + 16 + axes * (3 * rowBytes + 16)));
  e.pairs = uint64_t(pairs * (3 * 8 + 4));
  e.triangles = uint64_t(triangles * (36 + 3 * 24));
  // zstd's output buffer is ZSTD_compressBound(raw) but only the pages it
  // writes become resident: the compressed size, a quarter of the raw leaf
  // bytes at most on the meshes of bench/results/memory-estimate.md.
  e.compression = uint64_t(0.25 * leaves * leafStates);
  const double build = double(e.rootGrid + e.tree + e.leaves + e.pairs + e.triangles);
  // Memory freed by one phase mostly stays resident (allocator arenas of the
  // worker threads), so the phases add up rather than overlap: reading and
  // preparing the mesh (assimp's scene, the input and lattice copies, the
  // edge sort: about 400 B a triangle), the build, and the write's buffer.
  const double reading = 400 * triangles;
  const double process = 16.0 * (1 << 20); // libraries, thread stacks
  e.total = uint64_t(reading + build + double(e.compression) + process);
  return e;
}

uint64_t estimateHostBytes(const PreparedMesh& mesh) { return estimateHostMemory(mesh).total; }

} // namespace hdt
