// An independent brute-force winding number (double, the library's
// atan2) and the open / overlapping / nested test shapes of the winding-number
// suites (tests/test_winding.cpp, tests/cuda/test_cuda_winding.cpp).
#pragma once

#include "hdt/mesh.hpp"
#include "hdt/volume.hpp"

#include <gtest/gtest.h>

#include <string>
#include <vector>

namespace hdt {
namespace test {

// w at the centre of voxel (x, y, z) of the prepared (snapped) mesh: the sum
// over every triangle of its solid angle / 4 pi, in input order.
double referenceWinding(const PreparedMesh& mesh, int x, int y, int z);

struct WindingShape {
  std::string name;
  TriangleMesh mesh;
};

// Cube without its +z face, sphere with a cut cap, two overlapping closed
// spheres, nested shells (inner one inward: a cavity), a self-intersecting
// folded sphere, an open cube with every triangle doubled, a closed sphere
// with some triangles doubled, an open cube with zero-area triangles, an
// open cube with one face turned inward (inconsistent orientation).
std::vector<WindingShape> windingShapes();

// The winding shapes at 64^3 in 4^3 root cells of 8^3 leaves under the
// winding number: the distributed builds' tests (a few ranges of root cells).
BuildConfig windingShapesConfig();

// Every voxel of the volume against the reference: surface voxels must match
// the reference surface (the box test), every other voxel must be inside
// exactly when w >= 1/2. Voxels with |w - 1/2| < 1e-9 are not judged (the
// reference's own rounding); `ties` returns how many there were. `stride`
// > 1 judges every stride-th voxel of x only (large meshes).
::testing::AssertionResult volumeMatchesWinding(const Volume& volume, const PreparedMesh& mesh, uint64_t* ties = nullptr,
                                                int stride = 1);

} // namespace test
} // namespace hdt
