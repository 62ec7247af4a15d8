// The leaf steps of build_steps.hpp against per-voxel and per-ray tests:
// T3's row clipping against triangleOverlapsCube, classification's ray spans
// against rayHitsTriangle and its crossing counts against a brute count.
//
// clipRow answers "which voxels of this row meet the triangle" as one
// interval, composed from per-slice, per-height and per-row steps that the
// drivers evaluate at different loop levels, with double estimates corrected
// exactly. Here every voxel of a window around each triangle is tested on its
// own with triangleOverlapsCube, and the row interval must be exactly the set
// of voxels that overlap, for small, large and huge (lattice-limit)
// triangles, axis-aligned ones and slivers. The split form the CPU and CUDA
// drivers use is checked to give the same interval.
#include "hdt/build_steps.hpp"
#include "hdt/classify_steps.hpp"
#include "hdt/geometry.hpp"

#include <gtest/gtest.h>

#include <algorithm>
#include <cstdint>
#include <random>
#include <vector>

namespace hdt {
namespace test {
namespace {

constexpr int64_t kMaxLattice = int64_t(kMaxResolution) * kLatticePerVoxel - 1;

int64_t floorDivExact(int64_t a, int64_t b) { return a >= 0 ? a / b : -((-a + b - 1) / b); }

TEST(LeafSteps, CeilAndFloorDivisionMatchIntegerDivision) {
  std::mt19937_64 rng(7);
  for (int i = 0; i < 200000; ++i) {
    const int bits = int(rng() % 60) + 1;
    int64_t a = int64_t(rng() >> (64 - bits));
    if (rng() & 1) a = -a;
    const int64_t b = int64_t(rng() >> (64 - int(rng() % 50) - 1)) + 1;
    const double inv = 1.0 / double(b);
    ASSERT_EQ(detail::floorDiv(a, b, inv), floorDivExact(a, b)) << a << " / " << b;
    ASSERT_EQ(detail::ceilDiv(a, b, inv), -floorDivExact(-a, b)) << a << " / " << b;
  }
}

// The leaf kernels write runs of voxels straight into leaf words: the
// fields [lo, hi] of a word must be the spread row mask of those voxels.
TEST(LeafSteps, FieldRangeBitsEqualSpreadRowMasks) {
  for (int lo = 0; lo < 16; ++lo)
    for (int hi = lo; hi < 16; ++hi)
      ASSERT_EQ(spreadBits16(fullRowMask(hi + 1) & ~fullRowMask(lo)), fieldRangeBits(lo, hi)) << lo << " " << hi;
}

// A run along any axis lands on its own voxels as x-row runs: every voxel
// of the permuted run once, nothing else.
// Closed-mesh pass 2 on the device: each sector of 8 words takes its exit
// parities from one word of row bits as plane-0 fields; every word of every
// leaf size classifies as classifiedWord with rowBitsToWordBits does, on
// random words (all four field states) and random row parities.
TEST(LeafSteps, ClassifiedWordFromFieldsEqualsClassifiedWord) {
  std::mt19937 rng(18);
  for (int L : {8, 16, 32}) {
    const int words = int(leafWordCount(L)), rowWords = rowWordsFor(L);
    for (int trial = 0; trial < 200; ++trial) {
      std::vector<uint32_t> rows(static_cast<size_t>(rowWords));
      for (uint32_t& r : rows) r = trial % 4 == 0 ? ~0u : rng();
      for (int w = 0; w < words; ++w) {
        const uint32_t word = trial % 8 == 1 ? kInsidePlaneBits : rng();
        const uint32_t sectorRows = rows[size_t(firstRowOfWord(L, w & ~7) >> 5)];
        ASSERT_EQ(classifiedWordFields(word, exitFieldsOfWord(sectorRows, L, w)),
                  classifiedWord(word, rowBitsToWordBits(rows.data(), L, w)))
            << "L " << L << " word " << w << " trial " << trial;
      }
    }
  }
}

TEST(LeafSteps, RunsAlongEveryAxisBecomeXRowRuns) {
  constexpr int L = 16;
  std::mt19937_64 rng(5);
  for (int rep = 0; rep < 2000; ++rep) {
    const int axis = int(rng() % 3), h = int(rng() % L), s = int(rng() % L);
    const int first = int(rng() % L), last = int(rng() % L) - (rep % 7 == 0 ? L : 0); // some empty
    int want[L * L * L] = {}, got[L * L * L] = {};
    for (int i = first; i <= last; ++i) {
      const int p[3] = {i, h, s}; // (along, height, slice) in the row-axis frame: coordinate (axis + k) % 3 is p[k]
      int v[3];
      for (int k = 0; k < 3; ++k) v[(axis + k) % 3] = p[k];
      ++want[v[0] + L * (v[1] + L * v[2])];
    }
    forEachXRowRunOf(axis, L, h, s, first, last, [&](int row, int lo, int hi) {
      ASSERT_TRUE(0 <= lo && lo <= hi && hi < L && row >= 0 && row < L * L);
      for (int x = lo; x <= hi; ++x) ++got[x + L * row];
    });
    for (int v = 0; v < L * L * L; ++v) ASSERT_EQ(want[v], got[v]) << "axis " << axis << " voxel " << v;
  }
}

// The voxels of row (y, z) in [x0, x1] that overlap, as [first, last]; the
// overlap set of a convex triangle and a row is an interval, checked too.
void referenceRow(const LatticeTriangle& t, int64_t y, int64_t z, int64_t x0, int64_t x1, int64_t& first,
                  int64_t& last) {
  first = x1 + 1;
  last = x0 - 1;
  for (int64_t x = x0; x <= x1; ++x) {
    if (!triangleOverlapsCube(t, latticeOfVoxel(x), latticeOfVoxel(y), latticeOfVoxel(z), kLatticePerVoxel))
      continue;
    ASSERT_TRUE(last == x0 - 1 || last == x - 1) << "overlap set is not an interval at x=" << x;
    if (first > x) first = x;
    last = x;
  }
}

// The drivers' composition: the triangle's voxel box (cellRange), the slice's
// rows and span, the column span, the plane. The CPU driver evaluates the
// spans on the box clamped to the window (its leaf); the CUDA driver on the
// whole box, once per triangle, clamping the results to the window after.
void splitRow(const LatticeTriangle& t, const RowClipper& c, int64_t y, int64_t z, int64_t x0, int64_t x1,
              bool wholeBox, int64_t& first, int64_t& last) {
  int64_t bf[3], bl[3];
  triangleVoxelBox(t, kMaxResolution, bf, bl);
  first = x0;
  last = x1;
  if (y < bf[1] || y > bl[1] || z < bf[2] || z > bl[2]) {
    last = first - 1;
    return;
  }
  if (!wholeBox) { // the window's part of the box: x [x0, x1], the row's y and z
    bf[0] = std::max(x0, bf[0]);
    bl[0] = std::min(x1, bl[0]);
    bf[1] = bl[1] = y;
    bf[2] = bl[2] = z;
  }
  int64_t y0, y1, sf, sl, cf, cl;
  sliceSpans(c, bf, bl, z, y0, y1, sf, sl);
  columnSpan(c, bf, bl, y, cf, cl);
  first = std::max({x0, sf, cf});
  last = std::min({x1, sl, cl});
  if (y < y0 || y > y1) last = first - 1;
  clipRowByPlane(c.plane, y, z, first, last);
}

// Checks every row of a W^3 window whose low corner is voxel (wx, wy, wz).
void checkWindow(const LatticeTriangle& t, int64_t wx, int64_t wy, int64_t wz, int W, int& rowsHit) {
  RowClipper c;
  makeRowClipper(t, c);
  for (int64_t z = wz; z < wz + W; ++z)
    for (int64_t y = wy; y < wy + W; ++y) {
      int64_t rf, rl;
      referenceRow(t, y, z, wx, wx + W - 1, rf, rl);
      if (::testing::Test::HasFatalFailure()) return;
      int64_t f = wx, l = wx + W - 1;
      clipRow(c, y, z, f, l);
      const bool refEmpty = rf > rl, gotEmpty = f > l;
      ASSERT_EQ(refEmpty, gotEmpty) << "row y=" << y << " z=" << z << " ref [" << rf << ", " << rl << "] got [" << f
                                    << ", " << l << "]";
      if (!refEmpty) {
        ASSERT_EQ(rf, f) << "row y=" << y << " z=" << z;
        ASSERT_EQ(rl, l) << "row y=" << y << " z=" << z;
        ++rowsHit;
      }
      for (const bool wholeBox : {false, true}) {
        int64_t sf, sl;
        splitRow(t, c, y, z, wx, wx + W - 1, wholeBox, sf, sl);
        ASSERT_EQ(refEmpty, sf > sl) << "split form (whole box " << wholeBox << "), row y=" << y << " z=" << z;
        if (!refEmpty) {
          ASSERT_EQ(rf, sf) << "split form (whole box " << wholeBox << "), row y=" << y << " z=" << z;
          ASSERT_EQ(rl, sl) << "split form (whole box " << wholeBox << "), row y=" << y << " z=" << z;
        }
      }
    }
}

// A window of W voxels around a random point of the triangle.
void checkAroundTriangle(const LatticeTriangle& t, std::mt19937_64& rng, int W, int& rowsHit) {
  std::uniform_real_distribution<double> u(0.0, 1.0);
  double a = u(rng), b = u(rng);
  if (a + b > 1) {
    a = 1 - a;
    b = 1 - b;
  }
  int64_t corner[3];
  for (int k = 0; k < 3; ++k) {
    const double p = t.v[0][k] + a * (t.v[1][k] - t.v[0][k]) + b * (t.v[2][k] - t.v[0][k]);
    corner[k] = std::clamp<int64_t>(int64_t(p) / kLatticePerVoxel - W / 2, 0, kMaxResolution - W);
  }
  checkWindow(t, corner[0], corner[1], corner[2], W, rowsHit);
}

int32_t coord(std::mt19937_64& rng, int64_t centre, int64_t spread, int snapBits) {
  const int64_t off = int64_t(rng() % uint64_t(2 * spread + 1)) - spread;
  int64_t v = std::clamp<int64_t>(centre + off, 0, kMaxLattice);
  if (snapBits > 0) v &= ~((int64_t(1) << snapBits) - 1); // on voxel planes (8) or half-voxels (7)
  return int32_t(v);
}

// T2 tests the eight children of an element at once: each bit must be the
// per-child overlap test, for triangles from a fraction of a child to many
// elements, with vertices on the children's planes and centres (ties).
TEST(LeafSteps, ChildrenOverlapEqualsPerChildTest) {
  std::mt19937_64 rng(13);
  int hits = 0, partial = 0;
  for (const int64_t childVoxels : {int64_t(1), int64_t(2), int64_t(64), int64_t(4096)}) {
    const int64_t childSize = childVoxels * kLatticePerVoxel, cells = kMaxResolution / (2 * childVoxels);
    for (int i = 0; i < 4000; ++i) {
      const uint32_t c[3] = {uint32_t(rng() % uint64_t(cells)), uint32_t(rng() % uint64_t(cells)),
                             uint32_t(rng() % uint64_t(cells))};
      const uint64_t cell = packCoord(c[0], c[1], c[2]);
      const int64_t spread = childSize >> (i % 4); // a child, half, a quarter, an eighth
      const int snap = i % 3 == 0 ? 8 : (i % 3 == 1 ? 7 : 0);
      LatticeTriangle t; // around the parent's centre
      for (int v = 0; v < 3; ++v)
        for (int k = 0; k < 3; ++k) t.v[v][k] = coord(rng, int64_t(c[k]) * 2 * childSize + childSize, 2 * spread, snap);
      if (i % 5 == 2) t.v[1][i % 3] = t.v[2][i % 3] = t.v[0][i % 3]; // axis-aligned plane
      if (i % 13 == 6) t.v[0][i % 3] = int32_t(int64_t(c[i % 3]) * 2 * childSize + childSize); // on a split plane
      uint32_t want = 0;
      for (int k = 0; k < 8; ++k)
        if (triangleOverlapsElement(t, childCoord(cell, k), childSize)) want |= 1u << k;
      ASSERT_EQ(want, triangleOverlapsChildren(t, cell, childSize))
          << "child size " << childSize << " triangle (" << t.v[0][0] << "," << t.v[0][1] << "," << t.v[0][2]
          << ") (" << t.v[1][0] << "," << t.v[1][1] << "," << t.v[1][2] << ") (" << t.v[2][0] << "," << t.v[2][1]
          << "," << t.v[2][2] << ")";
      hits += want != 0;
      partial += want != 0 && want != 0xFFu;
    }
  }
  EXPECT_GT(hits, 8000);    // most triangles meet their parent
  EXPECT_GT(partial, 4000); // and many meet only some children
}

class RowClippingScale : public ::testing::TestWithParam<int64_t> {};

TEST_P(RowClippingScale, RowIntervalsEqualPerVoxelOverlap) {
  const int64_t spread = GetParam(); // lattice units: triangle size
  std::mt19937_64 rng(uint64_t(spread) * 31 + 1);
  int rowsHit = 0;
  for (int i = 0; i < 60; ++i) {
    const int snap = i % 4 == 0 ? 8 : (i % 4 == 1 ? 7 : 0); // faces and vertices on voxel planes / centres
    const int64_t centre = int64_t(rng() % uint64_t(kMaxLattice - 2 * spread)) + spread;
    LatticeTriangle t;
    for (int v = 0; v < 3; ++v)
      for (int k = 0; k < 3; ++k) t.v[v][k] = coord(rng, centre, spread, snap);
    if (i % 5 == 2) // axis-aligned: one coordinate shared
      t.v[1][i % 3] = t.v[2][i % 3] = t.v[0][i % 3];
    if (i % 7 == 3) // sliver: third vertex near the first edge
      for (int k = 0; k < 3; ++k) t.v[2][k] = int32_t((int64_t(t.v[0][k]) + t.v[1][k]) / 2 + int64_t(rng() % 3) - 1);
    checkAroundTriangle(t, rng, 20, rowsHit);
    if (HasFatalFailure()) {
      ADD_FAILURE() << "triangle (" << t.v[0][0] << "," << t.v[0][1] << "," << t.v[0][2] << ") (" << t.v[1][0] << ","
                    << t.v[1][1] << "," << t.v[1][2] << ") (" << t.v[2][0] << "," << t.v[2][1] << "," << t.v[2][2]
                    << ")";
      return;
    }
  }
  EXPECT_GT(rowsHit, 60); // the windows did meet the triangles
}

// Triangle sizes from a fraction of a voxel to the whole 65536^3 lattice.
INSTANTIATE_TEST_SUITE_P(Sizes, RowClippingScale,
                         ::testing::Values(int64_t(100), int64_t(1000), int64_t(20000), int64_t(1) << 20,
                                           int64_t(1) << 23, kMaxLattice / 2 - 1));

// raySpanAtW must pick exactly the rays rayHitsTriangle accepts, including
// rays through vertices and along edges (vertices on voxel centres), and
// pointsBeforeCrossing must count exactly.
class RaySpanScale : public ::testing::TestWithParam<int64_t> {};

// Triangle i of a ray test at this size: vertices on voxel planes, on
// half-voxels or anywhere in turn, some axis-aligned, some with an edge
// along z.
LatticeTriangle rayTestTriangle(std::mt19937_64& rng, int64_t spread, int i) {
  const int snap = i % 3 == 0 ? 7 : (i % 3 == 1 ? 8 : 0);
  const int64_t centre = int64_t(rng() % uint64_t(kMaxLattice - 2 * spread)) + spread;
  LatticeTriangle t;
  for (int v = 0; v < 3; ++v)
    for (int k = 0; k < 3; ++k) t.v[v][k] = coord(rng, centre, spread, snap);
  if (i % 5 == 2) t.v[1][i % 3] = t.v[2][i % 3] = t.v[0][i % 3]; // axis-aligned plane
  if (i % 11 == 4) { t.v[2][0] = t.v[1][0]; t.v[2][1] = t.v[1][1]; } // an edge along z
  return t;
}

TEST_P(RaySpanScale, SpanEqualsPerRayHitTest) {
  const int64_t spread = GetParam();
  std::mt19937_64 rng(uint64_t(spread) * 17 + 3);
  int hits = 0, inLeaf = 0;
  for (int i = 0; i < 200; ++i) {
    const LatticeTriangle t = rayTestTriangle(rng, spread, i);
    for (int axis = 0; axis < 3; ++axis) {
      const int U = rayAxisU(axis), W = rayAxisW(axis);
      int64_t lo[3], hi[3];
      triangleBounds(t, lo, hi);
      const int64_t u0 = std::max<int64_t>(0, lo[U] / kLatticePerVoxel - 2), w0 = std::max<int64_t>(0, lo[W] / kLatticePerVoxel - 2);
      const int64_t u1 = std::min<int64_t>(u0 + 40, hi[U] / kLatticePerVoxel + 2), w1 = std::min<int64_t>(w0 + 40, hi[W] / kLatticePerVoxel + 2);
      for (int64_t w = w0; w <= w1; ++w) {
        int64_t f = u0, l = u1;
        raySpanAtW(t, axis, w, f, l);
        // The CUDA driver's form: the span of the whole line of rays (the
        // triangle's centre range), evaluated once and clamped to a leaf.
        int64_t wf, wl;
        centreRange(lo[U], hi[U], 0, kMaxResolution, wf, wl);
        raySpanAtW(t, axis, w, wf, wl);
        wf = std::max(wf, u0);
        wl = std::min(wl, u1);
        ASSERT_EQ(f > l, wf > wl) << "whole-line span, axis " << axis << " w=" << w;
        if (f <= l) {
          ASSERT_EQ(f, wf);
          ASSERT_EQ(l, wl);
        }
        for (int64_t u = u0; u <= u1; ++u) {
          const bool expect = rayHitsTriangle(t, axis, latticeOfVoxelCentre(u), latticeOfVoxelCentre(w));
          ASSERT_EQ(expect, u >= f && u <= l) << "axis " << axis << " u=" << u << " w=" << w << " span [" << f << ", "
                                              << l << "] triangle " << i;
          if (!expect) continue;
          ++hits;
          const Crossing c = rayCrossing(t, axis, latticeOfVoxelCentre(u), latticeOfVoxelCentre(w));
          for (int L : {8, 16, 32}) {
            // Leaves along the ray that end just before, at or after the
            // crossing's voxel xc, or start there (the ties: a crossing on a
            // leaf's end, on its first centre), the ray at a random place in each.
            const int64_t xc = int64_t(c.num / (int128_t(c.den) * kLatticePerVoxel));
            for (int64_t a0 : {xc - L - 1, xc - L, xc - L + 1, xc - L / 2, xc - 1, xc, xc + 1}) {
              if (a0 < 0) continue;
              int count = 0; // brute force: centres strictly before the crossing
              while (count < L && int128_t(latticeOfVoxelCentre(a0 + count)) * c.den < c.num) ++count;
              ASSERT_EQ(count, pointsBeforeCrossing(c, latticeOfVoxelCentre(a0), kLatticePerVoxel, L));
              int64_t v0[3];
              v0[axis] = a0;
              v0[U] = u - int64_t(rng() % uint64_t(L)); // the ray somewhere in the leaf
              v0[W] = w - int64_t(rng() % uint64_t(L));
              if (v0[U] < 0 || v0[W] < 0) continue;
              const int64_t leafLo = latticeOfVoxel(a0);
              const bool within = crossingWithin(c, leafLo, leafLo + L * kLatticePerVoxel);
              LeafCrossings lc;
              makeLeafCrossings(t, axis, v0, L, lc);
              int before = -1, refBefore = -1;
              ASSERT_EQ(within, crossingInLeaf(lc, int(u - v0[U]), int(w - v0[W]), L, before));
              ASSERT_EQ(within, crossingInLeaf(t, axis, u, w, a0, L, refBefore));
              if (within) {
                ASSERT_EQ(count, before) << "leaf-wide crossings, L=" << L;
                ASSERT_EQ(count, refBefore);
                ++inLeaf;
              }
            }
          }
        }
      }
    }
  }
  EXPECT_GT(hits, 100);
  EXPECT_GT(inLeaf, 100);
}

// narrowToLeafCrossings only skips work: every ray whose crossing lies in
// the leaf stays in the narrowed span. And it does skip: leaves stacked
// along the ray axis over the triangle each see the triangle's hit rays, but
// only about one leaf's worth of them survive in all (counted where the
// crossings are narrow: others are left whole, and huge triangles are).
TEST_P(RaySpanScale, NarrowedSpanKeepsEveryCrossingInTheLeaf) {
  const int64_t spread = GetParam();
  std::mt19937_64 rng(uint64_t(spread) * 31 + 5);
  uint64_t spans = 0, kept = 0, crossings = 0, keptLines = 0, all = 0;
  for (int i = 0; i < 40; ++i) {
    const LatticeTriangle t = rayTestTriangle(rng, spread, i);
    for (int axis = 0; axis < 3; ++axis) {
      const int U = rayAxisU(axis), W = rayAxisW(axis);
      int64_t lo[3], hi[3];
      triangleBounds(t, lo, hi);
      for (int L : {8, 16, 32}) {
        int64_t v0[3];
        v0[U] = std::max<int64_t>(0, lo[U] / kLatticePerVoxel - int64_t(rng() % uint64_t(L)));
        v0[W] = std::max<int64_t>(0, lo[W] / kLatticePerVoxel - int64_t(rng() % uint64_t(L)));
        const int64_t first = std::max<int64_t>(0, lo[axis] / kLatticePerVoxel / L - 1);
        const int64_t last = std::min(first + 40, hi[axis] / kLatticePerVoxel / L + 1);
        for (int64_t leaf = first; leaf <= last; ++leaf) {
          v0[axis] = leaf * L;
          LeafCrossings lc;
          makeLeafCrossings(t, axis, v0, L, lc);
          for (int dw = 0; dw < L; ++dw) {
            int64_t f = v0[U], l = v0[U] + L - 1;
            raySpanAtW(t, axis, v0[W] + dw, f, l);
            if (f > l) continue;
            const int sf = int(f - v0[U]), sl = int(l - v0[U]);
            int nf = sf, nl = sl;
            narrowToLeafCrossings(lc, dw, nf, nl);
            if (nf <= nl) {
              ASSERT_GE(nf, sf);
              ASSERT_LE(nl, sl);
              if (lc.narrow) kept += uint64_t(nl - nf + 1), ++keptLines;
            }
            if (lc.narrow) spans += uint64_t(sl - sf + 1);
            for (int du = sf; du <= sl; ++du) {
              int before;
              if (!crossingInLeaf(lc, du, dw, L, before)) continue;
              ++all;
              if (lc.narrow) ++crossings;
              ASSERT_TRUE(du >= nf && du <= nl) << "axis " << axis << " L=" << L << " leaf " << leaf << " ray "
                                                << du << " not in [" << nf << ", " << nl << "]";
            }
          }
        }
      }
    }
  }
  ASSERT_GT(all, 0u);
  if (spread > (int64_t(1) << 20)) return; // no narrow crossings at this size
  ASSERT_GT(crossings, 0u);
  // Each narrowed span holds its crossings and about one ray more at each end.
  EXPECT_LE(kept, crossings + 3 * keptLines) << "spans " << spans;
  EXPECT_LT(2 * kept, spans) << "crossings " << crossings;
}

INSTANTIATE_TEST_SUITE_P(Sizes, RaySpanScale,
                         ::testing::Values(int64_t(300), int64_t(3000), int64_t(1) << 20, kMaxLattice / 2 - 1));

// Open-mesh votes turn y and z rows into x rows: every voxel must land at
// its own bit, for every leaf size.
template <int L>
void checkAxisRowsToXRows(std::mt19937_64& rng) {
  uint32_t rows[L * L], xRows[L * L];
  for (int axis = 1; axis < 3; ++axis) {
    for (uint32_t& r : rows) r = uint32_t(rng()) & fullRowMask(L);
    for (int i = 0; i < L; ++i) xRowsOfAxisMatrix<L>(axis, i, rows, xRows);
    for (int x = 0; x < L; ++x)
      for (int y = 0; y < L; ++y)
        for (int z = 0; z < L; ++z) {
          // Axis 1: row z + L x, bit y. Axis 2: row x + L y, bit z.
          const uint32_t expect = axis == 1 ? (rows[z + L * x] >> y) & 1u : (rows[x + L * y] >> z) & 1u;
          ASSERT_EQ(expect, (xRows[y + L * z] >> x) & 1u) << "L=" << L << " axis " << axis << " voxel " << x << ","
                                                          << y << "," << z;
        }
  }
}

TEST(LeafSteps, AxisRowsBecomeXRows) {
  std::mt19937_64 rng(11);
  for (int rep = 0; rep < 4; ++rep) {
    checkAxisRowsToXRows<8>(rng);
    checkAxisRowsToXRows<16>(rng);
    checkAxisRowsToXRows<32>(rng);
  }
}

} // namespace
} // namespace test
} // namespace hdt
