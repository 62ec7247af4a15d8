// Tests that catch an unsafe winding-number bound (core/include/hdt/winding.hpp).
//
// A bound that is too small decides voxels wrongly only where w is close to
// 1/2 or where the bound is nearly reached, which generic shapes rarely
// show. So these tests go where it matters, against an independent sum in
// long double:
//  * clusters of triangles placed so that the far field's remainder and the
//    variation over a box of points come within a factor of about 1.4 of
//    their bounds: any bound shrunk by half fails there;
//  * points and boxes next to the w = 1/2 surface spanning a hemisphere's
//    hole, found by bisection (|w - 1/2| from 1e-11 to 1e-2);
//  * every voxel of a build whose voxel centres crowd around w = 1/2.
#include "hdt/builder.hpp"
#include "hdt/winding_tree.hpp"
#include "support/reference_voxelizer.hpp"
#include "support/shapes.hpp"

#include <gtest/gtest.h>
#include <tbb/parallel_for.h>

#include <algorithm>
#include <atomic>
#include <mutex>
#include <cmath>
#include <random>
#include <vector>

namespace hdt {
namespace test {
namespace {

using Tris = LatticeTriangles;

// ---- the independent reference: long double, the C library's atan2l, input order ----

long double solidAngleL(const LatticeTriangle& t, const long double* p) {
  long double v[3][3], len[3];
  for (int j = 0; j < 3; ++j) {
    for (int a = 0; a < 3; ++a) v[j][a] = (long double)t.v[j][a] / 256.0L - p[a];
    len[j] = sqrtl(v[j][0] * v[j][0] + v[j][1] * v[j][1] + v[j][2] * v[j][2]);
  }
  auto dot = [&](int i, int j) { return v[i][0] * v[j][0] + v[i][1] * v[j][1] + v[i][2] * v[j][2]; };
  const long double det = v[0][0] * (v[1][1] * v[2][2] - v[1][2] * v[2][1]) -
                          v[0][1] * (v[1][0] * v[2][2] - v[1][2] * v[2][0]) +
                          v[0][2] * (v[1][0] * v[2][1] - v[1][1] * v[2][0]);
  const long double den = len[0] * len[1] * len[2] + dot(0, 1) * len[2] + dot(0, 2) * len[1] + dot(1, 2) * len[0];
  return 2.0L * atan2l(det, den);
}

// The sum of solid angles (steradians) at p.
long double sumL(const Tris& tris, const double* p) {
  const long double q[3] = {p[0], p[1], p[2]};
  long double s = 0;
  for (const LatticeTriangle& t : tris) s += solidAngleL(t, q);
  return s;
}

constexpr long double kPiL = 3.141592653589793238462643383279502884L;
long double windingL(const Tris& tris, const double* p) { return sumL(tris, p) / (4.0L * kPiL); }

// The same in double with std::atan2: quick, for points far from 1/2.
double windingD(const Tris& tris, const double* p) {
  double s = 0;
  for (const LatticeTriangle& t : tris) {
    double v[3][3], len[3];
    for (int j = 0; j < 3; ++j) {
      for (int a = 0; a < 3; ++a) v[j][a] = t.v[j][a] / 256.0 - p[a];
      len[j] = std::sqrt(v[j][0] * v[j][0] + v[j][1] * v[j][1] + v[j][2] * v[j][2]);
    }
    auto dot = [&](int i, int j) { return v[i][0] * v[j][0] + v[i][1] * v[j][1] + v[i][2] * v[j][2]; };
    const double det = v[0][0] * (v[1][1] * v[2][2] - v[1][2] * v[2][1]) -
                       v[0][1] * (v[1][0] * v[2][2] - v[1][2] * v[2][0]) +
                       v[0][2] * (v[1][0] * v[2][1] - v[1][1] * v[2][0]);
    const double den = len[0] * len[1] * len[2] + dot(0, 1) * len[2] + dot(0, 2) * len[1] + dot(1, 2) * len[0];
    s += 2 * std::atan2(det, den);
  }
  return s / (4 * M_PI);
}

// ---- clusters of small triangles -------------------------------------------------

// A right triangle of legs `size` (lattice units) at corner `at`, in the
// plane normal to axis a and facing +a.
LatticeTriangle facing(int a, std::array<int32_t, 3> at, int32_t size) {
  LatticeTriangle t;
  const int b = (a + 1) % 3, c = (a + 2) % 3;
  for (int j = 0; j < 3; ++j)
    for (int k = 0; k < 3; ++k) t.v[j][k] = at[size_t(k)];
  t.v[1][b] += size;
  t.v[2][c] += size;
  return t;
}

// How close a bounded sum comes to its bound over sample points, and whether
// it ever exceeds it.
struct BoundCheck {
  double worstRatio = 0; // max |exact - sum| / error over samples with error > 0
  int violations = 0;
  int checks = 0;
  std::string first;

  // `samples`: the points of the box [lo, hi] to compare at.
  void check(const WindingTreeView& t, const Tris& tris, const double* lo, const double* hi, int openings,
             const std::vector<std::array<double, 3>>& samples) {
    const WindingSum s = windingSumOverBox(t, lo, hi, openings);
    if (!s.ok && s.error == 0) return; // a triangle met the box: no bound was claimed
    for (const auto& q : samples) {
      const long double diff = fabsl(sumL(tris, q.data()) - (long double)s.sum);
      ++checks;
      if (s.error > 0) worstRatio = std::max(worstRatio, double(diff / s.error));
      // The verdict's own allowance (windingVerdict) on top of the bound.
      if (diff > (long double)(s.error * 1.001 + windingMargin(t.triangleCount))) {
        if (violations++ == 0) {
          first = "box [" + std::to_string(lo[0]) + "," + std::to_string(lo[1]) + "," + std::to_string(lo[2]) +
                  "]-[" + std::to_string(hi[0]) + "," + std::to_string(hi[1]) + "," + std::to_string(hi[2]) +
                  "] openings " + std::to_string(openings) + ": |exact - sum| = " + std::to_string(double(diff)) +
                  " > error " + std::to_string(s.error);
        }
      }
    }
  }
};

std::vector<std::array<double, 3>> alongSegment(const double* lo, const double* hi, int n) {
  std::vector<std::array<double, 3>> out;
  for (int i = 0; i <= n; ++i) {
    const double f = double(i) / n;
    out.push_back({lo[0] + f * (hi[0] - lo[0]), lo[1] + f * (hi[1] - lo[1]), lo[2] + f * (hi[2] - lo[2])});
  }
  return out;
}

// Two unit triangles facing +x at x = -2 and x = +2 voxels: their quadrupole
// cancels, so the far field's error at a point on the x axis is the second
// order remainder 6 A S^2 / d^4 + O(d^-6), which its bound 3 A r^2 / (d - r)^4
// reaches within (S / r)^2 ((d - r) / d)^4.
TEST(WindingBounds, FarFieldRemainderIsSoundAndNearlyReached) {
  const Tris tris = {facing(0, {-512, 0, 0}, 256), facing(0, {512, 0, 0}, 256)};
  const WindingTree tree = buildWindingTree(tris);
  ASSERT_EQ(tree.nodes.size(), 1u); // one leaf: the root's far field is what is measured
  BoundCheck c;
  for (double d = 6; d <= 40; d *= 1.1) {
    for (double y : {0.5, 0.0, 3.0}) {
      const double p[3] = {-d, y, 0.5};
      c.check(tree.view(), tris, p, p, 0, {{p[0], p[1], p[2]}});
    }
  }
  EXPECT_EQ(c.violations, 0) << c.first;
  EXPECT_GT(c.worstRatio, 0.6) << "the cluster no longer comes near the bound: the test lost its teeth";
  EXPECT_GT(c.checks, 50);
}

// One unit triangle facing +x and boxes of points along x at distance d:
// w varies over the box by about 2 A rho / d^3, the far field's variation
// bound (and the cancelling one's dipole term, 2 |D| rho / d^3).
TEST(WindingBounds, FarFieldVariationOverABoxIsSoundAndNearlyReached) {
  const Tris tris = {facing(0, {0, 0, 0}, 256)};
  const WindingTree tree = buildWindingTree(tris);
  BoundCheck c;
  for (double d = 4; d <= 30; d *= 1.15) {
    for (double rho : {0.05 * d, 0.02 * d}) {
      const double lo[3] = {-d - rho, 0.5, 0.5}, hi[3] = {-d + rho, 0.5, 0.5};
      c.check(tree.view(), tris, lo, hi, 0, alongSegment(lo, hi, 10));
    }
  }
  EXPECT_EQ(c.violations, 0) << c.first;
  EXPECT_GT(c.worstRatio, 0.6) << "the boxes no longer come near the bound: the test lost its teeth";
}

// The same with the triangle summed exactly: a second, far triangle makes the
// leaf's box reach the query box, so the leaf is taken apart and the first
// triangle's variation is bounded by 2 A rho / dist^3 on its own.
TEST(WindingBounds, ExactTriangleVariationOverABoxIsSoundAndNearlyReached) {
  const Tris tris = {facing(0, {0, 0, 0}, 256), facing(0, {-50 * 256, 20 * 256, 20 * 256}, 64)};
  const WindingTree tree = buildWindingTree(tris);
  ASSERT_EQ(tree.nodes.size(), 1u);
  BoundCheck c;
  for (double d = 4; d <= 12; d *= 1.1) {
    for (double rho : {0.05 * d, 0.02 * d}) {
      const double lo[3] = {-d - rho, 0.5, 0.5}, hi[3] = {-d + rho, 0.5, 0.5};
      c.check(tree.view(), tris, lo, hi, 0, alongSegment(lo, hi, 10));
    }
  }
  EXPECT_EQ(c.violations, 0) << c.first;
  EXPECT_GT(c.worstRatio, 0.6) << "the boxes no longer come near the bound: the test lost its teeth";
}

// The small-box lists (windingBoxLists): every voxel centre of a 4^3 box
// summed from them holds the exact sum; far nodes' remainders come near
// their bound on the facing pair (the dipole triangles' bound is looser: a
// triangle's true remainder is at most half of it).
TEST(WindingBounds, SmallBoxListsAreSound) {
  static WindingBoxLists lists; // large: off the stack
  auto checkLists = [&](const Tris& tris, const double* lo, double& worst, int& far, int& dip) {
    const WindingTree tree = buildWindingTree(tris);
    const WindingTreeView t = tree.view();
    const double hi[3] = {lo[0] + 3, lo[1] + 3, lo[2] + 3};
    if (!windingBoxLists(t, lo, hi, lists)) return false;
    far += lists.farCount;
    dip += lists.dipCount;
    for (int k = 0; k < 64; ++k) {
      const double p[3] = {lo[0] + k % 4, lo[1] + (k / 4) % 4, lo[2] + k / 16};
      const WindingSum s = windingSumFromLists(t, lists, p);
      const long double diff = fabsl(sumL(tris, p) - (long double)s.sum);
      if (s.error > 0) worst = std::max(worst, double(diff / s.error));
      if (diff > (long double)(s.error * 1.001 + windingMargin(t.triangleCount))) return false;
    }
    return true;
  };
  double worstFar = 0, worstDip = 0;
  int far = 0, dip = 0, unused = 0;
  const Tris pair = {facing(0, {-512, 0, 0}, 256), facing(0, {512, 0, 0}, 256)};
  for (double d = 12; d <= 40; d *= 1.1) {
    const double lo[3] = {-d - 3, -1.5, -1.5};
    EXPECT_TRUE(checkLists(pair, lo, worstFar, far, unused)) << d;
  }
  // A unit triangle in a leaf with a far one: the leaf is near, the triangle dipole.
  const Tris spread = {facing(0, {0, 0, 0}, 256), facing(0, {-50 * 256, 20 * 256, 20 * 256}, 64)};
  for (double d = 8; d <= 30; d *= 1.1) {
    const double lo[3] = {-d - 3, -1.5, -1.5};
    EXPECT_TRUE(checkLists(spread, lo, worstDip, unused, dip)) << d;
  }
  EXPECT_GT(far, 0);
  EXPECT_GT(dip, 0);
  EXPECT_GT(worstFar, 0.6) << "the pair no longer comes near the bound: the test lost its teeth";
  RecordProperty("worst_dipole_ratio", std::to_string(worstDip));
}

// Random clusters of up to 24 small triangles (several nodes), random boxes
// and points around them, every opening budget: the bound always holds.
TEST(WindingBounds, RandomClustersHoldTheExactSum) {
  std::mt19937 rng(20261124);
  std::uniform_int_distribution<int32_t> coord(-6 * 256, 6 * 256), leg(-300, 300);
  std::uniform_real_distribution<double> unit(-1, 1);
  BoundCheck c;
  for (int cluster = 0; cluster < 40; ++cluster) {
    Tris tris;
    const int n = 1 + cluster % 24;
    while (int(tris.size()) < n) {
      LatticeTriangle t;
      for (int a = 0; a < 3; ++a) {
        t.v[0][a] = coord(rng);
        t.v[1][a] = t.v[0][a] + leg(rng);
        t.v[2][a] = t.v[0][a] + leg(rng);
      }
      const int64_t ex = t.v[1][0] - t.v[0][0], ey = t.v[1][1] - t.v[0][1], ez = t.v[1][2] - t.v[0][2];
      const int64_t fx = t.v[2][0] - t.v[0][0], fy = t.v[2][1] - t.v[0][1], fz = t.v[2][2] - t.v[0][2];
      if (ey * fz - ez * fy == 0 && ez * fx - ex * fz == 0 && ex * fy - ey * fx == 0) continue;
      tris.push_back(t);
    }
    const WindingTree tree = buildWindingTree(tris);
    for (int q = 0; q < 30; ++q) {
      const double dist = 6 + 30 * (unit(rng) + 1);
      double dir[3] = {unit(rng), unit(rng), unit(rng)};
      const double len = std::sqrt(dir[0] * dir[0] + dir[1] * dir[1] + dir[2] * dir[2]) + 1e-9;
      const double c0[3] = {dist * dir[0] / len, dist * dir[1] / len, dist * dir[2] / len};
      const double h[3] = {q % 3 == 0 ? 0.0 : 2 * (unit(rng) + 1), q % 3 == 0 ? 0.0 : 2 * (unit(rng) + 1),
                           q % 3 == 0 ? 0.0 : 2 * (unit(rng) + 1)};
      const double lo[3] = {c0[0] - h[0], c0[1] - h[1], c0[2] - h[2]}, hi[3] = {c0[0] + h[0], c0[1] + h[1], c0[2] + h[2]};
      std::vector<std::array<double, 3>> samples;
      for (int k = 0; k < 8; ++k) samples.push_back({(k & 1) ? hi[0] : lo[0], (k & 2) ? hi[1] : lo[1], (k & 4) ? hi[2] : lo[2]});
      samples.push_back({c0[0], c0[1], c0[2]});
      for (int openings : {0, 1, 3, 100}) c.check(tree.view(), tris, lo, hi, openings, samples);
    }
  }
  EXPECT_EQ(c.violations, 0) << c.first;
  EXPECT_GT(c.checks, 10000);
}

// ---- the gradient bound: the boundary edges' Biot-Savart field ----------------------

// Pairs of points on short arcs around the middle of edge y = 0 of a large
// right triangle in the plane z = 0 (the side y < 0, off the triangle): the
// solid angle changes there at the rate 2 / rho of a long straight current,
// which the bound over the pair's box reaches within about 1 / 0.9. `copies`
// triangles are summed (a duplicated triangle doubles the edge's weight).
struct GradientCheck {
  double worstRatio = 0;
  int violations = 0, checks = 0;
  std::string first;
};

GradientCheck checkGradientAroundEdge(const Tris& tris) {
  const WindingTree tree = buildWindingTree(tris);
  const WindingTreeView t = tree.view();
  GradientCheck c;
  for (double rho = 0.6; rho < 12; rho *= 1.3) {
    for (double phi = -1.5; phi <= 1.5; phi += 0.25) {
      const double h = 0.05 * rho; // arc step
      const double p[3] = {20.3, -rho * std::cos(phi), rho * std::sin(phi)};
      const double q[3] = {20.3, p[1] + h * std::sin(phi), p[2] + h * std::cos(phi)};
      if (q[1] >= 0) continue; // stay off the triangle
      double lo[3], hi[3], len2 = 0;
      for (int a = 0; a < 3; ++a) {
        lo[a] = std::min(p[a], q[a]);
        hi[a] = std::max(p[a], q[a]);
        len2 += (q[a] - p[a]) * (q[a] - p[a]);
      }
      const double allowed = std::sqrt(len2) * windingGradientBound(t, lo, hi);
      const long double change = fabsl(sumL(tris, q) - sumL(tris, p));
      ++c.checks;
      if (allowed > 0) c.worstRatio = std::max(c.worstRatio, double(change / allowed));
      if (change > (long double)allowed * 1.0000001L + 1e-15L && c.violations++ == 0) {
        c.first = "rho " + std::to_string(rho) + " phi " + std::to_string(phi) + ": change " +
                  std::to_string(double(change)) + " > bound " + std::to_string(allowed);
      }
    }
  }
  return c;
}

LatticeTriangle bigTriangle(bool reversed) {
  LatticeTriangle t = facing(2, {0, 0, 0}, 40 * 256); // (0,0,0) (40,0,0) (0,40,0), facing +z
  if (reversed) std::swap(t.v[1], t.v[2]);
  return t;
}

TEST(WindingGradient, BoundIsSoundAndNearlyReachedAroundAnOpenEdge) {
  const GradientCheck c = checkGradientAroundEdge({bigTriangle(false)});
  EXPECT_EQ(c.violations, 0) << c.first;
  EXPECT_GT(c.worstRatio, 0.6) << "the arcs no longer come near the bound: the test lost its teeth";
  EXPECT_GT(c.checks, 100);
}

// A duplicated triangle: each edge is met twice in the same direction and
// counts twice (a chain that dropped repeats would give half the bound).
TEST(WindingGradient, DuplicatedTrianglesCountTheirEdgesTwice) {
  const WindingTree tree = buildWindingTree({bigTriangle(false), bigTriangle(false)});
  ASSERT_EQ(tree.edges.size(), 3u);
  for (const WindingEdge& e : tree.edges) EXPECT_EQ(e.weight, 2.0);
  const GradientCheck c = checkGradientAroundEdge({bigTriangle(false), bigTriangle(false)});
  EXPECT_EQ(c.violations, 0) << c.first;
  EXPECT_GT(c.worstRatio, 0.6);
}

// Inconsistent orientation: a triangle and its reverse cancel everywhere (no
// boundary, w = 0); two triangles that share an edge in the same direction
// add it twice, and the bound holds around it.
TEST(WindingGradient, InconsistentOrientation) {
  const WindingTree cancel = buildWindingTree({bigTriangle(false), bigTriangle(true)});
  EXPECT_TRUE(cancel.edges.empty());
  const double lo[3] = {5, -3, 1}, hi[3] = {9, -1, 2};
  EXPECT_EQ(windingGradientBound(cancel.view(), lo, hi), 0.0);
  // The mirror image of the big triangle across y = 0 faces -z and runs the
  // shared edge (0,0,0)-(40,0,0) the same way: that edge counts twice.
  // Reversed, it faces +z like its neighbour and the shared edge cancels.
  LatticeTriangle mirror = bigTriangle(false);
  for (int j = 0; j < 3; ++j) mirror.v[j][1] = -mirror.v[j][1];
  LatticeTriangle consistentMirror = mirror;
  std::swap(consistentMirror.v[1], consistentMirror.v[2]);
  EXPECT_EQ(buildWindingTree({bigTriangle(false), consistentMirror}).edges.size(), 4u);
  const Tris folded = {bigTriangle(false), mirror};
  const WindingTree doubled = buildWindingTree(folded);
  ASSERT_EQ(doubled.edges.size(), 5u);
  double weights = 0;
  for (const WindingEdge& e : doubled.edges) weights += e.weight;
  EXPECT_EQ(weights, 6.0); // four edges once, the shared one twice
  // Around the shared edge, off both triangles (z != 0 half-space): the arcs
  // of checkGradientAroundEdge cross y = 0 only above or below the plane.
  const WindingTreeView t = doubled.view();
  double worst = 0;
  int violations = 0;
  for (double rho = 0.6; rho < 12; rho *= 1.3) {
    for (double phi = 0.3; phi <= 2.8; phi += 0.25) { // z > 0
      const double h = 0.05 * rho;
      const double p[3] = {20.3, rho * std::cos(phi), rho * std::sin(phi)};
      const double q[3] = {20.3, p[1] - h * std::sin(phi), p[2] + h * std::cos(phi)};
      double blo[3], bhi[3];
      for (int a = 0; a < 3; ++a) {
        blo[a] = std::min(p[a], q[a]);
        bhi[a] = std::max(p[a], q[a]);
      }
      const double allowed = h * windingGradientBound(t, blo, bhi);
      const long double change = fabsl(sumL(folded, q) - sumL(folded, p));
      worst = std::max(worst, double(change / allowed));
      violations += change > (long double)allowed * 1.0000001L + 1e-15L;
    }
  }
  EXPECT_EQ(violations, 0);
  EXPECT_GT(worst, 0.6) << "the shared edge no longer dominates: the test lost its teeth";
}

// ---- next to w = 1/2 ---------------------------------------------------------------

// A hemisphere in the unit-voxel frame of an N^3 grid (voxel centres at
// half-integers) whose rim plane is tilted by 0.01 rad and passes a fraction of a voxel from
// the voxel centres of the middle layer: w crosses 1/2 in the hole, and many
// voxel centres lie within 1e-3 of it.
Shape nearHalfHemisphere(int n) {
  Shape s;
  s.name = "near_half_hemisphere";
  const double radius = 0.4 * n;
  s.mesh = uvHemisphere(10, 28, radius, {0.3, -0.2, 0.5 + 0.031});
  transform(s.mesh, rotationXYZ(0.01, -0.007, 0.0), {0.3, -0.2, 0.5});
  s.expectClosed = false;
  s.hasBounds = true;
  const double b = (n - 2) / 2.0;
  s.boundsMin = {-b, -b, -b};
  s.boundsMax = {b, b, b};
  return s;
}

BuildConfig windingBuild(const Shape& s, int n) {
  BuildConfig c = s.config(n, 4, 8, false);
  c.insideTest = InsideTest::WindingNumber;
  return c;
}

// Points on either side of the w = 1/2 surface, at distances 1e-9..0.3
// voxels along random lines through the hole, each with its reference w.
struct NearPoint {
  std::array<double, 3> p;
  long double w;
};

std::vector<NearPoint> pointsNearHalf(const Tris& tris, int n, int lines) {
  std::mt19937 rng(7);
  std::uniform_real_distribution<double> in(0.3 * n, 0.7 * n), tilt(-0.4, 0.4);
  std::vector<NearPoint> out;
  for (int l = 0; l < lines; ++l) {
    // A line along (tilt, tilt, 1) through a point of the middle layer.
    const double o[3] = {in(rng), in(rng), n / 2.0 + 0.5};
    const double dir[3] = {tilt(rng), tilt(rng), 1.0};
    auto at = [&](double t) { return std::array<double, 3>{o[0] + t * dir[0], o[1] + t * dir[1], o[2] + t * dir[2]}; };
    double a = -3, b = 3;
    const bool aInside = windingL(tris, at(a).data()) >= 0.5L;
    if (aInside == (windingL(tris, at(b).data()) >= 0.5L)) continue;
    for (int i = 0; i < 60; ++i) {
      const double m = 0.5 * (a + b);
      ((windingL(tris, at(m).data()) >= 0.5L) == aInside ? a : b) = m;
    }
    // A jump, not a crossing: the line met the surface itself.
    if (fabsl(windingL(tris, at(a).data()) - windingL(tris, at(b).data())) > 1e-9L) continue;
    for (double delta = 1e-9; delta < 0.5; delta *= 3.7) {
      for (double t : {a - delta, b + delta}) {
        const auto p = at(t);
        out.push_back({p, windingL(tris, p.data())});
      }
    }
  }
  return out;
}

// Point decisions (windingInsideAt) and box verdicts next to w = 1/2 agree
// with the reference wherever |w - 1/2| > 1e-11 (below that the library's
// double sum and the reference may disagree by rounding).
TEST(WindingNearHalf, PointsAndBoxesAcrossTheHoleAgreeWithTheReference) {
  const int n = 64;
  const Shape s = nearHalfHemisphere(n);
  const PreparedMesh m = prepareMesh(s.mesh, windingBuild(s, n));
  ASSERT_FALSE(m.closed);
  const WindingTree tree = buildWindingTree(m.triangles);
  const WindingTreeView t = tree.view();
  const std::vector<NearPoint> points = pointsNearHalf(m.triangles, n, 40);
  int judged = 0, veryNear = 0, wrong = 0;
  std::string first;
  for (const NearPoint& q : points) {
    const long double off = q.w - 0.5L;
    if (fabsl(off) < 1e-11L) continue;
    ++judged;
    veryNear += fabsl(off) < 1e-6L;
    const bool want = off > 0;
    if (windingInsideAt(t, q.p[0], q.p[1], q.p[2]) != want && wrong++ == 0) {
      first = "point w - 1/2 = " + std::to_string(double(off));
    }
  }
  EXPECT_EQ(wrong, 0) << first;
  EXPECT_GT(judged, 1000);
  EXPECT_GT(veryNear, 200);

  // Boxes of half-width h around each point: a verdict must hold at its
  // corners, its centre and every near point inside it.
  int boxes = 0, decided = 0;
  wrong = 0;
  for (size_t i = 0; i < points.size(); i += 3) {
    for (double h : {1e-4, 1e-2, 0.1, 0.5}) {
      const double lo[3] = {points[i].p[0] - h, points[i].p[1] - h, points[i].p[2] - h};
      const double hi[3] = {points[i].p[0] + h, points[i].p[1] + h, points[i].p[2] + h};
      const int v = windingVerdict(windingSumOverBox(t, lo, hi, kWindingBoxOpenings), t.triangleCount);
      ++boxes;
      if (v == kWindingUnsure) continue;
      ++decided;
      for (const NearPoint& q : points) {
        bool inBox = true;
        for (int a = 0; a < 3; ++a) inBox = inBox && q.p[size_t(a)] >= lo[a] && q.p[size_t(a)] <= hi[a];
        if (!inBox || fabsl(q.w - 0.5L) < 1e-11L) continue;
        if ((q.w > 0.5L) != (v == kWindingInside) && wrong++ == 0) {
          const WindingSum ws = windingSumOverBox(t, lo, hi, kWindingBoxOpenings);
          first = "box h = " + std::to_string(h) + " holds w - 1/2 = " + std::to_string(double(q.w - 0.5L)) +
                  " centre w - 1/2 " + std::to_string(double(points[i].w - 0.5L)) + " sum/4pi-1/2 " +
                  std::to_string(ws.sum / (4 * M_PI) - 0.5) + " err/4pi " + std::to_string(ws.error / (4 * M_PI)) +
                  " at " + std::to_string(q.p[0]) + " " + std::to_string(q.p[1]) + " " + std::to_string(q.p[2]) +
                  " exactL(c)-1/2 " + std::to_string(double(windingL(m.triangles, points[i].p.data()) - 0.5L));
        }
      }
      for (int k = 0; k < 8; ++k) {
        const double c[3] = {(k & 1) ? hi[0] : lo[0], (k & 2) ? hi[1] : lo[1], (k & 4) ? hi[2] : lo[2]};
        if ((windingL(m.triangles, c) >= 0.5L) != (v == kWindingInside) && wrong++ == 0) first = "box corner";
      }
    }
  }
  EXPECT_EQ(wrong, 0) << first;
  EXPECT_GT(decided, 50);
}

// Every voxel centre of a build against the reference (double, and long
// double where the double is within 1e-6 of 1/2), on a grid where many
// centres crowd around w = 1/2: leaves, uniform elements and the refinement
// of split elements all decide near the threshold.
TEST(WindingNearHalf, EveryVoxelOfABuildAgreesWithTheReference) {
  const int n = 64;
  const Shape s = nearHalfHemisphere(n);
  const PreparedMesh m = prepareMesh(s.mesh, windingBuild(s, n));
  BuildOptions o;
  o.backend = Backend::Cpu;
  const Volume v = buildCpu(m, o);
  const TreeView view = walkVolume(v);
  ASSERT_TRUE(view.problems.empty());
  std::vector<std::array<int, 3>> candidates; // non-surface voxels, all of them
  for (int z = 0; z < n; ++z)
    for (int y = 0; y < n; ++y)
      for (int x = 0; x < n; ++x)
        if (VoxelState(view.dense[size_t(x) + size_t(n) * (size_t(y) + size_t(n) * size_t(z))]) != VoxelState::Surface)
          candidates.push_back({x, y, z});
  std::atomic<int> judged{0}, near{0}, wrong{0};
  std::mutex firstMutex;
  std::string first;
  tbb::parallel_for(size_t(0), candidates.size(), [&](size_t i) {
    const auto& c = candidates[i];
    const double p[3] = {c[0] + 0.5, c[1] + 0.5, c[2] + 0.5};
    // A quick double sum first; long double only near the threshold.
    const double w = windingD(m.triangles, p);
    long double wl = w;
    if (std::fabs(w - 0.5) < 1e-6) wl = windingL(m.triangles, p);
    if (fabsl(wl - 0.5L) < 1e-11L) return;
    ++judged;
    near += fabsl(wl - 0.5L) < 1e-3L;
    const VoxelState got = VoxelState(view.dense[size_t(c[0]) + size_t(n) * (size_t(c[1]) + size_t(n) * size_t(c[2]))]);
    if ((got == VoxelState::Inside) != (wl > 0.5L) && wrong++ == 0) {
      const std::lock_guard<std::mutex> lock(firstMutex);
      first = "voxel " + std::to_string(c[0]) + "," + std::to_string(c[1]) + "," + std::to_string(c[2]) +
              " w - 1/2 = " + std::to_string(double(wl - 0.5L));
    }
  });
  EXPECT_EQ(wrong.load(), 0) << first;
  EXPECT_GT(near.load(), 200) << "too few voxel centres near w = 1/2: the test lost its teeth";
  RecordProperty("judged", judged.load());
  RecordProperty("near_half", near.load());
}

} // namespace
} // namespace test
} // namespace hdt
