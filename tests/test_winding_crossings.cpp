// The winding number from crossings and boundary strips
// (core/include/hdt/winding_crossings.hpp) against the library's brute-force
// sum over every triangle (windingSumAll), at voxel centres and at random
// lattice points off them, on open, overlapping, nested, self-intersecting,
// doubled and inconsistently oriented meshes and the shared teapot; rays
// that graze the boundary must give up; the tie rule must count a ray
// through an interior edge or vertex once.
#include "hdt/mesh_io.hpp"
#include "hdt/winding_tree.hpp"
#include "support/mesh_files.hpp"
#include "support/shapes.hpp"
#include "support/winding_reference.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <random>
#include <vector>

namespace hdt {
namespace test {
namespace {

constexpr int64_t kPer = kLatticePerVoxel;

PreparedMesh prepared(const TriangleMesh& mesh, int n) {
  BuildConfig c;
  c.resolution = n;
  c.rootGrid = 4;
  c.leafSize = 8;
  c.insideTest = InsideTest::WindingNumber;
  return prepareMesh(mesh, c);
}

struct Agreement {
  int checked = 0, unsure = 0, decided = 0;
};

// One lattice point: an ok evaluation must hold the brute-force sum within
// its error (plus the brute force's own rounding, windingMargin, and 1e-9
// for points a fraction of a voxel from a triangle, where the brute force
// is less accurate), and a decided verdict must be the brute force's side.
void expectAgrees(const WindingTreeView& t, const int64_t* P, Agreement& a) {
  const WindingSum s = windingCrossingSum(t, P);
  ++a.checked;
  if (!s.ok) {
    ++a.unsure;
    return;
  }
  const double p[3] = {double(P[0]) / kPer, double(P[1]) / kPer, double(P[2]) / kPer};
  const double exact = windingSumAll(t, p[0], p[1], p[2]);
  ASSERT_LE(std::fabs(s.sum - exact), s.error + windingMargin(t.triangleCount) + 1e-9)
      << "at (" << p[0] << ", " << p[1] << ", " << p[2] << "): crossings + strips " << s.sum / (4 * kWindingPi)
      << ", brute force " << exact / (4 * kWindingPi);
  const int v = windingVerdict(s, t.triangleCount);
  if (v != kWindingUnsure) {
    ++a.decided;
    EXPECT_EQ(v == kWindingInside, exact >= 2 * kWindingPi);
  }
}

// Every `step`-th voxel centre of an n^3 grid (and the centres of 2x2x2
// voxel boxes: lattice points on voxel corners), then `randoms` random
// lattice points.
Agreement checkPoints(const WindingTreeView& t, int n, int step, int randoms, uint32_t seed = 7) {
  Agreement a;
  for (int z = 0; z < n; z += step)
    for (int y = 1; y < n; y += step)
      for (int x = 2; x < n; x += step) {
        const int64_t centre[3] = {x * kPer + kPer / 2, y * kPer + kPer / 2, z * kPer + kPer / 2};
        expectAgrees(t, centre, a);
        const int64_t corner[3] = {x * kPer, y * kPer, z * kPer};
        expectAgrees(t, corner, a);
        if (::testing::Test::HasFatalFailure()) return a;
      }
  std::mt19937 rng(seed);
  std::uniform_int_distribution<int64_t> coord(-4 * kPer, (n + 4) * kPer);
  for (int i = 0; i < randoms && !::testing::Test::HasFatalFailure(); ++i) {
    const int64_t P[3] = {coord(rng), coord(rng), coord(rng)};
    expectAgrees(t, P, a);
  }
  return a;
}

class CrossingsShape : public ::testing::TestWithParam<int> {};

TEST_P(CrossingsShape, AgreeWithTheBruteForceSum) {
  const WindingShape s = windingShapes()[size_t(GetParam())];
  const PreparedMesh m = prepared(s.mesh, 64);
  const WindingTree tree = buildWindingTree(m.triangles);
  const Agreement a = checkPoints(tree.view(), 64, 3, 4000);
  EXPECT_GT(a.decided, a.checked * 9 / 10) << s.name << ": " << a.unsure << " unsure of " << a.checked;
}

INSTANTIATE_TEST_SUITE_P(Shapes, CrossingsShape, ::testing::Range(0, int(windingShapes().size())),
                         [](const ::testing::TestParamInfo<int>& i) { return windingShapes()[size_t(i.param)].name; });

TEST(Crossings, TeapotAgreesWithTheBruteForceSum) {
  std::string why;
  const std::string path = sharedMeshPath("teapot.obj", &why);
  if (path.empty()) GTEST_SKIP() << why;
  const PreparedMesh m = prepared(readMesh(path), 64);
  const WindingTree tree = buildWindingTree(m.triangles);
  ASSERT_GT(tree.edges.size(), 0u);
  const Agreement a = checkPoints(tree.view(), 64, 5, 2000);
  EXPECT_GT(a.decided, a.checked * 9 / 10) << a.unsure << " unsure of " << a.checked;
}

// The strip's angle is Van Oosterom-Strackee's with the third corner one
// voxel from p along -x (the formula is scale-invariant per corner).
TEST(Crossings, StripAngleIsTheSolidAngleTowardMinusX) {
  std::mt19937 rng(3);
  std::uniform_int_distribution<int> c(-600, 600);
  for (int i = 0; i < 2000; ++i) {
    WindingEdge e{};
    for (int a = 0; a < 3; ++a) {
      e.a[a] = c(rng) / 64.0;
      e.b[a] = c(rng) / 64.0;
    }
    const double p[3] = {c(rng) / 128.0, c(rng) / 128.0, c(rng) / 128.0};
    double angle, error;
    if (!windingStripAngle(e, p, angle, error)) continue;
    const double v[9] = {e.a[0], e.a[1], e.a[2], e.b[0], e.b[1], e.b[2], p[0] - 1, p[1], p[2]};
    EXPECT_NEAR(angle, triangleSolidAngle(v, p[0], p[1], p[2]), error + 1e-12);
  }
}

// K as one running product (windingStripProduct) and as the sum of the
// edges' angles agree, and the product decides almost every point (teapot:
// 160 boundary edges, many whole turns).
TEST(Crossings, StripProductMatchesTheEdgeSum) {
  std::string why;
  const std::string path = sharedMeshPath("teapot.obj", &why);
  const PreparedMesh m = path.empty() ? prepared(windingShapes()[1].mesh, 64) : prepared(readMesh(path), 64);
  const WindingTree tree = buildWindingTree(m.triangles);
  const WindingTreeView t = tree.view();
  std::mt19937 rng(11);
  std::uniform_int_distribution<int64_t> coord(-8 * kPer, 72 * kPer);
  int products = 0, tried = 0, turned = 0;
  for (int i = 0; i < 3000; ++i) {
    const double p[3] = {double(coord(rng)) / kPer, double(coord(rng)) / kPer, double(coord(rng)) / kPer};
    double K = 0, error = 0, sum = 0, sumError = 0;
    bool ok = true;
    for (const WindingEdge& e : tree.edges) {
      double angle, err;
      ok = ok && windingStripAngle(e, p, angle, err);
      sum += e.net * angle;
      sumError += e.weight * err;
    }
    const int r = windingStripProduct(t, p, K, error);
    EXPECT_EQ(r < 0, !ok);
    if (!ok) continue;
    ++tried;
    if (r != 0) continue;
    ++products;
    turned += std::fabs(K) > 2 * kWindingPi;
    ASSERT_LE(std::fabs(K - sum), error + sumError + 1e-12) << p[0] << " " << p[1] << " " << p[2];
  }
  EXPECT_GT(products, tried * 99 / 100);
  if (!path.empty()) EXPECT_GT(turned, 0);
}

// An open box of lattice triangles: the faces x = 0, x = 8, y = 0, y = 8,
// z = 0 (voxels), each a fan of 4 triangles around its centre, outward; the
// top (z = 8) open. Rays at y = z (the fans' diagonals) pass through
// interior edges and the fans' centre vertices.
LatticeTriangles openLatticeBox() {
  LatticeTriangles out;
  const int32_t s = 8 * int32_t(kPer);
  // Face corners in counter-clockwise order seen from outside, with the centre.
  auto fan = [&](std::array<std::array<int32_t, 3>, 4> q) {
    std::array<int32_t, 3> c{};
    for (int a = 0; a < 3; ++a) c[size_t(a)] = (q[0][size_t(a)] + q[2][size_t(a)]) / 2;
    for (int k = 0; k < 4; ++k) {
      LatticeTriangle t{};
      for (int a = 0; a < 3; ++a) {
        t.v[0][a] = q[size_t(k)][size_t(a)];
        t.v[1][a] = q[size_t((k + 1) % 4)][size_t(a)];
        t.v[2][a] = c[size_t(a)];
      }
      out.push_back(t);
    }
  };
  fan({{{0, 0, 0}, {0, 0, s}, {0, s, s}, {0, s, 0}}}); // x = 0, normal -x
  fan({{{s, 0, 0}, {s, s, 0}, {s, s, s}, {s, 0, s}}}); // x = 8, normal +x
  fan({{{0, 0, 0}, {s, 0, 0}, {s, 0, s}, {0, 0, s}}}); // y = 0, normal -y
  fan({{{0, s, 0}, {0, s, s}, {s, s, s}, {s, s, 0}}}); // y = 8, normal +y
  fan({{{0, 0, 0}, {0, s, 0}, {s, s, 0}, {s, 0, 0}}}); // z = 0, normal -z
  return out;
}

TEST(Crossings, RaysThroughInteriorEdgesAndVerticesCountOnce) {
  const WindingTree tree = buildWindingTree(openLatticeBox());
  const WindingTreeView t = tree.view();
  ASSERT_EQ(tree.edges.size(), 4u); // the top rim
  Agreement a;
  // Through the diagonals of the x faces (y = z and y = 8 - z) and the
  // centres (y = z = 4), from before, inside and behind the box.
  for (int64_t x : {-3 * kPer, 1 * kPer + 5, 4 * kPer, 7 * kPer + 200, 9 * kPer})
    for (int64_t y = 1; y < 8 * kPer; y += 37) {
      const int64_t diagonal[3] = {x, y, y}, anti[3] = {x, y, 8 * kPer - y};
      expectAgrees(t, diagonal, a);
      expectAgrees(t, anti, a);
    }
  const int64_t centre[3] = {2 * kPer, 4 * kPer, 4 * kPer};
  expectAgrees(t, centre, a);
  EXPECT_EQ(a.unsure, 0);
  EXPECT_EQ(a.decided, a.checked);
}

// A point whose +x ray passes exactly through a boundary vertex or through a
// boundary edge's interior lies in a strip's plane: the evaluation gives up
// (the callers then take the tree's sum).
TEST(Crossings, RaysGrazingTheBoundaryGiveUp) {
  const WindingTree tree = buildWindingTree(openLatticeBox());
  const WindingTreeView t = tree.view();
  int grazing = 0;
  for (const WindingEdge& e : tree.edges) {
    for (int k = 0; k <= 4; ++k) { // a, b and points between them (lattice points: the rim is at z = 8)
      int64_t P[3];
      for (int a = 0; a < 3; ++a) P[a] = int64_t(std::llround((e.a[a] * (4 - k) + e.b[a] * k) / 4 * kPer));
      for (int64_t back : {int64_t(1), kPer / 2, 5 * kPer}) {
        const int64_t Q[3] = {P[0] - back, P[1], P[2]};
        EXPECT_FALSE(windingCrossingSum(t, Q).ok) << Q[0] << " " << Q[1] << " " << Q[2];
        ++grazing;
      }
    }
  }
  EXPECT_EQ(grazing, 4 * 5 * 3);
  // Rays of the teapot's voxel centres through its boundary: unsure or right.
  std::string why;
  const std::string path = sharedMeshPath("teapot.obj", &why);
  if (path.empty()) return;
  const PreparedMesh m = prepared(readMesh(path), 64);
  const WindingTree tea = buildWindingTree(m.triangles);
  Agreement a;
  for (const WindingEdge& e : tea.edges) {
    const int64_t P[3] = {int64_t(e.a[0] * kPer) - kPer, int64_t(e.a[1] * kPer), int64_t(e.a[2] * kPer)};
    EXPECT_FALSE(windingCrossingSum(tea.view(), P).ok);
    expectAgrees(tea.view(), P, a);
  }
}

} // namespace
} // namespace test
} // namespace hdt
