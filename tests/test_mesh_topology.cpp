// prepareMesh's point numbers, closedness, duplicate count and kept triangles
// against brute force (std::map over lattice coordinates, one triangle at a
// time): closed, open, non-manifold, duplicated and degenerate triangles,
// vertices split at seams (distinct indices, one lattice point), points that
// snap together, several blocks and buckets; and the topology alone on point
// numbers up to 2^32 (the 128-bit keys).
#include "hdt/geometry.hpp"
#include "hdt/mesh.hpp"
#include "hdt/mesh_topology.hpp"
#include "support/shapes.hpp"

#include <gtest/gtest.h>

#include <algorithm>
#include <array>
#include <cstdint>
#include <cstring>
#include <map>
#include <numeric>
#include <random>
#include <string>
#include <utility>
#include <vector>

namespace hdt {
namespace test {
namespace {

// ---- brute force ------------------------------------------------------------------------

using LatticePoint = std::array<int32_t, 3>;

LatticePoint cornerOf(const LatticeTriangle& t, int j) { return {t.v[j][0], t.v[j][1], t.v[j][2]}; }

// What prepareMesh must give, one triangle at a time.
struct Expected {
  std::vector<LatticeTriangle> kept;
  bool closed = true;
  size_t duplicates = 0;
};

template <class Point> void tallyCorners(const std::vector<std::array<Point, 3>>& triangles, Expected& e) {
  std::map<std::pair<Point, Point>, size_t> edges;
  std::map<std::array<Point, 3>, size_t> corners;
  for (std::array<Point, 3> c : triangles) {
    for (int j = 0; j < 3; ++j) ++edges[std::minmax(c[size_t(j)], c[size_t(j + 1) % 3])];
    std::sort(c.begin(), c.end());
    ++corners[c];
  }
  e.closed = std::all_of(edges.begin(), edges.end(), [](const auto& x) { return x.second % 2 == 0; });
  e.duplicates = 0;
  for (const auto& c : corners) e.duplicates += c.second - 1;
}

Expected bruteForce(const TriangleMesh& mesh, const GridSpec& g) {
  Expected e;
  std::vector<std::array<LatticePoint, 3>> corners;
  for (size_t t = 0; t < mesh.triangleCount(); ++t) {
    LatticeTriangle lt;
    for (int j = 0; j < 3; ++j)
      for (int a = 0; a < 3; ++a) lt.v[j][a] = snapToLattice(mesh.points[3 * size_t(mesh.triangles[3 * t + j]) + a], g, a);
    if (isDegenerate(lt)) continue;
    e.kept.push_back(lt);
    corners.push_back({cornerOf(lt, 0), cornerOf(lt, 1), cornerOf(lt, 2)});
  }
  tallyCorners(corners, e);
  return e;
}

void expectPreparedAsBruteForce(const TriangleMesh& mesh, int resolution, const std::string& what) {
  SCOPED_TRACE(what);
  BuildConfig config;
  config.resolution = resolution;
  config.rootGrid = 4;
  config.leafSize = 8;
  const PreparedMesh p = prepareMesh(mesh, config);
  const Expected e = bruteForce(mesh, p.grid);
  ASSERT_EQ(p.triangles.size(), e.kept.size());
  EXPECT_EQ(std::memcmp(p.triangles.data(), e.kept.data(), e.kept.size() * sizeof(LatticeTriangle)), 0)
      << "kept triangles differ";
  EXPECT_EQ(p.degenerateTriangles, mesh.triangleCount() - e.kept.size());
  EXPECT_EQ(p.closed, e.closed);
  EXPECT_EQ(p.duplicateTriangles, e.duplicates);
}

// ---- generated meshes ---------------------------------------------------------------------

// Every triangle with its own three points (as STL, or OBJ seams), the points
// then shuffled: the same lattice points under many distinct indices, the
// smallest of them anywhere.
TriangleMesh splitAndShuffled(const TriangleMesh& m, uint32_t seed) {
  const size_t n = 3 * m.triangleCount();
  std::vector<uint32_t> place(n);
  std::iota(place.begin(), place.end(), 0u);
  std::shuffle(place.begin(), place.end(), std::mt19937(seed));
  TriangleMesh out;
  out.points.resize(3 * n);
  out.triangles.resize(n);
  for (size_t i = 0; i < n; ++i) {
    out.triangles[i] = place[i];
    for (int a = 0; a < 3; ++a) out.points[3 * size_t(place[i]) + a] = m.points[3 * size_t(m.triangles[i]) + a];
  }
  return out;
}

// Two tetrahedra sharing an edge (four triangles on it: closed) and a fin
// (three triangles on one edge: open), each a few times, far apart in the
// triangle order and with copies under other indices.
TriangleMesh nonManifold(bool fin) {
  TriangleMesh m;
  m.points = {0, 0, 0, 1, 0, 0, 0.5, 1, 0, 0.5, 0.5, 1, 0.5, 0.5, -1, 0.3, 2, 0.1};
  const std::vector<uint32_t> tets = {0, 1, 2, 0, 3, 1, 1, 3, 2, 2, 3, 0,  // tetrahedron over the base
                                      0, 2, 1, 0, 1, 4, 1, 2, 4, 2, 0, 4}; // and under it
  m.triangles = tets;
  if (fin) m.triangles.insert(m.triangles.end(), {0, 1, 5});
  return m;
}

TriangleMesh randomSoup(size_t triangles, int side, bool paired, uint32_t seed) {
  std::mt19937 rng(seed);
  TriangleMesh m;
  const uint32_t points = uint32_t(side * side * side);
  for (uint32_t i = 0; i < points; ++i)
    m.points.insert(m.points.end(), {double(i % side), double(i / side % side), double(i / side / side)});
  std::uniform_int_distribution<uint32_t> pick(0, points - 1);
  for (size_t i = 0; i < triangles; ++i) {
    uint32_t a = pick(rng), b = pick(rng), c = pick(rng);
    while (b == a) b = pick(rng);
    while (c == a || c == b) c = pick(rng);
    for (int k = 0; k < (paired ? 2 : 1); ++k) m.triangles.insert(m.triangles.end(), {a, b, c});
  }
  return m;
}

TEST(PrepareTopology, AgreesWithBruteForceOnGeneratedMeshes) {
  const TriangleMesh sphere = icosphere(4, 1.0); // 5120 triangles
  expectPreparedAsBruteForce(sphere, 256, "sphere");
  expectPreparedAsBruteForce(splitAndShuffled(sphere, 1), 256, "sphere, split at every vertex, shuffled");

  TriangleMesh holed = splitAndShuffled(sphere, 2);
  holed.triangles.erase(holed.triangles.begin() + 3 * 4000, holed.triangles.begin() + 3 * 4001);
  expectPreparedAsBruteForce(holed, 256, "split sphere with a hole");

  // The same faces again, reversed and under other indices: closed, all duplicated.
  TriangleMesh twice = splitAndShuffled(sphere, 3), flipped = splitAndShuffled(sphere, 4);
  flipOrientation(flipped);
  append(twice, flipped);
  expectPreparedAsBruteForce(twice, 256, "split sphere doubled, reversed");
  // One face three times: duplicates, and its edges odd.
  TriangleMesh thrice = sphere;
  for (int k = 0; k < 2; ++k) thrice.triangles.insert(thrice.triangles.end(), sphere.triangles.begin() + 30, sphere.triangles.begin() + 33);
  expectPreparedAsBruteForce(thrice, 256, "sphere with a face three times");

  expectPreparedAsBruteForce(nonManifold(false), 64, "two tetrahedra on one edge");
  expectPreparedAsBruteForce(nonManifold(true), 64, "two tetrahedra and a fin");

  // At a coarse resolution many points snap together and many triangles
  // become degenerate (dropped), in many blocks of triangles.
  TriangleMesh fine = icosphere(6, 1.0); // 81920 triangles
  expectPreparedAsBruteForce(fine, 32, "fine sphere at N = 32");
  expectPreparedAsBruteForce(splitAndShuffled(fine, 5), 32, "split fine sphere at N = 32");
  expectPreparedAsBruteForce(splitAndShuffled(fine, 6), 1024, "split fine sphere at N = 1024");

  for (size_t triangles : {7u, 1000u, 70000u})
    for (bool paired : {false, true})
      expectPreparedAsBruteForce(randomSoup(triangles, 4, paired, uint32_t(triangles)), 64,
                                 "soup of " + std::to_string(triangles) + (paired ? " pairs" : ""));
}

// ---- the parts on their own -----------------------------------------------------------------

TEST(PrepareTopology, PointNumbersAreTheFirstIndexOfEachLatticePoint) {
  std::mt19937 rng(7);
  for (size_t count : {1u, 5u, 200u, 300000u}) {
    SCOPED_TRACE(count);
    // Points from a small cube (many repeats), on lines along each axis
    // (equal in two coordinates, not in the third) and anywhere.
    std::vector<int32_t> xyz(3 * count);
    std::uniform_int_distribution<int32_t> small(0, 20), any(0, (1 << 24) - 1);
    for (size_t i = 0; i < count; ++i)
      for (int a = 0; a < 3; ++a) xyz[3 * i + a] = i % 5 == 0 || (i % 5 < 4 && int(i % 5) != a + 1) ? small(rng) % 4 : any(rng);
    std::vector<NumberedPoint> points(count);
    for (size_t i = 0; i < count; ++i) points[i] = {xyz[3 * i], xyz[3 * i + 1], xyz[3 * i + 2], UINT32_MAX};
    numberLatticePoints(points.data(), count);
    std::map<LatticePoint, uint32_t> first;
    size_t wrong = 0;
    for (size_t i = 0; i < count; ++i) {
      const auto it = first.emplace(LatticePoint{xyz[3 * i], xyz[3 * i + 1], xyz[3 * i + 2]}, uint32_t(i)).first;
      wrong += points[i].number != it->second || points[i].x != xyz[3 * i] || points[i].z != xyz[3 * i + 2];
    }
    EXPECT_EQ(wrong, 0u);
    if (count == 300000) EXPECT_LT(first.size(), count * 9 / 10); // repeats were there
  }
}

// Triangles on point numbers below `range`: a closed surface (the sphere's
// faces, points mapped to distinct random numbers), some removed or repeated,
// some not kept, against brute force over the same numbers.
void expectTopologyAsBruteForce(uint64_t range, uint32_t seed) {
  SCOPED_TRACE("range " + std::to_string(range));
  std::mt19937_64 rng(seed);
  const TriangleMesh sphere = icosphere(5, 1.0); // 20480 triangles, 10242 points
  std::vector<uint32_t> number(sphere.pointCount());
  std::map<uint64_t, bool> used;
  for (size_t i = 0; i < number.size(); ++i) { // distinct, the top of the range included
    do number[i] = uint32_t(i == 0 ? range - 1 : rng() % range);
    while (!used.emplace(number[i], true).second);
  }
  for (int variant = 0; variant < 4; ++variant) {
    SCOPED_TRACE(variant);
    std::vector<uint32_t> indices;
    for (uint32_t i : sphere.triangles) indices.push_back(number[i]);
    if (variant == 1) indices.erase(indices.begin() + 300, indices.begin() + 303); // a hole
    if (variant == 2) indices.insert(indices.end(), {indices[9], indices[11], indices[10]}); // a face again
    std::vector<uint8_t> keep(indices.size() / 3, 1);
    if (variant == 3) // a pair of faces, doubled, then not kept: closed, no duplicate
      for (int k = 0; k < 2; ++k) {
        indices.insert(indices.end(), {indices[0], indices[1], indices[2]});
        keep.push_back(0);
      }
    std::vector<std::array<uint32_t, 3>> kept;
    for (size_t t = 0; t < keep.size(); ++t)
      if (keep[t]) kept.push_back({indices[3 * t], indices[3 * t + 1], indices[3 * t + 2]});
    Expected e;
    tallyCorners(kept, e);
    const SurfaceTopology s = surfaceTopology(indices.data(), keep.data(), keep.size(), nullptr, range);
    EXPECT_EQ(s.closed, e.closed);
    EXPECT_EQ(s.duplicateTriangles, e.duplicates);
    EXPECT_EQ(e.closed, variant == 0 || variant == 3);
    EXPECT_EQ(e.duplicates, variant == 2 ? 1u : 0u);
  }
}

TEST(PrepareTopology, AgreesWithBruteForceOnPointNumbersUpTo2To32) {
  // 64-bit keys up to 2^25 - 1 points, 128-bit beyond.
  for (uint64_t range : {uint64_t(20000), uint64_t(1) << 20, (uint64_t(1) << 25) - 1, uint64_t(1) << 25,
                         uint64_t(3) << 30, uint64_t(1) << 32})
    expectTopologyAsBruteForce(range, uint32_t(range % 1000));
}

TEST(PrepareTopology, SoupsOfFewPointsAgreeWithBruteForce) {
  // Many triangles on a few numbers: long runs of equal edges and corners.
  std::mt19937 rng(11);
  for (uint32_t points : {4u, 9u, 40u}) {
    for (bool paired : {false, true}) {
      std::vector<uint32_t> indices;
      std::uniform_int_distribution<uint32_t> pick(0, points - 1);
      for (int i = 0; i < 30000; ++i) {
        uint32_t a = pick(rng), b = pick(rng), c = pick(rng);
        while (b == a) b = pick(rng);
        while (c == a || c == b) c = pick(rng);
        for (int k = 0; k < (paired ? 2 : 1); ++k) indices.insert(indices.end(), {a, c, b});
      }
      std::vector<std::array<uint32_t, 3>> tris;
      for (size_t t = 0; t < indices.size() / 3; ++t) tris.push_back({indices[3 * t], indices[3 * t + 1], indices[3 * t + 2]});
      Expected e;
      tallyCorners(tris, e);
      const SurfaceTopology s = surfaceTopology(indices.data(), nullptr, tris.size(), nullptr, points);
      EXPECT_EQ(s.closed, e.closed) << points << " points";
      EXPECT_EQ(s.duplicateTriangles, e.duplicates) << points << " points";
      EXPECT_EQ(e.closed, paired);
    }
  }
}

} // namespace
} // namespace test
} // namespace hdt
