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

// T2: the children of the element at `cell` (edge 2 childSize) that the
// triangle meets, as a byte: bit c is triangleOverlapsElement(t,
// childCoord(cell, c), childSize), for all eight at once. Each separating
// axis a of triangleOverlapsCube projects the triangle once, relative to the
// parent's centre P. Child c's centre is P + h s_c (h = childSize / 2, s_c
// the child's signs, +1 where bit d of c is set), which shifts every
// projection by h (a . s_c); so with r = h |a|_1 child c is separated on a
// iff  min_k a.(v_k - P) - r > h (a . s_c)  or  max_k a.(v_k - P) + r <
// h (a . s_c): the integers the per-child test compares, moved across.
HDT_HD uint32_t triangleOverlapsChildren(const LatticeTriangle& t, uint64_t cell, int64_t childSize) {
  const int64_t h = childSize / 2;
  int64_t v[3][3];
  for (int a = 0; a < 3; ++a) {
    const int64_t centre = int64_t(unpackCoord(cell, a)) * 2 * childSize + childSize;
    for (int i = 0; i < 3; ++i) v[i][a] = t.v[i][a] - centre;
  }
  uint32_t alive = 0xFFu;
  auto axis = [&](int64_t ax, int64_t ay, int64_t az) {
    const int64_t p0 = ax * v[0][0] + ay * v[0][1] + az * v[0][2];
    const int64_t p1 = ax * v[1][0] + ay * v[1][1] + az * v[1][2];
    const int64_t p2 = ax * v[2][0] + ay * v[2][1] + az * v[2][2];
    const int64_t r = h * (detail::abs64(ax) + detail::abs64(ay) + detail::abs64(az));
    const int64_t lo = detail::min3(p0, p1, p2) - r, hi = detail::max3(p0, p1, p2) + r;
    const int64_t hx = h * ax, hy = h * ay, hz = h * az;
    for (int c = 0; c < 8; ++c) {
      const int64_t shift = ((c & 1) ? hx : -hx) + ((c & 2) ? hy : -hy) + ((c & 4) ? hz : -hz);
      if (lo > shift || hi < shift) alive &= ~(1u << c);
    }
  };
  // The cube's face normals (the bounding boxes), then the edge cross
  // products, as triangleOverlapsCube orders them.
  axis(1, 0, 0);
  axis(0, 1, 0);
  axis(0, 0, 1);
  for (int j = 0; j < 3 && alive; ++j) {
    const int k = j == 2 ? 0 : j + 1;
    const int64_t e[3] = {v[k][0] - v[j][0], v[k][1] - v[j][1], v[k][2] - v[j][2]};
    axis(0, -e[2], e[1]);
    axis(e[2], 0, -e[0]);
    axis(-e[1], e[0], 0);
  }
  if (!alive) return 0;
  // The plane: |n . (v0 - C)| <= h |n|_1, in 128 bits.
  int64_t n[3];
  triangleNormal(t, n);
  const int128_t d = int128_t(n[0]) * v[0][0] + int128_t(n[1]) * v[0][1] + int128_t(n[2]) * v[0][2];
  const int128_t r = int128_t(h) * (detail::abs64(n[0]) + detail::abs64(n[1]) + detail::abs64(n[2]));
  const int128_t hn[3] = {int128_t(h) * n[0], int128_t(h) * n[1], int128_t(h) * n[2]};
  for (int c = 0; c < 8; ++c) {
    const int128_t shift = ((c & 1) ? hn[0] : -hn[0]) + ((c & 2) ? hn[1] : -hn[1]) + ((c & 4) ? hn[2] : -hn[2]);
    if (d - r > shift || d + r < shift) alive &= ~(1u << c);
  }
  return alive;
}

// T1: calls emit(cell - firstCell) for every root cell of [firstCell,
// endCell) (x fastest, R cells an axis of edge `cellSize`) whose closed box
// the triangle meets: the cells of its bounding box, each confirmed by the
// exact test. Both drivers' T1 loop, for the whole grid or a range of it.
template <class Emit>
HDT_HD void forEachRootCell(const LatticeTriangle& t, int64_t cellSize, int64_t R, uint64_t firstCell,
                            uint64_t endCell, Emit&& emit) {
  int64_t lo[3], hi[3], first[3], last[3];
  triangleBounds(t, lo, hi);
  for (int k = 0; k < 3; ++k) cellRange(lo[k], hi[k], cellSize, R, first[k], last[k]);
  for (int64_t z = first[2]; z <= last[2]; ++z)
    for (int64_t y = first[1]; y <= last[1]; ++y) {
      const uint64_t rowBase = uint64_t(R * (y + R * z));
      if (rowBase + uint64_t(last[0]) < firstCell || rowBase + uint64_t(first[0]) >= endCell) continue;
      for (int64_t x = first[0]; x <= last[0]; ++x) {
        const uint64_t cell = rowBase + uint64_t(x);
        if (cell < firstCell || cell >= endCell) continue;
        if (triangleOverlapsElement(t, packCoord(uint32_t(x), uint32_t(y), uint32_t(z)), cellSize))
          emit(uint32_t(cell - firstCell));
      }
    }
}

namespace detail {
// ceil(a / b) and floor(a / b) for b > 0, from the estimate a * (1 / b) in
// double, corrected exactly with integer products. The estimate is within one
// of the quotient for the magnitudes here (|a| < 2^60, quotients < 2^42), so
// each loop runs its test once or twice; only the correction decides the
// result, so the estimate's rounding (host or device) cannot change it.
HDT_HD int64_t ceilDiv(int64_t a, int64_t b, double invB) {
  int64_t q = int64_t(double(a) * invB);
  while (q * b < a) ++q;
  while ((q - 1) * b >= a) --q;
  return q;
}
HDT_HD int64_t floorDiv(int64_t a, int64_t b, double invB) {
  int64_t q = int64_t(double(a) * invB);
  while (q * b > a) --q;
  while ((q + 1) * b <= a) ++q;
  return q;
}

// One separating axis as a constraint on a single integer unknown i (the
// other coordinates folded into B by the caller):  lo <= A i + B <= hi.
// The sign of A is folded into the bounds once, so that narrowing needs
// |A| and its reciprocal only.
struct LinearBound {
  int64_t absA;  // |A|
  int64_t lo, hi; // for A < 0 already negated and swapped: lo <= |A| i - B <= hi
  int64_t bSign;  // +1 or -1: the sign B is taken with
  double invA;    // 1 / |A| (0 when A == 0)
};

HDT_HD LinearBound makeLinearBound(int64_t A, int64_t lo, int64_t hi) {
  LinearBound b;
  if (A >= 0) {
    b.absA = A;
    b.lo = lo;
    b.hi = hi;
    b.bSign = 1;
  } else { // lo <= A i + B <= hi  <=>  -hi <= -A i - B <= -lo
    b.absA = -A;
    b.lo = -hi;
    b.hi = -lo;
    b.bSign = -1;
  }
  b.invA = b.absA == 0 ? 0.0 : 1.0 / double(b.absA);
  return b;
}

// Narrows [first, last] to the integers i that satisfy the bound for the
// given B; first > last when none do.
HDT_HD void narrowToBound(const LinearBound& b, int64_t B, int64_t& first, int64_t& last) {
  const int64_t sB = b.bSign * B;
  if (b.absA == 0) {
    if (sB < b.lo || sB > b.hi) last = first - 1;
    return;
  }
  const int64_t f = ceilDiv(b.lo - sB, b.absA, b.invA);
  const int64_t l = floorDiv(b.hi - sB, b.absA, b.invA);
  if (f > first) first = f;
  if (l < last) last = l;
}
} // namespace detail

// T3: the plane axis of triangleOverlapsCube for rows of unit voxels along
// x. The normal (up to 2^51) needs 128 bits: voxel i of row (y, z) meets the
// plane iff |Pa i + Pb| <= R with Pa = 256 n_x and Pb = b0 + n_y cy + n_z cz.
// The doubles only seed the search; the 128-bit test decides. Kept apart
// from the other axes because it is the one step taken per row.
struct PlaneClipper {
  int64_t n[3];
  int128_t b0, r;
  // Seed: the plane meets the row's axis at
  //   x = x0 + ky (cy - y0) + kz (cz - z0)  (voxel units),
  // and the voxels within halfWidth of that point meet the plane.
  double x0, ky, kz, halfWidth;
  int64_t y0, z0;
};

HDT_HD void makePlaneClipper(const LatticeTriangle& t, PlaneClipper& p) {
  const int64_t half = kLatticePerVoxel / 2;
  triangleNormal(t, p.n);
  p.r = int128_t(half) * (detail::abs64(p.n[0]) + detail::abs64(p.n[1]) + detail::abs64(p.n[2]));
  p.b0 = int128_t(p.n[0]) * (half - t.v[0][0]) - int128_t(p.n[1]) * t.v[0][1] - int128_t(p.n[2]) * t.v[0][2];
  // n.(c_i - v0) = 0 at i = (v0x - 128) / 256 - (n_y (cy - v0y) + n_z (cz - v0z)) / (256 n_x).
  const double Pa = double(p.n[0]) * double(kLatticePerVoxel);
  p.y0 = t.v[0][1];
  p.z0 = t.v[0][2];
  p.x0 = double(t.v[0][0] - half) / double(kLatticePerVoxel);
  p.ky = p.n[0] == 0 ? 0.0 : -double(p.n[1]) / Pa;
  p.kz = p.n[0] == 0 ? 0.0 : -double(p.n[2]) / Pa;
  p.halfWidth = p.n[0] == 0 ? 0.0 : double(p.r) / (Pa > 0 ? Pa : -Pa);
}

// T3: whole-row overlap queries for one triangle. For a row of unit voxels
// along x at (y, z), each of the 13 separating axes a of triangleOverlapsCube
// says: voxel i overlaps on a iff
//     min_k a.v_k - 128 |a|_1  <=  a.c_i  <=  max_k a.v_k + 128 |a|_1
// where the voxel centre c_i = (256 i + 128, 256 y + 128, 256 z + 128) is
// linear in i. So every axis admits an interval of i, and the voxels of the
// row that meet the (convex) triangle are the intersection of 13 intervals:
// no per-voxel test at all. The axes group by the coordinates they involve,
// and each group is evaluated where it changes:
//   box x, y, z           the triangle's voxel bounding box (cellRange)
//   e x X (3, no x part)  which rows of a slice z:     clipRowsOfSlice
//   e x Y (3, x and z)    one x span per slice z:      clipSliceSpan
//   e x Z (3, x and y)    one x span per row height y: clipColumnSpan
//   the plane (x, y, z)   per row:                     clipRowByPlane
// so a row costs one plane step, not 13 axes. The setup depends on the
// triangle only (makeRowClipper); clipRow composes all of it for one row.
// Every step narrows by intersecting with an interval that depends on the
// triangle and the slice or row alone, so narrowing commutes with clamping
// to a leaf: a driver may evaluate a slice once for the whole triangle and
// clamp the result to each leaf (sliceSpans, columnSpan).
struct RowClipper {
  // Axes without an x component (box y, box z, e x X), as bounds on y:
  // |ay| * 256 y  vs  B = 128 ay + az cz.
  detail::LinearBound rowBound[5];
  int64_t rowAy[5], rowAz[5];
  detail::LinearBound boxX;     // box x as a bound on i (B = 0)
  detail::LinearBound slice[3]; // e x Y: bound on i with B = az cz
  int64_t sliceAz[3];
  detail::LinearBound column[3]; // e x Z: bound on i with B = ay cy
  int64_t columnAy[3];
  PlaneClipper plane;
};

// The clipper is set up in independent parts, so that a driver can build
// only the parts a step needs (the CUDA driver's per-triangle tables): 0-4
// the row axes, 5 box x, 6-8 the slice axes, 9-11 the column axes, 12 the plane.
constexpr int kRowClipperParts = 13;

HDT_HD void makeRowClipperPart(const LatticeTriangle& t, int part, RowClipper& c) {
  const int64_t half = kLatticePerVoxel / 2;
  // The axis a = (ax, ay, az) as lo <= ax * 256 i + ay cy + az cz <= hi.
  auto axisBounds = [&](int64_t ax, int64_t ay, int64_t az, int64_t& lo, int64_t& hi) {
    const int64_t p0 = ax * t.v[0][0] + ay * t.v[0][1] + az * t.v[0][2];
    const int64_t p1 = ax * t.v[1][0] + ay * t.v[1][1] + az * t.v[1][2];
    const int64_t p2 = ax * t.v[2][0] + ay * t.v[2][1] + az * t.v[2][2];
    const int64_t r = half * (detail::abs64(ax) + detail::abs64(ay) + detail::abs64(az));
    lo = detail::min3(p0, p1, p2) - r - ax * half;
    hi = detail::max3(p0, p1, p2) + r - ax * half;
  };
  // Edge j runs from vertex j to vertex j + 1.
  auto edge = [&](int j, int a) {
    const int m = j == 2 ? 0 : j + 1;
    return int64_t(t.v[m][a]) - t.v[j][a];
  };
  int64_t lo, hi;
  if (part < 5) { // row axes, as bounds on y: ay * 256 y + (128 ay + az cz) in [lo, hi]
    const int64_t ay = part == 0 ? 1 : (part == 1 ? 0 : -edge(part - 2, 2));
    const int64_t az = part == 0 ? 0 : (part == 1 ? 1 : edge(part - 2, 1));
    axisBounds(0, ay, az, lo, hi);
    c.rowBound[part] = detail::makeLinearBound(ay * kLatticePerVoxel, lo, hi);
    c.rowAy[part] = ay;
    c.rowAz[part] = az;
  } else if (part == 5) {
    axisBounds(1, 0, 0, lo, hi);
    c.boxX = detail::makeLinearBound(kLatticePerVoxel, lo, hi);
  } else if (part < 9) { // e x Y
    const int j = part - 6;
    axisBounds(edge(j, 2), 0, -edge(j, 0), lo, hi);
    c.slice[j] = detail::makeLinearBound(edge(j, 2) * kLatticePerVoxel, lo, hi);
    c.sliceAz[j] = -edge(j, 0);
  } else if (part < 12) { // e x Z
    const int j = part - 9;
    axisBounds(-edge(j, 1), edge(j, 0), 0, lo, hi);
    c.column[j] = detail::makeLinearBound(-edge(j, 1) * kLatticePerVoxel, lo, hi);
    c.columnAy[j] = edge(j, 0);
  } else {
    makePlaneClipper(t, c.plane);
  }
}

HDT_HD void makeRowClipper(const LatticeTriangle& t, RowClipper& c) {
  for (int part = 0; part < kRowClipperParts; ++part) makeRowClipperPart(t, part, c);
}

// Narrows [first, last] (voxel y indices) to the rows of slice z whose yz
// square meets the triangle's yz shadow (the five axes without an x
// component), so that the x steps are only asked about rows that can hit.
HDT_HD void clipRowsOfSlice(const RowClipper& c, int64_t z, int64_t& first, int64_t& last) {
  const int64_t cz = latticeOfVoxelCentre(z);
  for (int k = 0; k < 5 && first <= last; ++k)
    detail::narrowToBound(c.rowBound[k], c.rowAy[k] * (kLatticePerVoxel / 2) + c.rowAz[k] * cz, first, last);
}

// Narrows [first, last] (voxel x indices) to the voxels that the three
// e x Y axes allow in slice z (they do not depend on y).
HDT_HD void clipSliceSpan(const RowClipper& c, int64_t z, int64_t& first, int64_t& last) {
  const int64_t cz = latticeOfVoxelCentre(z);
  for (int k = 0; k < 3 && first <= last; ++k) detail::narrowToBound(c.slice[k], c.sliceAz[k] * cz, first, last);
}

// Narrows [first, last] (voxel x indices) to the voxels that the three
// e x Z axes allow at row height y (they do not depend on z).
HDT_HD void clipColumnSpan(const RowClipper& c, int64_t y, int64_t& first, int64_t& last) {
  const int64_t cy = latticeOfVoxelCentre(y);
  for (int k = 0; k < 3 && first <= last; ++k)
    detail::narrowToBound(c.column[k], c.columnAy[k] * cy, first, last);
}

// Narrows [first, last] (voxel x indices) to the voxels of row (y, z) whose
// box meets the triangle's plane: |g(i)| <= R with g(i) = |Pa| i + s Pb
// increasing (s the sign of Pa). A double estimate of the interval seeds the
// two ends; each end is then settled exactly by stepping g by |Pa| in 128
// bits. The walk is correct from any seed inside [first, last]; a good seed
// only makes it short.
HDT_HD void clipRowByPlane(const PlaneClipper& c, int64_t y, int64_t z, int64_t& first, int64_t& last) {
  if (first > last) return;
  const int64_t cy = latticeOfVoxelCentre(y), cz = latticeOfVoxelCentre(z);
  const int128_t R = c.r;
  const int128_t Pb = c.b0 + int128_t(c.n[1]) * cy + int128_t(c.n[2]) * cz;
  if (c.n[0] == 0) {
    if (Pb < -R || Pb > R) last = first - 1;
    return;
  }
  const int64_t step = detail::abs64(c.n[0]) * kLatticePerVoxel; // < 2^59
  const int128_t sPb = c.n[0] > 0 ? Pb : -Pb;
  const double centre = c.x0 + c.ky * double(cy - c.y0) + c.kz * double(cz - c.z0);
  int64_t f = first, l = last;
  if (centre - c.halfWidth > double(first)) f = centre - c.halfWidth < double(last) ? int64_t(centre - c.halfWidth) : last;
  if (centre + c.halfWidth < double(last)) l = centre + c.halfWidth > double(first) ? int64_t(centre + c.halfWidth) : first;
  // f: the smallest i in [first, last] with g(i) >= -R.
  int128_t g = int128_t(step) * f + sPb;
  if (g >= -R) {
    while (f > first && g - step >= -R) {
      --f;
      g -= step;
    }
  } else {
    while (f < last && g < -R) {
      ++f;
      g += step;
    }
    if (g < -R) {
      last = first - 1;
      return;
    }
  }
  // l: the largest i in [first, last] with g(i) <= R.
  g = int128_t(step) * l + sPb;
  if (g <= R) {
    while (l < last && g + step <= R) {
      ++l;
      g += step;
    }
  } else {
    while (l > first && g > R) {
      --l;
      g -= step;
    }
    if (g > R) {
      last = first - 1;
      return;
    }
  }
  first = f;
  last = l; // f > l when the plane passes between two voxel centres' slabs
}

// Narrows [first, last] (voxel x indices) to the voxels of row (y, z) that
// meet the triangle: all 13 axes, composed from the steps above. The drivers
// call the steps separately to share the slice and column spans among rows.
HDT_HD void clipRow(const RowClipper& c, int64_t y, int64_t z, int64_t& first, int64_t& last) {
  int64_t y0 = y, y1 = y;
  clipRowsOfSlice(c, z, y0, y1);
  if (y0 > y1) {
    last = first - 1;
    return;
  }
  detail::narrowToBound(c.boxX, 0, first, last);
  clipSliceSpan(c, z, first, last);
  clipColumnSpan(c, y, first, last);
  clipRowByPlane(c.plane, y, z, first, last);
}

// T3 may run its rows along any axis. Permuting the coordinates maps the 13
// separating axes onto themselves, so rows along another axis find exactly
// the same voxels; rows along the axis where the triangle's normal is
// smallest are the fewest (the triangle's shadow across them is smallest)
// and the longest, so that is the axis each triangle uses. In the permuted
// frame coordinate k is the original coordinate (axis + k) mod 3: rows run
// along `axis`, row heights are rayAxisU(axis), slices rayAxisW(axis).
HDT_HD int rowAxisFor(const LatticeTriangle& t) {
  int64_t n[3];
  triangleNormal(t, n);
  const int64_t a0 = detail::abs64(n[0]), a1 = detail::abs64(n[1]), a2 = detail::abs64(n[2]);
  return a0 <= a1 && a0 <= a2 ? 0 : (a1 <= a2 ? 1 : 2);
}

HDT_HD LatticeTriangle permuteToRowAxis(const LatticeTriangle& t, int axis) {
  LatticeTriangle p;
  for (int i = 0; i < 3; ++i)
    for (int k = 0; k < 3; ++k) p.v[i][k] = t.v[i][(axis + k) % 3];
  return p;
}

// The leaf origin v0 in the frame of row axis `axis` (permuteToRowAxis).
HDT_HD void permutedOrigin(const int64_t (&v0)[3], int axis, int64_t (&o)[3]) {
  for (int k = 0; k < 3; ++k) o[k] = v0[(axis + k) % 3];
}

// T3: the triangle's voxel box on a grid of `resolution` voxels an axis
// (the box axes, by cellRange). Empty along an axis when first > last.
HDT_HD void triangleVoxelBox(const LatticeTriangle& t, int64_t resolution, int64_t (&first)[3], int64_t (&last)[3]) {
  int64_t lo[3], hi[3];
  triangleBounds(t, lo, hi);
  for (int a = 0; a < 3; ++a) cellRange(lo[a], hi[a], kLatticePerVoxel, resolution, first[a], last[a]);
}

// T3: the voxels of the triangle's voxel box inside the leaf of L voxels an
// axis at v0. Empty along an axis when first > last.
HDT_HD void leafVoxelRanges(const LatticeTriangle& t, const int64_t (&v0)[3], int L, int64_t resolution,
                            int64_t (&first)[3], int64_t (&last)[3]) {
  triangleVoxelBox(t, resolution, first, last);
  for (int a = 0; a < 3; ++a) {
    if (first[a] < v0[a]) first[a] = v0[a];
    if (last[a] > v0[a] + L - 1) last[a] = v0[a] + L - 1;
  }
}

// T3 per slice z of the box [first, last]: the rows [y0, y1] that can meet
// the triangle and the slice's x span [x0, x1] (none when y0 > y1 or
// x0 > x1). The box may be the triangle's part in one leaf (the CPU driver)
// or its whole voxel box, evaluated once and clamped to each leaf (the CUDA
// driver): narrowing commutes with clamping, so both give the same voxels.
HDT_HD void sliceSpans(const RowClipper& c, const int64_t (&first)[3], const int64_t (&last)[3], int64_t z,
                       int64_t& y0, int64_t& y1, int64_t& x0, int64_t& x1) {
  y0 = first[1];
  y1 = last[1];
  clipRowsOfSlice(c, z, y0, y1);
  x0 = first[0];
  x1 = last[0];
  if (y0 <= y1) clipSliceSpan(c, z, x0, x1);
}

// T3 per row height y of the box: the x span the e x Z axes allow (as
// sliceSpans, evaluated on a leaf part or on the whole box).
HDT_HD void columnSpan(const RowClipper& c, const int64_t (&first)[3], const int64_t (&last)[3], int64_t y,
                       int64_t& x0, int64_t& x1) {
  x0 = first[0];
  x1 = last[0];
  clipColumnSpan(c, y, x0, x1);
}

// Mask of the L voxels of a leaf row (L <= 32): bits 0 .. L - 1.
HDT_HD constexpr uint32_t fullRowMask(int L) { return L == 32 ? 0xFFFFFFFFu : ((1u << L) - 1u); }

// Where a permuted row's voxels land in the leaf's x rows, as runs: calls
// set(rowIndex, lo, hi) once per x row touched (index y + L z), with the
// voxels [lo, hi] of that x row (lo == hi but for axis 0). The row is at
// (h, s) = (row height, slice), leaf-relative, and its voxels are the run
// [first, last] along `axis` (leaf-relative; none when first > last). A run
// along y or z sets one voxel in each of consecutive x rows, so it is
// walked as a run, not bit by bit.
template <class Set>
HDT_HD void forEachXRowRunOf(int axis, int L, int h, int s, int first, int last, Set&& set) {
  if (first > last) return;
  if (axis == 0) { // (x, y, z) = (i, h, s)
    set(h + L * s, first, last);
  } else if (axis == 1) { // (x, y, z) = (s, i, h): x rows i + L h, voxel s
    for (int i = first; i <= last; ++i) set(i + L * h, s, s);
  } else { // axis 2: (x, y, z) = (h, s, i): x rows s + L i, voxel h
    for (int i = first; i <= last; ++i) set(s + L * i, h, h);
  }
}

// The same with each x row's voxels as one L-bit mask: set(rowIndex, mask).
template <class Set>
HDT_HD void forEachXRowOf(int axis, int L, int h, int s, int first, int last, Set&& set) {
  forEachXRowRunOf(axis, L, h, s, first, last,
                   [&](int row, int lo, int hi) { set(row, fullRowMask(hi + 1) & ~fullRowMask(lo)); });
}

// Classification: the rays along `axis` through the voxel centres of the
// line at voxel coordinate w (along rayAxisW) that pass through the triangle,
// as voxel coordinates u (along rayAxisU): narrows [first, last], exactly the
// u for which rayHitsTriangle is true. For fixed w each edge's perturbed
// orientation is a linear function of u, so each edge admits a half-line of
// u and the hits are their intersection: three exact divisions per line
// instead of three orientations per ray. A ray hits when all three signs
// equal the projected triangle's orientation (the three orientations sum to
// it, so the other sign class is empty, and a triangle whose projection has
// no area is never hit).
//
// What does not depend on w (the edges and their reciprocals) is set up once
// per triangle (makeRaySpanSetup), so that a driver evaluating many lines of
// one triangle (the CUDA driver's line table) does not redo it per line.
struct RaySpanSetup {
  bool hits;     // the projection has area (no ray hits otherwise)
  bool positive; // its orientation
  int64_t au[3], aw[3], du[3], dw[3]; // edge j: start vertex and direction in (U, W)
  double inv[3]; // 1 / |A| of edge j (A = -256 dw; 0 when A == 0)
};

HDT_HD void makeRaySpanSetup(const LatticeTriangle& t, int axis, RaySpanSetup& s) {
  const int U = rayAxisU(axis), W = rayAxisW(axis);
  const int64_t area = (int64_t(t.v[1][U]) - t.v[0][U]) * (int64_t(t.v[2][W]) - t.v[0][W]) -
                       (int64_t(t.v[1][W]) - t.v[0][W]) * (int64_t(t.v[2][U]) - t.v[0][U]);
  s.hits = area != 0;
  s.positive = area > 0;
  for (int j = 0; j < 3; ++j) {
    const int k = j == 2 ? 0 : j + 1;
    s.au[j] = t.v[j][U];
    s.aw[j] = t.v[j][W];
    s.du[j] = t.v[k][U] - s.au[j];
    s.dw[j] = t.v[k][W] - s.aw[j];
    const int64_t absA = (s.dw[j] < 0 ? -s.dw[j] : s.dw[j]) * kLatticePerVoxel;
    s.inv[j] = absA == 0 ? 0.0 : 1.0 / double(absA);
  }
}

HDT_HD void raySpanAtW(const RaySpanSetup& s, int64_t w, int64_t& first, int64_t& last) {
  if (!s.hits) {
    last = first - 1;
    return;
  }
  const bool positive = s.positive;
  const int64_t pw = latticeOfVoxelCentre(w), half = kLatticePerVoxel / 2;
  for (int j = 0; j < 3 && first <= last; ++j) {
    const int64_t au = s.au[j], aw = s.aw[j];
    const int64_t du = s.du[j], dw = s.dw[j];
    // orientPerturbed(a, b, p) with pu = 256 u + 128: o(u) = A u + B; on a
    // tie (o = 0) its sign is that of -dw, or of du when dw = 0.
    const int64_t A = -dw * kLatticePerVoxel;
    const int64_t B = du * (pw - aw) - dw * (half - au);
    if (A == 0) {
      const int sign = B != 0 ? (B > 0 ? 1 : -1) : (du > 0 ? 1 : (du < 0 ? -1 : 0));
      if (sign != (positive ? 1 : -1)) last = first - 1;
      continue;
    }
    const int64_t absA = A > 0 ? A : -A;
    const double inv = s.inv[j];
    if (A > 0) {
      if (positive) { // o >= 0 (ties count as +): u >= ceil(-B / A)
        const int64_t f = detail::ceilDiv(-B, absA, inv);
        if (f > first) first = f;
      } else { // o <= -1: u <= floor((-1 - B) / A)
        const int64_t l = detail::floorDiv(-1 - B, absA, inv);
        if (l < last) last = l;
      }
    } else {
      if (positive) { // o >= 1: |A| u <= B - 1
        const int64_t l = detail::floorDiv(B - 1, absA, inv);
        if (l < last) last = l;
      } else { // o <= 0 (ties count as -): |A| u >= B
        const int64_t f = detail::ceilDiv(B, absA, inv);
        if (f > first) first = f;
      }
    }
  }
}

HDT_HD void raySpanAtW(const LatticeTriangle& t, int axis, int64_t w, int64_t& first, int64_t& last) {
  RaySpanSetup s;
  makeRaySpanSetup(t, axis, s);
  raySpanAtW(s, w, first, last);
}

// For a ray that hits the triangle (raySpanAtW, rayHitsTriangle): if the
// crossing lies inside the leaf's half-open extent [a0, a0 + L) along `axis`,
// returns true and sets `before` to the number of the row's voxel centres
// strictly before it (each of them sees one more crossing ahead of it).
// The reference form, one ray at a time; the drivers use LeafCrossings.
HDT_HD bool crossingInLeaf(const LatticeTriangle& t, int axis, int64_t u, int64_t w, int64_t a0, int L, int& before) {
  const Crossing c = rayCrossing(t, axis, latticeOfVoxelCentre(u), latticeOfVoxelCentre(w));
  const int64_t lo = latticeOfVoxel(a0);
  if (!crossingWithin(c, lo, lo + int64_t(L) * kLatticePerVoxel)) return false;
  before = pointsBeforeCrossing(c, latticeOfVoxelCentre(a0), kLatticePerVoxel, L);
  return true;
}

// The row's voxels strictly before a crossing, as a mask: the ones that see
// that crossing ahead of them.
HDT_HD constexpr uint32_t maskBeforeCrossing(int before) {
  return before >= 32 ? 0xFFFFFFFFu : ((1u << before) - 1u);
}

// The same answer for all rays of one leaf and triangle, set up once per
// (leaf, triangle) pair. With den = |n_axis| and the crossing at num / den
// (rayCrossing), t = num - den * (leaf start) is an affine function of the
// ray's leaf-relative (du, dw), and for a crossing inside the leaf
// 0 <= t < 256 L den < 2^64 (|n| < 2^51, L <= 32): the per-ray work is two
// products and unsigned 64-bit arithmetic, with no division but a double
// estimate that an exact product check settles.
struct LeafCrossings {
  int128_t t00;       // t at the leaf's first ray (du = dw = 0)
  // For a ray that hits the triangle the crossing lies within the
  // triangle's extent along the axis, so |t| <= den * (that extent's
  // farthest point from the leaf start). When that bound is below 2^62, t
  // of every hit ray fits 64 bits and is computed in 64-bit wrapping
  // arithmetic from t00's low bits: exact, and no 128-bit product a ray.
  bool narrow;
  int64_t stepU;      // t(du + 1) - t(du), < 2^59 in magnitude
  int64_t stepW;      // t(dw + 1) - t(dw)
  uint64_t den;       // |n_axis| > 0
  uint64_t perVoxel;  // 256 den
  uint64_t extent;    // 256 L den
  double invPerVoxel; // 1 / perVoxel, for the estimate
  double invStepU;    // 1 / stepU (0 when stepU is), for narrowToLeafCrossings
};

// What LeafCrossings takes from the triangle alone (per triangle and axis),
// so that a driver can set it up once per triangle: with s the sign of
// n_axis, t at the leaf's first ray is
//   s (n . v_0) - s n_U pu0 - s n_W pw0 - den * (leaf start)
// (rayCrossing's numerator, shifted to the leaf; exact in 128 bits).
struct RayCrossingSetup {
  int128_t sDot;      // s (n . v_0)
  int64_t snU, snW;   // s n_U, s n_W
  uint64_t den;       // |n_axis|
  double invPerVoxel; // 1 / (256 den)
  int64_t lo, hi;     // the triangle's lattice extent along the axis
};

HDT_HD void makeRayCrossingSetup(const LatticeTriangle& t, int axis, RayCrossingSetup& r) {
  const int U = rayAxisU(axis), W = rayAxisW(axis);
  int64_t n[3];
  triangleNormal(t, n);
  const int64_t s = n[axis] < 0 ? -1 : 1;
  r.sDot = (int128_t(n[axis]) * t.v[0][axis] + int128_t(n[U]) * t.v[0][U] + int128_t(n[W]) * t.v[0][W]) * s;
  r.snU = s * n[U];
  r.snW = s * n[W];
  r.den = uint64_t(s * n[axis]);
  r.invPerVoxel = r.den == 0 ? 0.0 : 1.0 / double(r.den * uint64_t(kLatticePerVoxel));
  r.lo = detail::min3(t.v[0][axis], t.v[1][axis], t.v[2][axis]);
  r.hi = detail::max3(t.v[0][axis], t.v[1][axis], t.v[2][axis]);
}

// v0: the leaf's first voxel; only for triangles whose projection along
// `axis` has area (raySpanAtW finds no hit otherwise).
HDT_HD void makeLeafCrossings(const RayCrossingSetup& r, int axis, const int64_t (&v0)[3], int L, LeafCrossings& c) {
  const int U = rayAxisU(axis), W = rayAxisW(axis);
  const int64_t pu0 = latticeOfVoxelCentre(v0[U]), pw0 = latticeOfVoxelCentre(v0[W]);
  c.den = r.den;
  c.t00 = r.sDot - int128_t(r.snU) * pu0 - int128_t(r.snW) * pw0 -
          int128_t(latticeOfVoxel(v0[axis])) * int128_t(r.den);
  c.stepU = -r.snU * kLatticePerVoxel;
  c.stepW = -r.snW * kLatticePerVoxel;
  c.perVoxel = r.den * uint64_t(kLatticePerVoxel);
  c.extent = c.perVoxel * uint64_t(L);
  c.invPerVoxel = r.invPerVoxel;
  c.invStepU = c.stepU == 0 ? 0.0 : 1.0 / double(c.stepU);
  // |t| <= den * e for hit rays; den < 2^51 and e < 2^25, so the product is
  // taken in double, with a factor 2 of margin for its rounding.
  const int64_t a = latticeOfVoxel(v0[axis]);
  const int64_t e = detail::abs64(r.hi - a) > detail::abs64(r.lo - a) ? detail::abs64(r.hi - a) : detail::abs64(r.lo - a);
  c.narrow = double(r.den) * double(e) < 4611686018427387904.0; // 2^62
}

HDT_HD void makeLeafCrossings(const LatticeTriangle& t, int axis, const int64_t (&v0)[3], int L, LeafCrossings& c) {
  RayCrossingSetup r;
  makeRayCrossingSetup(t, axis, r);
  makeLeafCrossings(r, axis, v0, L, c);
}

// t of the ray at leaf-relative (du, dw) of narrow LeafCrossings, in
// wrapping 64-bit arithmetic: exact for every ray that hits the triangle
// (|t| < 2^62, so the low 64 bits are t in two's complement).
HDT_HD int64_t narrowCrossingT(const LeafCrossings& c, int du, int dw) {
  return int64_t(uint64_t(c.t00) + uint64_t(c.stepU) * uint64_t(int64_t(du)) +
                 uint64_t(c.stepW) * uint64_t(int64_t(dw)));
}

// crossingInLeaf for the ray at leaf-relative (du, dw) of a LeafCrossings.
HDT_HD bool crossingInLeaf(const LeafCrossings& c, int du, int dw, int L, int& before) {
  uint64_t tt;
  if (c.narrow) {
    const int64_t t = narrowCrossingT(c, du, dw);
    if (t < 0 || uint64_t(t) >= c.extent) return false;
    tt = uint64_t(t);
  } else {
    const int128_t t = c.t00 + int128_t(c.stepU) * du + int128_t(c.stepW) * dw;
    if (t < 0 || t >= int128_t(c.extent)) return false;
    tt = uint64_t(t);
  }
  const uint64_t half = c.den * uint64_t(kLatticePerVoxel / 2);
  if (tt <= half) { // no centre before the crossing
    before = 0;
    return true;
  }
  // before = ceil(m / perVoxel) with m = t - 128 den > 0; k * perVoxel < 2^64 for k <= L.
  const uint64_t m = tt - half;
  const double q = double(m) * c.invPerVoxel;
  int k = q < 1.0 ? 1 : (q > double(L) ? L : int(q));
  while (k > 1 && uint64_t(k - 1) * c.perVoxel >= m) --k;
  while (k < L && uint64_t(k) * c.perVoxel < m) ++k;
  before = k;
  return true;
}

// The hit rays [first, last] of ray line dw (leaf-relative u) narrowed to a
// span that still holds every ray whose crossing lies in the leaf. Along a
// line t is affine in u, so those rays form an interval; its ends are
// estimated in double and widened past the estimate's error bound, and
// crossingInLeaf still decides each ray exactly, so the result cannot
// change. A triangle that spans several leaves along the ray axis is hit by
// the same rays in each of them; without this each leaf would visit them all
// (about half the rays T3 visited on the CAD parts crossed elsewhere). Only
// narrow LeafCrossings are narrowed (t of every hit ray fits 64 bits).
HDT_HD void narrowToLeafCrossings(const LeafCrossings& c, int dw, int& first, int& last) {
  if (!c.narrow || first > last) return;
  const int64_t tf = narrowCrossingT(c, first, dw); // ray `first` hits the triangle: exact
  if (c.stepU == 0) { // the same t for the whole line
    if (tf < 0 || uint64_t(tf) >= c.extent) last = first - 1;
    return;
  }
  // t(first + d) = tf + stepU d is in [0, extent) for d between a and b.
  const double inv = c.invStepU, t = double(tf), e = double(c.extent);
  double a = -t * inv, b = (e - t) * inv;
  if (a > b) {
    const double x = a;
    a = b;
    b = x;
  }
  // Rounding: the conversions, the difference, the reciprocal and the
  // product, each 2^-53 relative; below 2^-50 relative to (|t| + e) / |s|
  // together. Plus one for the ends.
  const double err = ((t < 0 ? -t : t) + e) * 0x1p-50 * (inv < 0 ? -inv : inv) * (1.0 + 0x1p-50) + 1.0;
  a -= err;
  b += err;
  const int n = last - first;
  if (b < 0.0 || a > double(n)) {
    last = first - 1; // no ray of the span crosses in the leaf
    return;
  }
  const int lo = a <= 0.0 ? 0 : int(a);           // floor(a)
  const int hi = b >= double(n) ? n : int(b) + 1; // at least ceil(b)
  last = first + hi;
  first += lo;
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

// ---- classification pass 1 (docs/design.md, "Classification") ---------------
// The crossings of one (leaf, triangle) pair with the leaf's rays along
// `axis`, in the three steps both drivers follow (the CPU in one loop,
// forEachPairCrossing; the CUDA kernels one warp-wide step each):
//   1. pairRayRange: the rays whose centre line can meet the triangle;
//   2. leafLineRays: per ray line w, the rays that hit and can cross in the leaf;
//   3. crossingInLeaf: per such ray, the exact crossing (row, before).

// Step 1: the triangle's ray ranges [u0, u1] x [w0, w1] (voxel coordinates)
// within the leaf at v0; false when empty.
HDT_HD bool pairRayRange(const LatticeTriangle& t, int axis, const int64_t (&v0)[3], int L, int64_t& u0, int64_t& u1,
                         int64_t& w0, int64_t& w1) {
  int64_t lo[3], hi[3];
  triangleBounds(t, lo, hi);
  centreRange(lo[rayAxisU(axis)], hi[rayAxisU(axis)], v0[rayAxisU(axis)], L, u0, u1);
  centreRange(lo[rayAxisW(axis)], hi[rayAxisW(axis)], v0[rayAxisW(axis)], L, w0, w1);
  return u0 <= u1 && w0 <= w1;
}

// Step 2 from a span of hit rays [uf, ul] of line w (voxel coordinates, from
// raySpanAtW or a table of its results): the leaf-relative rays [f, l] whose
// crossing can lie in the leaf (narrowToLeafCrossings).
HDT_HD void leafLineRays(const LeafCrossings& c, const int64_t (&v0)[3], int axis, int64_t w, int64_t uf, int64_t ul,
                         int& f, int& l) {
  f = int(uf - v0[rayAxisU(axis)]);
  l = int(ul - v0[rayAxisU(axis)]);
  narrowToLeafCrossings(c, int(w - v0[rayAxisW(axis)]), f, l);
}

// Steps 2 and 3 for one ray line w of a pair whose step 1 gave [u0, u1]:
// fn(row, before) for every ray of the line that crosses the triangle in the
// leaf (row = du + L dw). `crossings` is set up on the line's first hit
// (`made`: whether it already is), so a pair's lines share it.
template <class Fn>
HDT_HD void forEachLineCrossing(const LatticeTriangle& t, int axis, const int64_t (&v0)[3], int L, int64_t w,
                                int64_t u0, int64_t u1, LeafCrossings& crossings, bool& made, Fn&& fn) {
  int64_t uf = u0, ul = u1;
  raySpanAtW(t, axis, w, uf, ul);
  if (uf > ul) return;
  if (!made) {
    makeLeafCrossings(t, axis, v0, L, crossings);
    made = true;
  }
  int f, l;
  leafLineRays(crossings, v0, axis, w, uf, ul, f, l);
  const int dw = int(w - v0[rayAxisW(axis)]);
  for (int du = f; du <= l; ++du) {
    int before;
    if (crossingInLeaf(crossings, du, dw, L, before)) fn(du + L * dw, before);
  }
}

// All three steps for one pair, one ray at a time: fn(row, before) for every
// ray of the leaf (row = du + L dw) that crosses the triangle inside it.
template <class Fn>
HDT_HD void forEachPairCrossing(const LatticeTriangle& t, int axis, const int64_t (&v0)[3], int L, Fn&& fn) {
  int64_t u0, u1, w0, w1;
  if (!pairRayRange(t, axis, v0, L, u0, u1, w0, w1)) return;
  LeafCrossings crossings{};
  bool made = false; // set up on the first hit: many pairs have none
  for (int64_t w = w0; w <= w1; ++w) forEachLineCrossing(t, axis, v0, L, w, u0, u1, crossings, made, fn);
}

// Writes a row of L voxel bits (bit i = voxel i) into leaf words as the given
// plane.
HDT_HD void orRowIntoLeaf(uint32_t* words, int L, int row, uint32_t mask, LeafPlane plane) {
  const uint32_t v = uint32_t(row) * uint32_t(L); // first voxel of the row
  for (int k = 0; k < L; k += 16) {
    const uint32_t bits = (L == 8) ? (mask & 0xFFu) : ((mask >> k) & 0xFFFFu);
    const uint32_t voxel = v + uint32_t(k);
    words[voxel >> 4] |= (spreadBits16(bits) << plane) << (2 * (voxel & 15u));
  }
}

// Plane 0 of the 2-bit fields [lo, hi] of one leaf word (0 <= lo <= hi <=
// 15); shifted left by one, plane 1. A run of voxels written straight into
// leaf words, without spreading a row mask.
HDT_HD constexpr uint32_t fieldRangeBits(int lo, int hi) {
  return ((2u << (2 * hi)) - (1u << (2 * lo))) & kInsidePlaneBits; // bits 2 lo .. 2 hi + 1
}

// In-place transpose of an L x L bit matrix (L = 8, 16 or 32): afterwards
// bit r of a[c] is what bit c of a[r] was. Quadrants swap, then their
// quadrants, and so on: log2(L) steps of L / 2 masked swaps.
template <int L>
HDT_HD void transposeBits(uint32_t (&a)[L]) {
#if defined(__CUDA_ARCH__)
#pragma unroll
#endif
  for (int j = L / 2; j >= 1; j >>= 1) {
    uint32_t m = 0; // the bits b with (b & j) == 0
    for (int b = 0; b < L; ++b)
      if ((b & j) == 0) m |= 1u << b;
#if defined(__CUDA_ARCH__)
#pragma unroll
#endif
    for (int k = 0; k < L; ++k) {
      if (k & j) continue;
      const uint32_t t = ((a[k] >> j) ^ a[k + j]) & m;
      a[k] ^= t << j;
      a[k + j] ^= t;
    }
  }
}

// Classification of open meshes votes per voxel over three axes, but the
// leaf's words hold x rows. Axis a's rows are indexed u + L w with (u, w)
// the cyclic other axes: y rows (axis 1) are z + L x with bit y, z rows
// (axis 2) are x + L y with bit z. Matrix i of axis 1 (slice z = i: its y
// rows indexed by x) transposed holds the x rows (y, i); matrix i of axis 2
// (height y = i: its z rows indexed by x) transposed holds the x rows (i, z).
// Writes those L x rows into xRows (index y + L z).
template <int L>
HDT_HD void xRowsOfAxisMatrix(int axis, int i, const uint32_t* rows, uint32_t* xRows) {
  uint32_t a[L];
  for (int x = 0; x < L; ++x) a[x] = rows[axis == 1 ? i + L * x : x + L * i];
  transposeBits<L>(a);
  for (int k = 0; k < L; ++k) xRows[axis == 1 ? k + L * i : i + L * k] = a[k];
}

// ---- leaf words and row masks ------------------------------------------------
// Leaf layout (types.hpp): voxel v = x + L (y + L z) is 2-bit field v % 16 of
// word v / 16, so a word holds 16 voxels of one row (L = 16), half a row
// (L = 32) or two rows (L = 8). `rows` holds one L-bit mask per row (y + L z).

// The 16 voxel bits of word w, voxel order.
HDT_HD uint32_t wordBitsFromRows(const uint32_t* rows, int L, int w) {
  if (L == 16) return rows[w] & 0xFFFFu;
  if (L == 8) return (rows[2 * w] & 0xFFu) | ((rows[2 * w + 1] & 0xFFu) << 8);
  return (rows[w >> 1] >> ((w & 1) * 16)) & 0xFFFFu; // L == 32
}

// One bit per row (rowBits[r / 32] bit r % 32) widened to the 16 voxel bits
// of word w: every voxel of a row gets the row's bit.
HDT_HD uint32_t rowBitsToWordBits(const uint32_t* rowBits, int L, int w) {
  auto bit = [rowBits](int r) { return (rowBits[r >> 5] >> (r & 31)) & 1u; };
  if (L == 16) return bit(w) ? 0xFFFFu : 0u;
  if (L == 8) return (bit(2 * w) ? 0x00FFu : 0u) | (bit(2 * w + 1) ? 0xFF00u : 0u);
  return bit(w >> 1) ? 0xFFFFu : 0u; // L == 32
}

// The 16 voxel bits of one plane of a leaf word (inverse of spreadBits16).
HDT_HD uint32_t planeBits16(uint32_t word, LeafPlane plane) {
  uint32_t m = planeOf(word, plane);
  m = (m | (m >> 1)) & 0x33333333u;
  m = (m | (m >> 2)) & 0x0F0F0F0Fu;
  m = (m | (m >> 4)) & 0x00FF00FFu;
  return (m | (m >> 8)) & 0x0000FFFFu;
}

// A leaf word with plane 0 set to `inside` (16 voxel bits) wherever the
// voxel is not surface (plane 1): the last step of classification.
HDT_HD uint32_t withInsidePlane(uint32_t word, uint32_t inside) {
  return (word & kSurfacePlaneBits) | (spreadBits16(inside) & ~planeOf(word, kSurfacePlane));
}

// Plane 0 cleared where plane 1 is set: a word whose inside plane was written
// without regard to the surface (the parts of a split leaf, merged).
HDT_HD uint32_t withoutInsideUnderSurface(uint32_t word) { return word & ~planeOf(word, kSurfacePlane); }

// The majority of three bit sets (open meshes: the +x, +y and +z answers).
HDT_HD constexpr uint32_t majorityOf3(uint32_t a, uint32_t b, uint32_t c) { return (a & b) | (a & c) | (b & c); }

} // namespace hdt
