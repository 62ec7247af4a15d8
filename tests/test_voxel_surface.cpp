// The voxel surface (voxel_surface.hpp) against faces counted on the dense
// export: the merged quads, rasterized back to cell faces, must be exactly the
// faces between an occupied and an unoccupied cell of the dense volume
// coarsened by the same rule (largest state of each c^3 block), each once and
// with the state of its occupied cell and, for labelled volumes, the label of
// that cell (majority of its voxels' labels in the dense label export).
#include "hdt/builder.hpp"
#include "hdt/dense.hpp"
#include "hdt/labels.hpp"
#include "hdt/volume_walk.hpp"
#include "hdt/voxel_surface.hpp"
#include "support/shapes.hpp"

#include <gtest/gtest.h>
#include <tbb/global_control.h>

#include <algorithm>
#include <map>
#include <random>
#include <sstream>

namespace hdt {
namespace test {
namespace {

// A unit face (axis, outward, plane, u, v in cells of edge c) packed in a
// key, with its state and label (faceValue); sorted by key.
using FaceMap = std::vector<std::pair<uint64_t, int>>;
uint64_t faceKey(int axis, int outward, int plane, int u, int v) {
  return (uint64_t(axis) << 50) | (uint64_t(outward > 0) << 48) | (uint64_t(plane) << 32) | (uint64_t(u) << 16) |
         uint64_t(v);
}

int faceValue(int state, int label) { return state | (label << 8); }

// Label of each cell of edge c: the majority of the labels of its non-Outside
// voxels in the dense label export, ties to the lowest (brute force); all 0
// for an unlabelled volume.
std::vector<uint16_t> referenceCellLabels(const Volume& v, int c) {
  const int N = v.grid.resolution, n = N / c;
  std::vector<uint16_t> labels(size_t(n) * n * n, 0);
  if (v.labels.empty()) return labels;
  const std::vector<uint16_t> dense = denseLabels(v);
  for (int cz = 0; cz < n; ++cz)
    for (int cy = 0; cy < n; ++cy)
      for (int cx = 0; cx < n; ++cx) {
        std::map<int, int> count;
        for (int z = cz * c; z < (cz + 1) * c; ++z)
          for (int y = cy * c; y < (cy + 1) * c; ++y)
            for (int x = cx * c; x < (cx + 1) * c; ++x) {
              const int l = dense[size_t(x) + size_t(N) * (size_t(y) + size_t(N) * size_t(z))];
              if (l) ++count[l];
            }
        int best = 0, most = 0;
        for (const auto& entry : count) // ascending labels: ties keep the lowest
          if (entry.second > most) {
            best = entry.first;
            most = entry.second;
          }
        labels[size_t(cx) + size_t(n) * (size_t(cy) + size_t(n) * size_t(cz))] = uint16_t(best);
      }
  return labels;
}

int uAxisOf(int axis) { return axis == 0 ? 1 : 0; }
int vAxisOf(int axis) { return axis == 2 ? 1 : 2; }

// Faces of the dense volume coarsened to cells of edge c (brute force).
FaceMap referenceFaces(const Volume& v, int c) {
  const std::vector<uint8_t> dense = denseStates(v);
  const int N = v.grid.resolution, n = N / c;
  std::vector<uint8_t> cells(size_t(n) * n * n, 0);
  for (int z = 0; z < N; ++z)
    for (int y = 0; y < N; ++y)
      for (int x = 0; x < N; ++x) {
        uint8_t& cell = cells[size_t(x / c) + size_t(n) * (size_t(y / c) + size_t(n) * size_t(z / c))];
        cell = std::max(cell, dense[size_t(x) + size_t(N) * (size_t(y) + size_t(N) * size_t(z))]);
      }
  const std::vector<uint16_t> labels = referenceCellLabels(v, c);
  auto occupied = [&](int x, int y, int z) {
    if (x < 0 || y < 0 || z < 0 || x >= n || y >= n || z >= n) return 0;
    const int s = cells[size_t(x) + size_t(n) * (size_t(y) + size_t(n) * size_t(z))];
    return (v.surfaceOnly ? s == 2 : s != 0) ? s : 0;
  };
  FaceMap faces;
  for (int z = 0; z < n; ++z)
    for (int y = 0; y < n; ++y)
      for (int x = 0; x < n; ++x) {
        const int s = occupied(x, y, z);
        if (!s) continue;
        const int p[3] = {x, y, z};
        for (int axis = 0; axis < 3; ++axis)
          for (int outward : {1, -1}) {
            int q[3] = {x, y, z};
            q[axis] += outward;
            if (occupied(q[0], q[1], q[2])) continue;
            faces.emplace_back(faceKey(axis, outward, p[axis] + (outward > 0 ? 1 : 0), p[uAxisOf(axis)],
                                       p[vAxisOf(axis)]),
                               faceValue(s, labels[size_t(x) + size_t(n) * (size_t(y) + size_t(n) * size_t(z))]));
          }
      }
  std::sort(faces.begin(), faces.end());
  return faces;
}

// The quads rasterized to cell faces; a face covered twice is reported.
FaceMap rasterize(const std::vector<SurfaceQuad>& quads, int c, std::string& problems) {
  FaceMap faces;
  std::ostringstream why;
  for (const SurfaceQuad& q : quads) {
    if (q.plane % c || q.u % c || q.v % c || q.du % c || q.dv % c || q.du <= 0 || q.dv <= 0) {
      why << "quad not on the cell grid; ";
      continue;
    }
    for (int v = q.v; v < q.v + q.dv; v += c)
      for (int u = q.u; u < q.u + q.du; u += c) {
        faces.emplace_back(faceKey(q.axis, q.outward, q.plane / c, u / c, v / c), faceValue(q.state, q.label));
      }
  }
  std::sort(faces.begin(), faces.end());
  for (size_t i = 1; i < faces.size(); ++i)
    if (faces[i].first == faces[i - 1].first) why << "face covered twice; ";
  problems = why.str();
  return faces;
}

void expectSurfaceMatchesDense(const Volume& v, int maxDepth, const std::string& what) {
  const int c = surfaceCellEdge(v.grid, maxDepth);
  SurfaceOptions options;
  options.maxDepth = maxDepth;
  const FaceMap expected = referenceFaces(v, c);
  for (bool merge : {true, false}) {
    options.merge = merge;
    const std::vector<SurfaceQuad> quads = extractSurfaceQuads(v, options);
    std::string problems;
    const FaceMap got = rasterize(quads, c, problems);
    EXPECT_EQ(problems, "") << what << " maxDepth " << maxDepth << (merge ? " merged" : " unmerged");
    EXPECT_EQ(got.size(), expected.size()) << what << " maxDepth " << maxDepth;
    EXPECT_TRUE(got == expected) << what << " maxDepth " << maxDepth << (merge ? " merged" : " unmerged");
    if (!merge) EXPECT_EQ(quads.size(), expected.size()) << what;
    if (merge && !expected.empty()) EXPECT_LE(quads.size(), expected.size()) << what;
  }
}

int fullDepth(const GridSpec& g) {
  int d = g.height;
  for (int l = g.leafSize; l > 1; l /= 2) ++d;
  return d;
}

void setVoxel(uint32_t* words, int L, int x, int y, int z, int s) {
  const uint32_t i = uint32_t(x + L * (y + L * z));
  words[i >> 4] = (words[i >> 4] & ~(3u << (2 * (i & 15u)))) | (uint32_t(s) << (2 * (i & 15u)));
}

// A random tree: every kind of element next to every other (leaf beside
// leaf, leaf beside larger Full/Empty elements, the grid border), leaves of
// random and of blocky contents. Not a build's output: a stress of the walk.
Volume randomVolume(unsigned seed, int R, int L, int height, bool surfaceOnly) {
  std::mt19937 rng(seed);
  Volume v;
  v.grid.rootGrid = R;
  v.grid.leafSize = L;
  v.grid.height = height;
  v.grid.resolution = R * (1 << height) * L;
  v.grid.origin = {-2.0, 0.5, 3.0};
  v.grid.voxelSize = 0.25;
  v.surfaceOnly = surfaceOnly;
  std::vector<ElementWord> level(size_t(R) * R * R);
  uint64_t leaves = 0;
  v.levelStart = {0};
  for (int k = 0; k <= height; ++k) {
    const uint64_t first = v.elements.size() + level.size();
    uint64_t children = 0;
    for (ElementWord& w : level) {
      const int pick = int(rng() % 8);
      if (k < height && pick < 4) {
        w = makeElement(ElementState::Branch, uint32_t(first + children));
        children += 8;
      } else if (k == height && pick < 5) {
        w = makeElement(ElementState::Boundary, uint32_t(leaves++));
      } else {
        w = makeElement(pick % 2 ? ElementState::Full : ElementState::Empty, 0);
      }
    }
    v.elements.insert(v.elements.end(), level.begin(), level.end());
    v.levelStart.push_back(v.elements.size());
    level.assign(children, 0);
  }
  v.leafWords.assign(leaves * leafWordCount(L), 0);
  for (uint64_t i = 0; i < leaves; ++i) {
    uint32_t* words = v.leafWords.data() + i * leafWordCount(L);
    const bool blocky = i % 2;
    const int bx = int(rng() % L), by = int(rng() % L), bz = int(rng() % L);
    for (int z = 0; z < L; ++z)
      for (int y = 0; y < L; ++y)
        for (int x = 0; x < L; ++x) {
          int s = int(rng() % 3);
          if (blocky) s = (x < bx && y < by) ? 2 : (z < bz ? 1 : 0);
          setVoxel(words, L, x, y, z, s);
        }
  }
  computeStructureStatistics(v);
  return v;
}

TEST(VoxelSurface, RandomTreesMatchDenseFacesAtEveryDepth) {
  struct Case {
    int R, L, height;
  };
  for (const Case& k : {Case{2, 8, 2}, Case{3, 16, 1}, Case{1, 32, 1}, Case{2, 8, 0}})
    for (bool surfaceOnly : {false, true})
      for (unsigned seed : {1u, 2u}) {
        if (seed == 2 && k.R * k.L > 32) continue; // the large grid once: keeps the test quick
        const Volume v = randomVolume(seed, k.R, k.L, k.height, surfaceOnly);
        std::ostringstream what;
        what << "R=" << k.R << " L=" << k.L << " h=" << k.height << (surfaceOnly ? " surface-only" : "")
             << " seed " << seed;
        for (int depth = -1; depth <= fullDepth(v.grid); ++depth) expectSurfaceMatchesDense(v, depth, what.str());
      }
}

TEST(VoxelSurface, BuiltShapesMatchDenseFaces) {
  BuildOptions options;
  options.backend = Backend::Cpu;
  for (const char* name : {"sphere", "torus", "grid_aligned_box", "hollow_sphere", "open_hemisphere", "thin_plate"})
    for (bool surfaceOnly : {false, true}) {
      const Shape shape = makeShape(name, 64);
      const Volume v = voxelize(shape.mesh, shape.config(64, 2, 8, surfaceOnly), options);
      for (int depth : {-1, 4, 3, 2, 1})
        expectSurfaceMatchesDense(v, depth, std::string(name) + (surfaceOnly ? " surface-only" : ""));
    }
}

// An aligned cube inside one leaf grid: 6 faces of one state, 6 rectangles.
TEST(VoxelSurface, AlignedCubeIsSixRectangles) {
  Volume v = randomVolume(7, 1, 16, 0, false);
  v.elements[0] = makeElement(ElementState::Boundary, 0);
  v.leafWords.assign(leafWordCount(16), 0);
  for (int z = 3; z < 11; ++z)
    for (int y = 5; y < 9; ++y)
      for (int x = 2; x < 14; ++x) setVoxel(v.leafWords.data(), 16, x, y, z, 2);
  const std::vector<SurfaceQuad> quads = extractSurfaceQuads(v);
  ASSERT_EQ(quads.size(), 6u);
  for (const SurfaceQuad& q : quads) EXPECT_EQ(q.state, 2);
  expectSurfaceMatchesDense(v, -1, "aligned cube");
}

// A Full root cell among Empty ones: one rectangle a side.
TEST(VoxelSurface, FullElementIsSixRectangles) {
  Volume v = randomVolume(3, 3, 8, 1, false);
  for (uint64_t i = 0; i < 27; ++i) v.elements[i] = makeElement(ElementState::Empty, 0);
  v.elements[13] = makeElement(ElementState::Full, 0);
  const std::vector<SurfaceQuad> quads = extractSurfaceQuads(v);
  ASSERT_EQ(quads.size(), 6u);
  for (const SurfaceQuad& q : quads) {
    EXPECT_EQ(q.du, 16);
    EXPECT_EQ(q.state, 1);
  }
}

// Labels 1..3 on a random tree: Full elements one label each, leaves either
// one label for all their occupied voxels or mixed (a label per voxel).
Volume randomLabelledVolume(unsigned seed, int R, int L, int height) {
  Volume v = randomVolume(seed, R, L, height, false);
  std::mt19937 rng(seed + 100);
  const size_t voxels = size_t(L) * L * L;
  v.labels.elementLabels.assign(v.elements.size(), kOutsideLabel);
  std::vector<Label> mixedVoxels; // L^3 per mixed leaf, in leaf order
  for (size_t i = 0; i < v.elements.size(); ++i) {
    const ElementState s = elementState(v.elements[i]);
    if (s == ElementState::Full) v.labels.elementLabels[i] = Label(1 + rng() % 3);
    if (s != ElementState::Boundary) continue;
    if (rng() % 2) {
      v.labels.elementLabels[i] = Label(1 + rng() % 3);
      continue;
    }
    const uint32_t* words = v.leaf(elementPayload(v.elements[i]));
    const bool blocky = rng() % 2; // label by half-space or voxel by voxel
    const int split = int(rng() % L);
    for (size_t k = 0; k < voxels; ++k) {
      const bool occupied = (words[k / kVoxelsPerWord] >> (2 * (k % kVoxelsPerWord))) & 3u;
      const Label label = blocky ? Label(int(k % size_t(L)) < split ? 1 : 2) : Label(1 + rng() % 3);
      mixedVoxels.push_back(occupied ? label : kOutsideLabel);
    }
  }
  packVoxelLabels(v, mixedVoxels.data());
  return v;
}

TEST(VoxelSurface, LabelledRandomTreesMatchDenseLabelsAtEveryDepth) {
  for (unsigned seed : {1u, 2u, 3u}) {
    const Volume v = randomLabelledVolume(seed, 2, 8, 2);
    ASSERT_FALSE(v.labels.palettes.empty()) << "no mixed leaf: the test would not check them";
    for (int depth = -1; depth <= fullDepth(v.grid); ++depth)
      expectSurfaceMatchesDense(v, depth, "labelled random tree seed " + std::to_string(seed));
  }
}

// Two labelled cubes sharing a face, built: at the aligned placement the
// shared face splits no cell of any depth, at the shifted one it cuts coarse
// cells (majority labels). The quads of the first cube's outer faces carry
// label 1 only, and a merged face never spans the two.
TEST(VoxelSurface, TouchingLabelledCubesMatchDenseLabels) {
  const int n = 64;
  BuildConfig config;
  config.resolution = n;
  config.rootGrid = 2;
  config.leafSize = 8;
  config.hasBounds = true;
  config.boundsMin = {-31, -31, -31};
  config.boundsMax = {31, 31, 31};
  auto plane = [&](int x, int y, int z) { return Vec3{voxelPlane(n, x), voxelPlane(n, y), voxelPlane(n, z)}; };
  BuildOptions options;
  options.backend = Backend::Cpu;
  for (int shift : {0, 5}) {
    TriangleMesh mesh = box(plane(16 - shift, 20, 20), plane(32 - shift, 40, 40));
    mesh.triangleLabels.assign(mesh.triangleCount(), 1);
    const TriangleMesh second = box(plane(32 - shift, 20, 20), plane(48, 40, 40));
    append(mesh, second);
    mesh.triangleLabels.resize(mesh.triangleCount(), 2);
    const Volume v = voxelizeLabelled(mesh, config, options);
    ASSERT_FALSE(v.labels.empty());
    for (int depth : {-1, 4, 3, 2, 1, 0})
      expectSurfaceMatchesDense(v, depth, "touching cubes shifted by " + std::to_string(shift));
    std::map<int, int> perLabel;
    for (const SurfaceQuad& q : extractSurfaceQuads(v)) ++perLabel[q.label];
    EXPECT_EQ(perLabel.size(), 2u);
    const VoxelSurface surface = extractVoxelSurface(v);
    ASSERT_EQ(surface.labels.size(), surface.quadCount());
  }
}

TEST(VoxelSurface, OrderDoesNotDependOnThreads) {
  const Shape shape = makeShape("torus", 128);
  BuildOptions options;
  options.backend = Backend::Cpu;
  const Volume v = voxelize(shape.mesh, shape.config(128, 4, 8, false), options);
  const VoxelSurface all = extractVoxelSurface(v);
  VoxelSurface one;
  {
    tbb::global_control single(tbb::global_control::max_allowed_parallelism, 1);
    one = extractVoxelSurface(v);
  }
  ASSERT_GT(all.quadCount(), 0u);
  EXPECT_TRUE(all.points == one.points);
  EXPECT_TRUE(all.states == one.states);
  EXPECT_TRUE(all.labels.empty()); // unlabelled volume
}

// Mesh units and winding: corners on the grid, counter-clockwise seen from outside.
TEST(VoxelSurface, PointsInMeshUnitsFacingOut) {
  const Volume v = randomVolume(5, 2, 8, 1, false);
  const std::vector<SurfaceQuad> quads = extractSurfaceQuads(v);
  const VoxelSurface s = extractVoxelSurface(v);
  ASSERT_EQ(s.quadCount(), quads.size());
  for (size_t i = 0; i < quads.size(); ++i) {
    const float* p = s.points.data() + 12 * i;
    double e1[3], e2[3];
    for (int a = 0; a < 3; ++a) {
      e1[a] = p[3 + a] - p[a];
      e2[a] = p[9 + a] - p[a];
    }
    const double normal[3] = {e1[1] * e2[2] - e1[2] * e2[1], e1[2] * e2[0] - e1[0] * e2[2],
                              e1[0] * e2[1] - e1[1] * e2[0]};
    const SurfaceQuad& q = quads[i];
    EXPECT_GT(normal[q.axis] * q.outward, 0) << "quad " << i;
    EXPECT_FLOAT_EQ(p[q.axis], float(v.grid.origin[q.axis] + q.plane * v.grid.voxelSize));
  }
}

// The walk tiles the grid: every voxel in exactly one visited element.
TEST(VolumeWalk, TilesTheGridAndLocatesEveryVoxel) {
  const Volume v = randomVolume(9, 2, 8, 2, false);
  const int N = v.grid.resolution;
  for (int maxLevel = 0; maxLevel <= v.grid.height; ++maxLevel) {
    std::vector<int> cover(size_t(N) * N * N, 0);
    walkVolume(v, maxLevel, [&](const WalkedElement& e) {
      EXPECT_TRUE(e.state() != ElementState::Branch || e.level == maxLevel);
      for (int z = 0; z < e.edge; ++z)
        for (int y = 0; y < e.edge; ++y)
          for (int x = 0; x < e.edge; ++x) {
            const int gx = e.origin[0] + x, gy = e.origin[1] + y, gz = e.origin[2] + z;
            ++cover[size_t(gx) + size_t(N) * (size_t(gy) + size_t(N) * size_t(gz))];
            if ((x | y | z) == 0 || (x & y & z) == e.edge - 1) {
              const WalkedElement found = locateElement(v, gx, gy, gz, maxLevel);
              EXPECT_EQ(found.index, e.index);
            }
          }
    });
    EXPECT_EQ(std::count(cover.begin(), cover.end(), 1), long(cover.size())) << "maxLevel " << maxLevel;
  }
}

} // namespace
} // namespace test
} // namespace hdt
