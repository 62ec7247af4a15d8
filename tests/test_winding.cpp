// The winding-number inside test (core/include/hdt/winding.hpp): every voxel
// centre against an independent brute-force sum, closed meshes equal to
// parity, Auto's choice, determinism over threads and root ranges.
#include "hdt/builder.hpp"
#include "hdt/error.hpp"
#include "hdt/mesh_io.hpp"
#include "hdt/root_ranges.hpp"
#include "hdt/winding_tree.hpp"
#include "support/format_volumes.hpp"
#include "support/mesh_files.hpp"
#include "support/shapes.hpp"
#include "support/winding_reference.hpp"

#include <gtest/gtest.h>
#include <tbb/task_arena.h>

#include <algorithm>
#include <cmath>
#include <cstring>
#include <fstream>
#include <stdexcept>

namespace hdt {
namespace test {
namespace {

BuildConfig windingConfig(int n, InsideTest test, int rootGrid = 4, int leafSize = 8) {
  BuildConfig c;
  c.resolution = n;
  c.rootGrid = rootGrid;
  c.leafSize = leafSize;
  c.insideTest = test;
  return c;
}

Volume buildWith(const PreparedMesh& m, int threads = 0) {
  BuildOptions o;
  o.backend = Backend::Cpu;
  o.threads = threads;
  return buildCpu(m, o);
}

void expectSameBytes(const Volume& a, const Volume& b, const std::string& what) {
  EXPECT_EQ(a.levelStart, b.levelStart) << what;
  EXPECT_TRUE(a.elements == b.elements) << what;
  EXPECT_TRUE(a.leafWords == b.leafWords) << what;
}

// ---- the shared per-element functions ------------------------------------------------

TEST(WindingFunctions, AtanMatchesTheLibrary) {
  for (int i = -2000; i <= 2000; ++i) {
    for (double x : {1.0, -1.0, 0.25, -3.0, 1e-12, 0.0}) {
      const double y = i * 0.00731;
      EXPECT_NEAR(windingAtan2(y, x), std::atan2(y, x), 4e-16 * (1 + std::fabs(std::atan2(y, x)))) << y << " " << x;
    }
  }
}

TEST(WindingFunctions, SolidAngleOfAnOctant) {
  // The triangle (1,0,0) (0,1,0) (0,0,1) seen from the origin spans an
  // octant: 4 pi / 8; seen from its front side the sign flips.
  const double v[9] = {1, 0, 0, 0, 1, 0, 0, 0, 1};
  EXPECT_NEAR(triangleSolidAngle(v, 0, 0, 0), kWindingPi / 2, 1e-15);
  EXPECT_LT(triangleSolidAngle(v, 1, 1, 1), 0);
}

// The tree's bounded sum contains the exact sum, for points and boxes.
TEST(WindingFunctions, TreeBoundHoldsTheExactSum) {
  const PreparedMesh m = prepareMesh(windingShapes()[1].mesh, windingConfig(64, InsideTest::WindingNumber));
  const WindingTree tree = buildWindingTree(m.triangles);
  const WindingTreeView t = tree.view();
  int checked = 0;
  for (int z = 2; z < 62; z += 7)
    for (int y = 3; y < 62; y += 5)
      for (int x = 1; x < 62; x += 3) {
        const double p[3] = {x + 0.5, y + 0.5, z + 0.5};
        const double exact = windingSumAll(t, p[0], p[1], p[2]);
        for (int openings : {0, 2, 10, 40}) { // given up or decided: the bound holds either way
          const WindingSum s = windingSumOverBox(t, p, p, openings);
          if (!s.ok && s.error == 0) continue;
          EXPECT_LE(std::fabs(s.sum - exact), s.error * 1.001 + windingMargin(t.triangleCount)) << x << y << z;
          ++checked;
        }
        const double lo[3] = {p[0], p[1], p[2]}, hi[3] = {p[0] + 3, p[1] + 2, p[2] + 1};
        const WindingSum b = windingSumOverBox(t, lo, hi, 5);
        if (!b.ok && b.error == 0) continue;
        for (int k = 0; k < 8; ++k) {
          const double q[3] = {(k & 1) ? hi[0] : lo[0], (k & 2) ? hi[1] : lo[1], (k & 4) ? hi[2] : lo[2]};
          EXPECT_LE(std::fabs(b.sum - windingSumAll(t, q[0], q[1], q[2])), b.error * 1.001 + windingMargin(t.triangleCount));
        }
      }
  EXPECT_GT(checked, 1000);
}

TEST(WindingFunctions, TreeIsAFunctionOfTheTriangles) {
  // An open mesh of 86,400 triangles: the tree's subtrees and the edge sort
  // run in parallel above a few thousand triangles.
  const PreparedMesh m = prepareMesh(uvHemisphere(120, 360, 1.0), windingConfig(256, InsideTest::WindingNumber));
  const WindingTree a = buildWindingTree(m.triangles);
  WindingTree b;
  tbb::task_arena(1).execute([&] { b = buildWindingTree(m.triangles); });
  ASSERT_EQ(a.nodes.size(), b.nodes.size());
  EXPECT_EQ(0, std::memcmp(a.nodes.data(), b.nodes.data(), a.nodes.size() * sizeof(WindingNode)));
  ASSERT_EQ(a.triangles.size(), m.triangles.size());
  EXPECT_EQ(0, std::memcmp(a.triangles.data(), b.triangles.data(), a.triangles.size() * sizeof(WindingTriangle)));
  ASSERT_GT(a.edges.size(), 0u);
  ASSERT_EQ(a.edges.size(), b.edges.size());
  EXPECT_EQ(0, std::memcmp(a.edges.data(), b.edges.data(), a.edges.size() * sizeof(WindingEdge)));
  // Every node's children or triangles lie inside the arrays, each triangle in exactly one leaf.
  std::vector<int> seen(a.triangles.size(), 0);
  for (const WindingNode& n : a.nodes) {
    if (n.count == 0) {
      ASSERT_LT(size_t(n.first) + 1, a.nodes.size());
    } else {
      ASSERT_LE(size_t(n.first) + n.count, a.triangles.size());
      for (uint32_t i = n.first; i < n.first + n.count; ++i) ++seen[i];
    }
  }
  EXPECT_EQ(std::count(seen.begin(), seen.end(), 1), std::ptrdiff_t(seen.size()));
}

// ---- builds against the brute-force reference -----------------------------------------

class WindingShapeTest : public ::testing::TestWithParam<int> {};

TEST_P(WindingShapeTest, EveryVoxelMatchesBruteForce) {
  const WindingShape s = windingShapes()[size_t(GetParam())];
  const PreparedMesh m = prepareMesh(s.mesh, windingConfig(64, InsideTest::WindingNumber));
  const Volume v = buildWith(m);
  EXPECT_EQ(v.insideTest, InsideTest::WindingNumber);
  EXPECT_GT(v.stats.insideVoxels, 0u) << s.name;
  uint64_t ties = 0;
  EXPECT_TRUE(volumeMatchesWinding(v, m, &ties)) << s.name;
  EXPECT_LT(ties, 64u) << s.name;
  RecordProperty("refined_elements", std::to_string(v.stats.windingRefinedElements));
}

INSTANTIATE_TEST_SUITE_P(Shapes, WindingShapeTest, ::testing::Range(0, int(windingShapes().size())),
                         [](const ::testing::TestParamInfo<int>& i) { return windingShapes()[size_t(i.param)].name; });

// A larger grid (128^3, leaves of 16) on the open cube: the w = 1/2 surface
// across the hole crosses uniform elements, which get refined.
TEST(WindingBuild, OpenCubeAt128RefinesTheHole) {
  const PreparedMesh m = prepareMesh(windingShapes()[0].mesh, windingConfig(128, InsideTest::WindingNumber, 4, 16));
  const Volume v = buildWith(m);
  EXPECT_GT(v.stats.windingRefinedElements, 0u);
  EXPECT_TRUE(volumeMatchesWinding(v, m));
}

TEST(WindingBuild, OverlapOfTwoClosedSpheresIsInside) {
  const WindingShape s = windingShapes()[2];
  const PreparedMesh wm = prepareMesh(s.mesh, windingConfig(64, InsideTest::WindingNumber));
  const PreparedMesh pm = prepareMesh(s.mesh, windingConfig(64, InsideTest::Parity));
  ASSERT_TRUE(wm.closed);
  const Volume w = buildWith(wm), p = buildWith(pm);
  EXPECT_EQ(voxelAt(w, 32, 32, 32), VoxelState::Inside);  // w = 2
  EXPECT_EQ(voxelAt(p, 32, 32, 32), VoxelState::Outside); // parity 0
  EXPECT_GT(w.stats.insideVoxels, p.stats.insideVoxels);
}

TEST(WindingBuild, ClosedShapesEqualParity) {
  for (const char* name : {"sphere", "torus", "rotated_cube", "centre_box", "grid_aligned_box", "two_bodies", "hollow_sphere"}) {
    Shape s;
    try {
      s = makeShape(name, 64);
    } catch (const std::out_of_range&) {
      continue;
    }
    ASSERT_TRUE(s.expectClosed) << name;
    BuildConfig wc = s.config(64, 4, 8, false), pc = wc;
    wc.insideTest = InsideTest::WindingNumber;
    pc.insideTest = InsideTest::Parity;
    const PreparedMesh wm = prepareMesh(s.mesh, wc), pm = prepareMesh(s.mesh, pc);
    if (pm.duplicateTriangles > 0) continue; // doubled shells: parity 0, winding 2
    expectSameBytes(buildWith(wm), buildWith(pm), s.name);
  }
}

// Auto is the default (issue 16): a default config decides an open mesh by the
// winding number and a closed one by exact parity, byte for byte as asked.
TEST(WindingBuild, DefaultIsAuto) {
  BuildConfig d;
  EXPECT_EQ(d.insideTest, InsideTest::Auto);
  d.resolution = 64;
  d.rootGrid = 4;
  d.leafSize = 8;
  const TriangleMesh open = windingShapes()[0].mesh, closed = icosphere(2, 1.0);
  const PreparedMesh openDefault = prepareMesh(open, d), closedDefault = prepareMesh(closed, d);
  EXPECT_EQ(openDefault.requestedInsideTest, InsideTest::Auto);
  EXPECT_EQ(openDefault.insideTest, InsideTest::WindingNumber);
  EXPECT_EQ(closedDefault.insideTest, InsideTest::Parity);
  expectSameBytes(buildWith(openDefault), buildWith(prepareMesh(open, windingConfig(64, InsideTest::WindingNumber))),
                  "open, default");
  expectSameBytes(buildWith(closedDefault), buildWith(prepareMesh(closed, windingConfig(64, InsideTest::Parity))),
                  "closed, default");
}

TEST(WindingBuild, AutoIsParityWhenClosedAndWindingWhenOpen) {
  const PreparedMesh closed = prepareMesh(icosphere(2, 1.0), windingConfig(64, InsideTest::Auto));
  const PreparedMesh open = prepareMesh(windingShapes()[0].mesh, windingConfig(64, InsideTest::Auto));
  EXPECT_EQ(closed.insideTest, InsideTest::Parity);
  EXPECT_EQ(open.insideTest, InsideTest::WindingNumber);
  EXPECT_EQ(buildWith(closed).insideTest, InsideTest::Parity);
  EXPECT_EQ(buildWith(open).insideTest, InsideTest::WindingNumber);
  BuildConfig surf = windingConfig(64, InsideTest::WindingNumber);
  surf.surfaceOnly = true;
  const Volume s = buildWith(prepareMesh(windingShapes()[0].mesh, surf));
  EXPECT_EQ(s.stats.insideVoxels, 0u);
}

TEST(WindingBuild, SameBytesOnAnyThreadCountAndAsRanges) {
  for (int shape : {0, 4}) {
    const PreparedMesh m = prepareMesh(windingShapes()[size_t(shape)].mesh, windingConfig(64, InsideTest::WindingNumber));
    const Volume one = buildWith(m, 1);
    for (int threads : {2, 7}) expectSameBytes(one, buildWith(m, threads), "threads " + std::to_string(threads));
    BuildOptions o;
    o.threads = 2;
    const uint64_t cells = 4 * 4 * 4;
    const Volume ranges = buildCpuRanges(m, o, {RootRange{0, 16}, RootRange{16, 40}, RootRange{40, cells}});
    expectSameBytes(one, ranges, "ranges");
  }
}

TEST(WindingBuild, BadInputStaysClean) {
  TriangleMesh empty;
  EXPECT_THROW(prepareMesh(empty, windingConfig(64, InsideTest::WindingNumber)), Error);
  TriangleMesh flat; // every triangle zero-area: refused before any sum
  flat.points = {0, 0, 0, 1, 1, 1, 2, 2, 2};
  flat.triangles = {0, 1, 2};
  EXPECT_THROW(prepareMesh(flat, windingConfig(64, InsideTest::WindingNumber)), Error);
  const WindingTree none = buildWindingTree({});
  EXPECT_TRUE(none.nodes.empty());
}

// ---- shared meshes ------------------------------------------------------------------

class WindingSharedMesh : public ::testing::TestWithParam<const char*> {};

TEST_P(WindingSharedMesh, SampledVoxelsMatchBruteForce) {
  std::string why;
  const std::string path = sharedMeshPath(GetParam(), &why);
  if (path.empty()) GTEST_SKIP() << why;
  const PreparedMesh m = prepareMesh(readMesh(path), windingConfig(64, InsideTest::Auto));
  ASSERT_FALSE(m.closed);
  ASSERT_EQ(m.insideTest, InsideTest::WindingNumber);
  const Volume v = buildWith(m);
  EXPECT_TRUE(volumeMatchesWinding(v, m, nullptr, 61)); // every 61st voxel
  expectSameBytes(v, buildWith(m, 1), "1 thread");
}

INSTANTIATE_TEST_SUITE_P(Files, WindingSharedMesh, ::testing::Values("teapot.obj", "ogre.obj"),
                         [](const ::testing::TestParamInfo<const char*>& i) {
                           return std::string(i.param).substr(0, std::string(i.param).find('.'));
                         });

} // namespace
} // namespace test
} // namespace hdt
