// Closedness and duplicated triangles of a mesh on the lattice (prepareMesh),
// computed on numbers of its lattice points instead of their coordinates:
// 4-byte point numbers instead of 12-byte points make the edge and corner
// keys a fraction of the bytes to move and compare.
#pragma once

#include <cstddef>
#include <cstdint>

namespace hdt {

// numbers[i] = the smallest index j <= i of the `count` points (x, y, z, 3
// coordinates a point) with point j == point i: two points get the same
// number exactly when they are equal (a mesh's own indices where its points
// are unique). Linear, parallel, the same result whatever the thread count.
// count must be at most 2^32.
void numberLatticePoints(const int32_t* xyz, size_t count, uint32_t* numbers);

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
// numbers[indices[3 t + j]], j < 3 (indices[3 t + j] where numbers is null):
// three distinct numbers a kept triangle, all below pointRange (at most 2^32).
// Linear and parallel.
SurfaceTopology surfaceTopology(const uint32_t* indices, const uint8_t* keep, size_t triangles,
                                const uint32_t* numbers, uint64_t pointRange);

} // namespace hdt
