// Closedness and duplicated triangles of a mesh on the lattice (prepareMesh),
// computed on numbers of its lattice points instead of their coordinates:
// 4-byte point numbers instead of 12-byte points make the edge and corner
// keys a fraction of the bytes to move and compare.
#pragma once

#include <cstddef>
#include <cstdint>
#include <functional>

namespace hdt {

// The passes below read their items (points, triangles) in fixed blocks, at
// most 64, in parallel: block k is items [k size, min(n, (k + 1) size)).
struct ItemBlocks {
  size_t count = 0, size = 0;
};
ItemBlocks itemBlocks(size_t n);

// The caller's own work on block `block` = items [begin, end), run by the pass
// in the same task just before it reads those items: e.g. writing them, so
// that the pass reads them from cache instead of in a loop of their own.
using BlockWork = std::function<void(size_t block, size_t begin, size_t end)>;

// A lattice point and its number: 16 bytes, so that a triangle's corner gives
// its coordinates and its number in one cache line.
struct NumberedPoint {
  int32_t x, y, z;
  uint32_t number;
};

// points[i].number = the smallest index j <= i of the `count` points with the
// same x, y, z as point i: two points get the same number exactly when they
// are equal (a mesh's own indices where its points are unique). Linear,
// parallel, the same result whatever the thread count. count must be at most
// 2^32. `before` (if set) runs on every block of the points
// (itemBlocks(count)) before it reads their coordinates.
void numberLatticePoints(NumberedPoint* points, size_t count, const BlockWork& before = {});

struct SurfaceTopology {
  // Every undirected edge (pair of point numbers) is used by an even number
  // of triangles: the surface is a mod-2 cycle.
  bool closed = true;
  // Triangles with the same three point numbers (in any order) as another
  // one: each copy beyond the first counts.
  size_t duplicateTriangles = 0;
};

// The topology of the triangles t < `triangles` with keep[t] != 0 (all of
// them where keep is null), whose corners are the point numbers
// points[indices[3 t + j]].number, j < 3 (indices[3 t + j] where points is
// null): three distinct numbers a kept triangle, all below pointRange (at most
// 2^32). Linear and parallel. `before` (if set) runs on every block of the
// triangles (itemBlocks(triangles)) before their keep flags and indices are
// read (none runs where triangles or pointRange is 0).
SurfaceTopology surfaceTopology(const uint32_t* indices, const uint8_t* keep, size_t triangles,
                                const NumberedPoint* points, uint64_t pointRange, const BlockWork& before = {});

} // namespace hdt
