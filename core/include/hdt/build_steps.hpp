// The per-element steps of the construction, shared by the CPU and CUDA
// drivers. Each is a small pure function of lattice integers; a driver only
// decides how to schedule them (oneTBB tasks or CUDA threads) and where to put
// the results. Coordinates named `cell` are element indices at one level;
// coordinates named `voxel` are global voxel indices.
#pragma once

#include "hdt/geometry.hpp"
#include "hdt/lattice.hpp"
#include "hdt/platform.hpp"
#include "hdt/types.hpp" // spreadBits16 (orRowIntoLeaf)

namespace hdt {

// Packed (x, y, z) element or leaf coordinates, 21 bits each.
HDT_HD uint64_t packCoord(uint32_t x, uint32_t y, uint32_t z) {
  return uint64_t(x) | (uint64_t(y) << 21) | (uint64_t(z) << 42);
}
HDT_HD uint32_t unpackCoord(uint64_t c, int axis) {
  return uint32_t(c >> (21 * axis)) & 0x1FFFFFu;
}

// Coordinate of child `c` (Morton bits: 1 = +x, 2 = +y, 4 = +z) of a parent.
HDT_HD uint64_t childCoord(uint64_t parent, int c) {
  return packCoord(2 * unpackCoord(parent, 0) + (c & 1), 2 * unpackCoord(parent, 1) + ((c >> 1) & 1),
                   2 * unpackCoord(parent, 2) + ((c >> 2) & 1));
}

// Lattice bounding box of a triangle.
HDT_HD void triangleBounds(const LatticeTriangle& t, int64_t (&lo)[3], int64_t (&hi)[3]) {
  for (int a = 0; a < 3; ++a) {
    lo[a] = detail::min3(t.v[0][a], t.v[1][a], t.v[2][a]);
    hi[a] = detail::max3(t.v[0][a], t.v[1][a], t.v[2][a]);
  }
}

// Cells [first, last] of edge `cellSize` (lattice) whose closed boxes meet the
// closed interval [lo, hi], clamped to [0, count). Empty when first > last.
HDT_HD void cellRange(int64_t lo, int64_t hi, int64_t cellSize, int64_t count, int64_t& first,
                      int64_t& last) {
  first = lo / cellSize - (lo % cellSize == 0 ? 1 : 0);
  last = hi / cellSize;
  if (first < 0) first = 0;
  if (last > count - 1) last = count - 1;
}

// T1/T2: does the triangle meet the closed box of the element at `cell`?
HDT_HD bool triangleOverlapsElement(const LatticeTriangle& t, uint64_t cell, int64_t cellSize) {
  return triangleOverlapsCube(t, unpackCoord(cell, 0) * cellSize, unpackCoord(cell, 1) * cellSize,
                              unpackCoord(cell, 2) * cellSize, cellSize);
}

namespace detail {
// ceil(a / b) and floor(a / b) for b > 0, through a double estimate that is
// then corrected exactly (integer division is several times slower).
HDT_HD int64_t ceilDiv(int64_t a, int64_t b) {
  int64_t q = int64_t(double(a) / double(b));
  while (q * b < a) ++q;
  while ((q - 1) * b >= a) --q;
  return q;
}
HDT_HD int64_t floorDiv(int64_t a, int64_t b) {
  int64_t q = int64_t(double(a) / double(b));
  while (q * b > a) --q;
  while ((q + 1) * b <= a) ++q;
  return q;
}
// Narrows [first, last] to the integers i with lo <= A * i + B <= hi.
HDT_HD void narrowToLinear(int64_t lo, int64_t hi, int64_t A, int64_t B, int64_t& first, int64_t& last) {
  if (A == 0) {
    if (B < lo || B > hi) last = first - 1;
    return;
  }
  const int64_t f = A > 0 ? ceilDiv(lo - B, A) : ceilDiv(B - hi, -A);
  const int64_t l = A > 0 ? floorDiv(hi - B, A) : floorDiv(B - lo, -A);
  if (f > first) first = f;
  if (l < last) last = l;
}
} // namespace detail

// T3: whole-row overlap queries for one triangle. For a row of unit voxels
// along x at (y, z), each of the 13 separating axes a of triangleOverlapsCube
// says: voxel i overlaps on a iff
//     min_k a.v_k - 128 |a|_1  <=  a.c_i  <=  max_k a.v_k + 128 |a|_1
// where the voxel centre c_i = (256 i + 128, 256 y + 128, 256 z + 128) is
// linear in i. So every axis admits an interval of i, and the voxels of the
// row that meet the (convex) triangle are the intersection of 13 intervals:
// no per-voxel test at all. The setup is done once per triangle.
struct RowClipper {
  // Box and edge axes (|a| < 2^25: 64 bits suffice): lo <= A i + ay cy + az cz <= hi.
  int64_t A[12], ay[12], az[12], lo[12], hi[12];
  // The plane axis (the normal, up to 2^51) needs 128 bits: |Pa i + Pb| <= Pr.
  int64_t n[3];
  int128_t planeB0, planeR;
};

HDT_HD void makeRowClipper(const LatticeTriangle& t, RowClipper& c) {
  const int64_t half = kLatticePerVoxel / 2;
  int k = 0;
  auto addAxis = [&](int64_t ax, int64_t ay, int64_t az) {
    const int64_t p0 = ax * t.v[0][0] + ay * t.v[0][1] + az * t.v[0][2];
    const int64_t p1 = ax * t.v[1][0] + ay * t.v[1][1] + az * t.v[1][2];
    const int64_t p2 = ax * t.v[2][0] + ay * t.v[2][1] + az * t.v[2][2];
    const int64_t r = half * (detail::abs64(ax) + detail::abs64(ay) + detail::abs64(az));
    c.A[k] = ax * kLatticePerVoxel;
    c.ay[k] = ay;
    c.az[k] = az;
    c.lo[k] = detail::min3(p0, p1, p2) - r - ax * half;
    c.hi[k] = detail::max3(p0, p1, p2) + r - ax * half;
    ++k;
  };
  // Axes without an x component first: they accept or reject a whole row
  // without a division (the row misses the triangle's yz shadow).
  int64_t e[3][3];
  for (int j = 0; j < 3; ++j) {
    const int m = j == 2 ? 0 : j + 1;
    for (int a = 0; a < 3; ++a) e[j][a] = int64_t(t.v[m][a]) - t.v[j][a];
  }
  addAxis(0, 1, 0);
  addAxis(0, 0, 1);
  for (int j = 0; j < 3; ++j) addAxis(0, -e[j][2], e[j][1]);
  addAxis(1, 0, 0);
  for (int j = 0; j < 3; ++j) {
    addAxis(e[j][2], 0, -e[j][0]);
    addAxis(-e[j][1], e[j][0], 0);
  }
  triangleNormal(t, c.n);
  c.planeR = int128_t(half) * (detail::abs64(c.n[0]) + detail::abs64(c.n[1]) + detail::abs64(c.n[2]));
  c.planeB0 = int128_t(c.n[0]) * (half - t.v[0][0]) - int128_t(c.n[1]) * t.v[0][1] -
              int128_t(c.n[2]) * t.v[0][2];
}

// Narrows [first, last] (global voxel x indices) to the voxels of row (y, z)
// that meet the triangle; first > last when none do.
HDT_HD void clipRow(const RowClipper& c, int64_t y, int64_t z, int64_t& first, int64_t& last) {
  const int64_t cy = latticeOfVoxelCentre(y), cz = latticeOfVoxelCentre(z);
  for (int k = 0; k < 12 && first <= last; ++k) {
    const int64_t B = c.ay[k] * cy + c.az[k] * cz;
    const int64_t A = c.A[k];
    detail::narrowToLinear(c.lo[k], c.hi[k], A, B, first, last);
  }
  if (first > last) return;
  // Plane: d(i) = n.(c_i - v0) = Pa i + Pb, must satisfy |d(i)| <= r. Solve
  // in double, then correct the ends exactly with 128-bit products.
  const int128_t Pa = int128_t(c.n[0]) * kLatticePerVoxel;
  const int128_t Pb = c.planeB0 + int128_t(c.n[1]) * cy + int128_t(c.n[2]) * cz;
  auto meets = [&](int64_t i) {
    const int128_t d = Pa * i + Pb;
    return d >= -c.planeR && d <= c.planeR;
  };
  if (Pa == 0) {
    if (!meets(first)) last = first - 1;
    return;
  }
  const double centre = -double(Pb) / double(Pa);
  const double halfWidth = double(c.planeR) / (Pa > 0 ? double(Pa) : -double(Pa));
  const double lo = centre - halfWidth, hi = centre + halfWidth;
  if (hi < double(first) - 2 || lo > double(last) + 2) {
    last = first - 1;
    return;
  }
  int64_t f = lo < double(first) ? first : int64_t(lo);
  int64_t l = hi > double(last) ? last : int64_t(hi);
  while (f > first && meets(f - 1)) --f;
  while (f <= l && !meets(f)) ++f;
  while (l < last && meets(l + 1)) ++l;
  while (l >= f && !meets(l)) --l;
  first = f;
  last = l;
}

// Narrows [first, last] (voxel y indices) to the rows of slice z whose yz
// square meets the triangle's yz shadow (the five axes without an x
// component), so that clipRow is only asked about rows that can hit.
HDT_HD void clipRowsOfSlice(const RowClipper& c, int64_t z, int64_t& first, int64_t& last) {
  const int64_t cz = latticeOfVoxelCentre(z);
  for (int k = 0; k < 5 && first <= last; ++k) {
    const int64_t A = c.ay[k] * kLatticePerVoxel;
    const int64_t B = c.ay[k] * (kLatticePerVoxel / 2) + c.az[k] * cz;
    detail::narrowToLinear(c.lo[k], c.hi[k], A, B, first, last);
  }
}

// Bits [first - x0, last - x0] of a leaf row starting at voxel x0.
HDT_HD uint32_t rowBits(int64_t x0, int64_t first, int64_t last) {
  if (first > last) return 0;
  const int f = int(first - x0), l = int(last - x0);
  const uint32_t upto = l == 31 ? 0xFFFFFFFFu : ((1u << (l + 1)) - 1u);
  return upto & ~((1u << f) - 1u);
}

// Classification: the row of voxel centres along `axis` at voxel coordinates
// (u, w) of the two other axes, inside a leaf whose extent along `axis` starts
// at voxel a0 and has L voxels. If the triangle is crossed inside the leaf's
// half-open extent, returns true and sets `before` to the number of the row's
// voxel centres strictly before the crossing (each of them sees one more
// crossing ahead of it).
HDT_HD bool rowCrossing(const LatticeTriangle& t, int axis, int64_t u, int64_t w, int64_t a0, int L,
                        int& before) {
  const int64_t pu = latticeOfVoxelCentre(u), pw = latticeOfVoxelCentre(w);
  if (!rayHitsTriangle(t, axis, pu, pw)) return false;
  const Crossing c = rayCrossing(t, axis, pu, pw);
  const int64_t lo = latticeOfVoxel(a0);
  if (!crossingWithin(c, lo, lo + int64_t(L) * kLatticePerVoxel)) return false;
  before = pointsBeforeCrossing(c, latticeOfVoxelCentre(a0), kLatticePerVoxel, L);
  return true;
}

// Voxel rows [first, last] along one axis whose centre lies in the closed
// lattice interval [lo, hi], clamped to the leaf [v0, v0 + L).
HDT_HD void centreRange(int64_t lo, int64_t hi, int64_t v0, int L, int64_t& first, int64_t& last) {
  const int64_t half = kLatticePerVoxel / 2;
  // centre(j) = 256 j + 128 >= lo  <=>  j >= ceil((lo - 128) / 256)
  const int64_t a = lo - half, b = hi - half;
  first = a <= 0 ? -((-a) / kLatticePerVoxel) : (a + kLatticePerVoxel - 1) / kLatticePerVoxel;
  last = b >= 0 ? b / kLatticePerVoxel : -((-b + kLatticePerVoxel - 1) / kLatticePerVoxel);
  if (first < v0) first = v0;
  if (last > v0 + L - 1) last = v0 + L - 1;
}

// Writes a row of L voxel bits (bit i = voxel i) into leaf words as the given
// 2-bit plane (0: the "inside" bit, 1: the "surface" bit).
HDT_HD void orRowIntoLeaf(uint32_t* words, int L, int row, uint32_t mask, int plane) {
  const uint32_t v = uint32_t(row) * uint32_t(L); // first voxel of the row
  for (int k = 0; k < L; k += 16) {
    const uint32_t bits = (L == 8) ? (mask & 0xFFu) : ((mask >> k) & 0xFFFFu);
    const uint32_t voxel = v + uint32_t(k);
    words[voxel >> 4] |= (spreadBits16(bits) << plane) << (2 * (voxel & 15u));
  }
}

// Inverse of orRowIntoLeaf: the row's bits of one 2-bit plane.
HDT_HD uint32_t rowFromLeaf(const uint32_t* words, int L, int row, int plane) {
  const uint32_t v = uint32_t(row) * uint32_t(L);
  uint32_t mask = 0;
  for (int k = 0; k < L; k += 16) {
    const uint32_t voxel = v + uint32_t(k);
    uint32_t m = (words[voxel >> 4] >> (2 * (voxel & 15u) + plane)) & 0x55555555u;
    m = (m | (m >> 1)) & 0x33333333u; // compact every other bit: inverse of spreadBits16
    m = (m | (m >> 2)) & 0x0F0F0F0Fu;
    m = (m | (m >> 4)) & 0x00FF00FFu;
    m = (m | (m >> 8)) & 0x0000FFFFu;
    mask |= (L == 8 ? (m & 0xFFu) : m) << k;
  }
  return mask;
}

// Mask of the L voxels of a leaf row (L <= 32).
HDT_HD constexpr uint32_t fullRowMask(int L) { return L == 32 ? 0xFFFFFFFFu : ((1u << L) - 1u); }

} // namespace hdt
