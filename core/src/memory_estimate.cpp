// The host memory model behind the CPU driver's refusal of oversized builds.
//
// Each part follows the data structures of cpu_builder.cpp and the .hdt
// writer (hdt_file_encode.hpp):
//   root grid   per cell: the element word (4 B), its packed coordinates (8 B,
//               while branching and again while the uniform elements are
//               classified) and 4 B for the joined volume's copy of the words
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
//   winding     under the winding-number test (winding.cpp): the tree over the
//               triangles, and per leaf its origin and the signed crossing
//               count at each of its L^2 rows' exits (int32)
// The leaf and pair counts come from a coarse raster of the triangles at the
// leaf level (touchedLeafCells): every leaf cube a triangle may meet is marked
// once in a bitset, so faces that share leaf cubes (thin walls, both sides of
// a plate) are counted once. When that bitset would be too large, they come
// from the surface instead: a planar piece of area A with unit normal n
// crosses about A (|nx| + |ny| + |nz|) / L^2 cubes of edge L, plus the cubes
// its edges reach into; every triangle touches at least one.
#include "hdt/builder.hpp"

#include "hdt/build_steps.hpp"
#include "hdt/winding_tree.hpp"

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>
#include <tbb/parallel_reduce.h>

#include <algorithm>
#include <atomic>
#include <cmath>
#include <memory>

namespace hdt {
namespace {

// The raster's bitset is used up to (N / L)^3 = 2^30 leaf cubes (128 MiB,
// freed before the build); beyond that the estimate falls back to the area.
constexpr double kMaxRasterCells = double(uint64_t(1) << 30);

struct LeafRaster {
  double leaves = 0; // distinct leaf cubes marked
  double pairs = 0;  // (triangle, marked cube) pairs
};

// Marks, for one triangle, a superset of the leaf cubes (edge S lattice
// units, `count` an axis) whose closed box it meets: per column of cubes along
// its dominant axis d whose rectangle its projection meets, the range of its
// plane over that rectangle (clipped to the triangle's bounds), widened by a
// lattice unit against rounding. Returns the number of cubes marked (with repeats).
template <class Mark>
uint64_t rasterTriangle(const LatticeTriangle& t, int64_t S, int64_t count, Mark&& mark) {
  int64_t n[3], lo[3], hi[3];
  triangleNormal(t, n);
  triangleBounds(t, lo, hi);
  int d = 0;
  for (int a = 1; a < 3; ++a)
    if (std::llabs(n[a]) > std::llabs(n[d])) d = a;
  const int u = (d + 1) % 3, w = (d + 2) % 3;
  int64_t uFirst, uLast, wFirst, wLast, dFirst, dLast;
  cellRange(lo[u], hi[u], S, count, uFirst, uLast);
  cellRange(lo[w], hi[w], S, count, wFirst, wLast);
  // p_d = v0_d - (n_u (p_u - v0_u) + n_w (p_w - v0_w)) / n_d; n_d != 0 for the
  // non-degenerate triangles of a PreparedMesh.
  const double su = double(n[u]) / double(n[d]), sw = double(n[w]) / double(n[d]);
  auto planeD = [&](double pu, double pw) {
    return double(t.v[0][d]) - su * (pu - double(t.v[0][u])) - sw * (pw - double(t.v[0][w]));
  };
  // The projection onto (u, w) is a triangle of orientation sign(n_d): a
  // column is skipped when its closed rectangle lies wholly outside one edge
  // (exact: integer corners, products below 2^53).
  const double orient = n[d] > 0 ? 1.0 : -1.0;
  auto outsideAnEdge = [&](double u0, double u1, double w0, double w1) {
    for (int i = 0; i < 3; ++i) {
      const int j = (i + 1) % 3;
      const double eu = double(t.v[j][u]) - t.v[i][u], ew = double(t.v[j][w]) - t.v[i][w];
      auto side = [&](double pu, double pw) { return orient * (eu * (pw - t.v[i][w]) - ew * (pu - t.v[i][u])); };
      if (std::max(std::max(side(u0, w0), side(u1, w0)), std::max(side(u0, w1), side(u1, w1))) < 0) return true;
    }
    return false;
  };
  uint64_t marked = 0;
  for (int64_t cw = wFirst; cw <= wLast; ++cw) {
    const double w0 = double(std::max(cw * S, lo[w])), w1 = double(std::min((cw + 1) * S, hi[w]));
    for (int64_t cu = uFirst; cu <= uLast; ++cu) {
      const double u0 = double(std::max(cu * S, lo[u])), u1 = double(std::min((cu + 1) * S, hi[u]));
      if (outsideAnEdge(u0, u1, w0, w1)) continue;
      const double c[4] = {planeD(u0, w0), planeD(u1, w0), planeD(u0, w1), planeD(u1, w1)};
      const double dLo = std::max(double(lo[d]), std::min(std::min(c[0], c[1]), std::min(c[2], c[3])));
      const double dHi = std::min(double(hi[d]), std::max(std::max(c[0], c[1]), std::max(c[2], c[3])));
      cellRange(int64_t(std::floor(dLo)) - 1, int64_t(std::ceil(dHi)) + 1, S, count, dFirst, dLast);
      for (int64_t cd = dFirst; cd <= dLast; ++cd) {
        int64_t cell[3];
        cell[d] = cd;
        cell[u] = cu;
        cell[w] = cw;
        mark(uint64_t(cell[0]) + uint64_t(count) * (uint64_t(cell[1]) + uint64_t(count) * uint64_t(cell[2])));
        ++marked;
      }
    }
  }
  return marked;
}

// Leaf cubes the mesh touches, counted once each (an upper bound of the
// build's leaf grids), and the (triangle, cube) pairs; zero leaves when the
// grid of leaf cubes is too large for the bitset.
LeafRaster touchedLeafCells(const PreparedMesh& mesh) {
  const GridSpec& g = mesh.grid;
  const int64_t count = g.resolution / g.leafSize;
  if (std::pow(double(count), 3) > kMaxRasterCells) return {};
  const int64_t S = int64_t(g.leafSize) * kLatticePerVoxel;
  const size_t words = size_t((uint64_t(count) * uint64_t(count) * uint64_t(count) + 63) / 64);
  std::unique_ptr<std::atomic<uint64_t>[]> bits(new std::atomic<uint64_t>[words]);
  tbb::parallel_for(size_t(0), words, [&](size_t i) { bits[i].store(0, std::memory_order_relaxed); });
  const auto& tris = mesh.triangles;
  LeafRaster r;
  r.pairs = tbb::parallel_reduce(
      tbb::blocked_range<size_t>(0, tris.size(), 256), 0.0,
      [&](const tbb::blocked_range<size_t>& range, double pairs) {
        for (size_t i = range.begin(); i != range.end(); ++i) {
          pairs += double(rasterTriangle(tris[i], S, count, [&](uint64_t cell) {
            const uint64_t bit = uint64_t(1) << (cell & 63);
            std::atomic<uint64_t>& word = bits[cell >> 6];
            if (!(word.load(std::memory_order_relaxed) & bit)) word.fetch_or(bit, std::memory_order_relaxed);
          }));
        }
        return pairs;
      },
      std::plus<double>());
  r.leaves = tbb::parallel_reduce(
      tbb::blocked_range<size_t>(0, words, 1 << 14), 0.0,
      [&](const tbb::blocked_range<size_t>& range, double n) {
        for (size_t i = range.begin(); i != range.end(); ++i) {
          const uint64_t word = bits[i].load(std::memory_order_relaxed);
          n += double(popcount32(uint32_t(word)) + popcount32(uint32_t(word >> 32)));
        }
        return n;
      },
      std::plus<double>());
  return r;
}

} // namespace

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
  // The raster's counts; without it, the cubes of edge L the surface meets
  // (closed cubes: touching counts, and curved or folded surfaces meet a little
  // more than a plane: factor 1.1), and the pairs: each triangle meets the
  // cubes its area crosses, those its edges run into, and at least one.
  const LeafRaster raster = touchedLeafCells(mesh);
  const double leafCells = std::pow(double(g.resolution) / L, 3);
  const double leaves =
      raster.leaves > 0 ? raster.leaves : std::min(leafCells, 1.1 * projected / (L * L) + 8);
  const double pairs =
      raster.leaves > 0 ? raster.pairs : 1.1 * projected / (L * L) + perimeter / L + triangles;

  HostMemoryEstimate e;
  e.leafGrids = leaves;
  e.leafPairs = pairs;
  const double axes = mesh.closed ? 1 : 3;
  const double rowBytes = std::ceil(L * L / 32) * 4;
  const double cellBytes = 4 + 8 + 4; // element, coordinates, joined copy
  e.rootGrid = uint64_t(std::pow(double(g.rootGrid), 3) * cellBytes);
  e.tree = uint64_t(leaves * 2.7 * cellBytes);
  const double leafStates = L * L * L / 4;
  e.leaves = uint64_t(leaves * (leafStates + 16 + axes * (3 * rowBytes + 16)));
  e.pairs = uint64_t(pairs * (3 * 8 + 4));
  e.triangles = uint64_t(triangles * (36 + 3 * 24));
  // The writer holds the compressed blocks at their exact size (and version
  // 2's one-frame buffer of ZSTD_compressBound(raw) becomes resident only
  // where written): a quarter of the raw leaf bytes at most on the meshes of
  // bench/results/memory-estimate.md.
  e.compression = uint64_t(0.25 * leaves * leafStates);
  if (mesh.insideTest == InsideTest::WindingNumber) {
    const double treeBytes = sizeof(WindingTriangle) + sizeof(LatticeTriangle) + 2 * sizeof(WindingNode);
    e.winding = uint64_t(triangles * treeBytes + leaves * (L * L * 4 + 12 + 4));
  }
  const double build = double(e.rootGrid + e.tree + e.leaves + e.pairs + e.triangles + e.winding);
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
