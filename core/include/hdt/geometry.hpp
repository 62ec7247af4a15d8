// Exact geometric predicates on lattice triangles, shared by both drivers.
//
// triangleOverlapsCube   Akenine-Moeller separating-axis test (13 axes) for a
//                        closed axis-aligned cube. Touching counts as overlap,
//                        so a face lying on a voxel plane marks the voxels on
//                        both sides of it.
// rayHitsTriangle        does the ray along +axis through a row centre pass
//                        through the triangle? Exact 2D orientations with the
//                        query point perturbed symbolically by (eps, eps^2)
//                        (simulation of simplicity): a ray through an edge or a
//                        vertex is counted by exactly one of the triangles
//                        around it, so parity is exact on closed meshes.
// Crossing               where that ray meets the triangle's plane, as an exact
//                        rational, with the comparisons the classifier needs.
#pragma once

#include "hdt/lattice.hpp"
#include "hdt/platform.hpp"

#include <cmath>

namespace hdt {

namespace detail {
HDT_HD int64_t abs64(int64_t a) { return a < 0 ? -a : a; }
HDT_HD int64_t min3(int64_t a, int64_t b, int64_t c) {
  const int64_t m = a < b ? a : b;
  return m < c ? m : c;
}
HDT_HD int64_t max3(int64_t a, int64_t b, int64_t c) {
  const int64_t m = a > b ? a : b;
  return m > c ? m : c;
}
// Separating-axis test along one axis; true if the axis separates.
HDT_HD bool separatedOnAxis(int64_t ax, int64_t ay, int64_t az, const int64_t (&v)[3][3],
                            int64_t half) {
  const int64_t p0 = ax * v[0][0] + ay * v[0][1] + az * v[0][2];
  const int64_t p1 = ax * v[1][0] + ay * v[1][1] + az * v[1][2];
  const int64_t p2 = ax * v[2][0] + ay * v[2][1] + az * v[2][2];
  const int64_t r = half * (abs64(ax) + abs64(ay) + abs64(az));
  return min3(p0, p1, p2) > r || max3(p0, p1, p2) < -r;
}
} // namespace detail

// Twice the triangle's normal (e0 x e1); zero for a degenerate triangle.
HDT_HD void triangleNormal(const LatticeTriangle& t, int64_t (&n)[3]) {
  const int64_t e0[3] = {int64_t(t.v[1][0]) - t.v[0][0], int64_t(t.v[1][1]) - t.v[0][1],
                         int64_t(t.v[1][2]) - t.v[0][2]};
  const int64_t e1[3] = {int64_t(t.v[2][0]) - t.v[1][0], int64_t(t.v[2][1]) - t.v[1][1],
                         int64_t(t.v[2][2]) - t.v[1][2]};
  n[0] = e0[1] * e1[2] - e0[2] * e1[1];
  n[1] = e0[2] * e1[0] - e0[0] * e1[2];
  n[2] = e0[0] * e1[1] - e0[1] * e1[0];
}

// Area in voxel^2, in double: for memory estimates and load balance only
// (never for a decision the bytes depend on).
HDT_HD double triangleArea(const LatticeTriangle& t) {
  int64_t n[3];
  triangleNormal(t, n);
  const double perVoxel2 = double(kLatticePerVoxel) * double(kLatticePerVoxel);
  return 0.5 * sqrt(double(n[0]) * n[0] + double(n[1]) * n[1] + double(n[2]) * n[2]) / perVoxel2;
}

HDT_HD bool isDegenerate(const LatticeTriangle& t) {
  int64_t n[3];
  triangleNormal(t, n);
  return n[0] == 0 && n[1] == 0 && n[2] == 0;
}

// Closed cube [lo, lo + size] (lattice units, size even) against triangle t.
HDT_HD bool triangleOverlapsCube(const LatticeTriangle& t, int64_t lox, int64_t loy, int64_t loz,
                                 int64_t size) {
  const int64_t h = size / 2;
  const int64_t c[3] = {lox + h, loy + h, loz + h};
  int64_t v[3][3];
  for (int i = 0; i < 3; ++i)
    for (int a = 0; a < 3; ++a) v[i][a] = t.v[i][a] - c[a];

  // The cube's own face normals: bounding-box overlap.
  for (int a = 0; a < 3; ++a) {
    if (detail::min3(v[0][a], v[1][a], v[2][a]) > h) return false;
    if (detail::max3(v[0][a], v[1][a], v[2][a]) < -h) return false;
  }
  // Cross products of the cube's axes with the triangle's edges.
  for (int j = 0; j < 3; ++j) {
    const int k = j == 2 ? 0 : j + 1;
    const int64_t e[3] = {v[k][0] - v[j][0], v[k][1] - v[j][1], v[k][2] - v[j][2]};
    if (detail::separatedOnAxis(0, -e[2], e[1], v, h)) return false;
    if (detail::separatedOnAxis(e[2], 0, -e[0], v, h)) return false;
    if (detail::separatedOnAxis(-e[1], e[0], 0, v, h)) return false;
  }
  // The triangle's plane: |n . v0| <= h * (|nx| + |ny| + |nz|), in 128 bits.
  int64_t n[3];
  triangleNormal(t, n);
  const int128_t d = int128_t(n[0]) * v[0][0] + int128_t(n[1]) * v[0][1] + int128_t(n[2]) * v[0][2];
  const int128_t r = int128_t(h) * (detail::abs64(n[0]) + detail::abs64(n[1]) + detail::abs64(n[2]));
  return (d < 0 ? -d : d) <= r;
}

// Axis helpers for rays: the ray runs along `axis`; u and w are the two other
// coordinates in cyclic order (axis 0: u = y, w = z; 1: u = z, w = x; 2: u = x, w = y).
HDT_HD constexpr int rayAxisU(int axis) { return axis == 2 ? 0 : axis + 1; }
HDT_HD constexpr int rayAxisW(int axis) { return axis == 0 ? 2 : axis - 1; }

// Sign of orient2d(A, B, P + (eps, eps^2)): never zero unless A == B.
HDT_HD int orientPerturbed(int64_t au, int64_t aw, int64_t bu, int64_t bw, int64_t pu, int64_t pw) {
  const int64_t o = (bu - au) * (pw - aw) - (bw - aw) * (pu - au);
  if (o != 0) return o > 0 ? 1 : -1;
  if (bw != aw) return bw > aw ? -1 : 1; // coefficient of eps:   -(bw - aw)
  if (bu != au) return bu > au ? 1 : -1; // coefficient of eps^2: +(bu - au)
  return 0;
}

// Does the line along `axis` through (u, w) pierce the triangle's projection?
HDT_HD bool rayHitsTriangle(const LatticeTriangle& t, int axis, int64_t pu, int64_t pw) {
  const int a = rayAxisU(axis), b = rayAxisW(axis);
  const int s0 = orientPerturbed(t.v[0][a], t.v[0][b], t.v[1][a], t.v[1][b], pu, pw);
  const int s1 = orientPerturbed(t.v[1][a], t.v[1][b], t.v[2][a], t.v[2][b], pu, pw);
  const int s2 = orientPerturbed(t.v[2][a], t.v[2][b], t.v[0][a], t.v[0][b], pu, pw);
  return s0 != 0 && s0 == s1 && s1 == s2;
}

// Position num / den (den > 0) along `axis` where the line through (u, w)
// meets the triangle's plane. Only meaningful when rayHitsTriangle() is true
// (then the plane is not parallel to the axis).
struct Crossing {
  int128_t num;
  int64_t den;
};

HDT_HD Crossing rayCrossing(const LatticeTriangle& t, int axis, int64_t pu, int64_t pw) {
  const int a = rayAxisU(axis), b = rayAxisW(axis);
  int64_t n[3];
  triangleNormal(t, n);
  // n . (X - v0) = 0  =>  x = (n_axis * v0_axis - n_u (pu - v0_u) - n_w (pw - v0_w)) / n_axis
  int128_t num = int128_t(n[axis]) * t.v[0][axis] - int128_t(n[a]) * (pu - t.v[0][a]) -
                 int128_t(n[b]) * (pw - t.v[0][b]);
  int64_t den = n[axis];
  if (den < 0) {
    num = -num;
    den = -den;
  }
  return Crossing{num, den};
}

// Is the crossing inside the half-open lattice interval [lo, hi)?
HDT_HD bool crossingWithin(const Crossing& c, int64_t lo, int64_t hi) {
  return int128_t(lo) * c.den <= c.num && c.num < int128_t(hi) * c.den;
}

// How many of the points first, first + step, ..., first + (count - 1) * step
// lie strictly before the crossing: ceil(m / (step den)) clamped to [0, count]
// with m = num - first den. A double estimate of the quotient is corrected
// with exact 128-bit products (no 128-bit division: a slow software routine
// on GPUs); count is small (a leaf's width), so the correction is short.
HDT_HD int pointsBeforeCrossing(const Crossing& c, int64_t first, int64_t step, int count) {
  const int128_t m = c.num - int128_t(first) * c.den; // > 0 iff first is before
  if (m <= 0) return 0;
  const int128_t per = int128_t(step) * c.den;
  if (m > per * count) return count;
  const double q = double(m) / double(per);
  int k = q < 1.0 ? 1 : (q > double(count) ? count : int(q));
  while (k > 1 && per * (k - 1) >= m) --k;
  while (per * k < m) ++k;
  return k;
}

} // namespace hdt
