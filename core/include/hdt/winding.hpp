// The generalized winding number inside test (Jacobson et al. 2013), shared
// by the CPU and CUDA drivers (docs/design.md, "Winding number").
//
// w(p) = sum over triangles of the signed solid angle / 4 pi; a voxel centre
// is inside when w >= 1/2. Coordinates are voxel units (lattice / 256, exact
// doubles). A tree over the triangles (WindingTree, built on the host in
// winding_tree_build.cpp, the same tree for both drivers) gives the sum over a box of
// points as an estimate plus a rigorous error bound; a decision is taken from
// the estimate only where the bound keeps w clear of 1/2, otherwise the box is
// split, and a single point falls back to the exact sum over every triangle
// in a fixed order. Only + - * / and sqrt are used (correctly rounded on both
// sides, no contraction: -ffp-contract=off, nvcc --fmad=false), atan2 is our
// own, so the host and the device compute the same bits.
#pragma once

#include "hdt/platform.hpp"
#include "hdt/winding_basics.hpp"
#include "hdt/winding_crossings.hpp"

#include <cmath>
#include <cstdint>

namespace hdt {

// Distance between two boxes (0 when they meet).
HDT_HD double windingBoxDistance(const double* alo, const double* ahi, const double* blo, const double* bhi) {
  double s = 0;
  for (int a = 0; a < 3; ++a) {
    const double gap = alo[a] > bhi[a] ? alo[a] - bhi[a] : (blo[a] > ahi[a] ? blo[a] - ahi[a] : 0.0);
    s = s + gap * gap;
  }
  return sqrt(s);
}

// The sum of solid angles over a box of points [lo, hi] (a single point when
// lo == hi), refined until it decides w >= 1/2 for every point of the box.
//
// Bounds (exact real arithmetic; rounding is covered by windingMargin): a
// node at positive distance from the box may count as the first two terms of
// the Taylor expansion of the solid-angle kernel K(x) = n . (x - c) / |x - c|^3
// about the node's centre (a dipole and a quadrupole term, winding_tree_build.cpp). The
// kernel's second derivatives are at most 6 / dist^4 (those of 1 / r: k! /
// r^(k+1)), so that is off by at most 3 A r^2 / (d - r)^4 at c (r: the node's
// radius, d: centre to c, A: its area); its gradient in c is at most 2 /
// dist^3, so the node's exact sum varies by at most 2 A rho / dist^3 across
// the box (rho: the box's half diagonal). Triangles are summed exactly at c and add
// 2 A rho / dist^3; a triangle meeting the box makes it undecidable as a
// whole (the caller splits it).
//
// The refinement keeps up to kWindingOpen approximated nodes and opens the
// one with the largest error (the first in the list on a tie) until the
// estimate is clear of 2 pi by more than the total error, or nothing is left
// to open, or `maxOpen` nodes were opened. The order of every step is fixed.
// (WindingSum, in winding_basics.hpp: the estimate, its error bound, ok.)

constexpr int kWindingOpen = 1024;

// A second bound on |exact(p) - estimate(c)| for every p of the box, one
// that keeps the cancellation of the node's normals (a closed cluster's
// dipole is small): exact(p) = T(p) + E(p), T the expansion, |E(p)| <=
// 3 A r^2 / (dm - r)^4 (dm: the node's centre to the box), and
// |T(p) - T(c)| <= rho max |grad T|, where grad of the dipole term is at most
// 2 |D| / dm^3 (the Hessian of 1 / r) and that of the quadrupole term
// -Q : Hess(1 / r) at most |Q|_F 6 sqrt(3) / dm^4 (third derivatives of 1 / r
// are at most 3! / r^4 in any directions, Frobenius <= sqrt(3) spectral;
// 11 > 6 sqrt 3). Infinite when the node's sphere reaches the box.
HDT_HD double windingBoxExpansionError(const WindingNode& n, const double* lo, const double* hi, double rho) {
  double s = 0;
  for (int a = 0; a < 3; ++a) {
    const double g = n.centre[a] < lo[a] ? lo[a] - n.centre[a] : (n.centre[a] > hi[a] ? n.centre[a] - hi[a] : 0.0);
    s = s + g * g;
  }
  const double dm = sqrt(s);
  if (!(dm > n.radius)) return INFINITY;
  const double gap = dm - n.radius;
  const double dipole = sqrt(n.dipole[0] * n.dipole[0] + n.dipole[1] * n.dipole[1] + n.dipole[2] * n.dipole[2]);
  double q2 = 0;
  for (int k = 0; k < 9; ++k) q2 = q2 + n.quad[k] * n.quad[k];
  const double dm3 = dm * dm * dm;
  return 2.0 * dipole * rho / dm3 + 11.0 * sqrt(q2) * rho / (dm3 * dm) +
         3.0 * n.area * n.radius * n.radius / ((gap * gap) * (gap * gap));
}

// The dipole and quadrupole terms of node n's expansion at point p; d is set to
// the distance from p to the node's centre (its error bounds need it).
HDT_HD double windingNodeExpansion(const WindingNode& n, const double* p, double& d) {
  const double dx = n.centre[0] - p[0], dy = n.centre[1] - p[1], dz = n.centre[2] - p[2];
  d = sqrt(dx * dx + dy * dy + dz * dz);
  const double d3 = d * d * d;
  const double ux = dx / d, uy = dy / d, uz = dz / d;
  const double* q = n.quad;
  const double uqu = ux * (q[0] * ux + q[1] * uy + q[2] * uz) + uy * (q[3] * ux + q[4] * uy + q[5] * uz) +
                     uz * (q[6] * ux + q[7] * uy + q[8] * uz);
  return (n.dipole[0] * dx + n.dipole[1] * dy + n.dipole[2] * dz) / d3 + ((q[0] + q[4] + q[8]) - 3.0 * uqu) / d3;
}

// Distance-dependent dipole estimate and error of node n; false when the
// node meets the box (it must be opened).
HDT_HD bool windingNodeFarField(const WindingNode& n, const double* lo, const double* hi, const double* c, double rho,
                                double& estimate, double& error) {
  const double dist = windingBoxDistance(n.lo, n.hi, lo, hi);
  if (!(dist > 0)) return false;
  double d = 0;
  estimate = windingNodeExpansion(n, c, d);
  const double gap = d - n.radius > dist ? d - n.radius : dist;
  error = 3.0 * n.area * n.radius * n.radius / ((gap * gap) * (gap * gap));
  if (rho > 0) {
    error = error + 2.0 * n.area * rho / (dist * dist * dist);
    const double cancelling = windingBoxExpansionError(n, lo, hi, rho);
    if (cancelling < error) error = cancelling;
  }
  return true;
}

// Rounding allowance (steradians) of a sum over n triangles: each solid angle
// is good to a few ulps of 2 pi away from its triangle (voxel centres that
// are not surface are at least half a voxel from every triangle).
HDT_HD double windingMargin(uint32_t n) { return 4.0 * kWindingPi * (1e-9 + 1e-14 * double(n)); }

enum WindingVerdict : int { kWindingOutside = 0, kWindingInside = 1, kWindingUnsure = 2 };

// Inside (w >= 1/2), outside, or unsure from a bounded sum.
HDT_HD int windingVerdict(const WindingSum& s, uint32_t n) {
  if (!s.ok) return kWindingUnsure;
  const double e = s.error * 1.001 + windingMargin(n); // the bound's own rounding, generously
  if (s.sum - e >= 2.0 * kWindingPi) return kWindingInside;
  if (s.sum + e < 2.0 * kWindingPi) return kWindingOutside;
  return kWindingUnsure;
}

// A max-heap of approximated nodes by error (ties: the lower node id first).
struct WindingOpenHeap {
  uint32_t id[kWindingOpen];
  double sum[kWindingOpen], error[kWindingOpen];
  int count = 0;
  double sumTotal = 0, errorTotal = 0;

  HDT_HD bool above(int i, int j) const { return error[i] > error[j] || (error[i] == error[j] && id[i] < id[j]); }
  HDT_HD void swap(int i, int j) {
    const uint32_t n = id[i];
    id[i] = id[j];
    id[j] = n;
    const double s = sum[i], e = error[i];
    sum[i] = sum[j];
    error[i] = error[j];
    sum[j] = s;
    error[j] = e;
  }
  HDT_HD void push(uint32_t node, double s, double e) {
    int i = count++;
    id[i] = node;
    sum[i] = s;
    error[i] = e;
    sumTotal = sumTotal + s;
    errorTotal = errorTotal + e;
    while (i > 0 && above(i, (i - 1) / 2)) {
      swap(i, (i - 1) / 2);
      i = (i - 1) / 2;
    }
  }
  HDT_HD uint32_t pop() {
    const uint32_t node = id[0];
    const double popped = error[0];
    sumTotal = sumTotal - sum[0];
    errorTotal = errorTotal - error[0];
    swap(0, --count);
    int i = 0;
    for (;;) {
      const int l = 2 * i + 1, r = l + 1;
      int m = i;
      if (l < count && above(l, m)) m = l;
      if (r < count && above(r, m)) m = r;
      if (m == i) break;
      swap(i, m);
      i = m;
    }
    // A node barely clear of the box has a huge error (and may have a huge
    // estimate); once it is gone the running totals have lost the small
    // terms, so they are summed afresh.
    if (count > 0 && popped > 1024.0 * errorTotal) resum();
    return node;
  }
  // The totals summed afresh in array order. The running totals only screen:
  // every returned sum and error comes from here (they drift by far more than
  // the margin when huge terms come and go).
  HDT_HD void resum() {
    double s = 0, e = 0;
    for (int i = 0; i < count; ++i) {
      s = s + sum[i];
      e = e + error[i];
    }
    sumTotal = s;
    errorTotal = e;
  }
};

// `slack` (steradians) is added to the error while deciding whether to
// refine further (not to the returned error): a point query that must stay
// clear of 2 pi by slack more, because its value is carried to other
// points (windingGradientBound).
HDT_HD WindingSum windingSumOverBox(const WindingTreeView& t, const double* lo, const double* hi, int maxOpen,
                                    double slack = 0) {
  double c[3], rho2 = 0;
  for (int a = 0; a < 3; ++a) {
    c[a] = 0.5 * (lo[a] + hi[a]);
    const double h = 0.5 * (hi[a] - lo[a]);
    rho2 = rho2 + h * h;
  }
  const double rho = sqrt(rho2);
  double exact = 0, exactError = 0; // triangles summed exactly, and their variation over the box
  WindingOpenHeap heap;             // approximated nodes
  uint32_t stack[kWindingStack];
  int top = 0, opened = 0;
  stack[top++] = 0;
  // A node taken apart: a leaf's triangles summed exactly, an inner node's
  // children to the stack. False when a triangle meets the box.
  auto takeApart = [&](const WindingNode& n) {
    if (n.count == 0) {
      stack[top++] = n.first + 1; // the left child first
      stack[top++] = n.first;
      return true;
    }
    for (uint32_t i = n.first; i < n.first + n.count; ++i) {
      const WindingTriangle& tri = t.triangles[i];
      exact = exact + triangleSolidAngle(tri.v, c[0], c[1], c[2]);
      if (rho > 0) {
        const double td = windingBoxDistance(tri.lo, tri.hi, lo, hi);
        if (!(td > 0)) return false;
        exactError = exactError + 2.0 * tri.area * rho / (td * td * td);
      }
    }
    return true;
  };
  for (;;) {
    // The nodes on the stack: approximated when far, taken apart otherwise.
    while (top > 0) {
      const uint32_t id = stack[--top];
      double e, err;
      if (heap.count < kWindingOpen && windingNodeFarField(t.nodes[id], lo, hi, c, rho, e, err)) {
        heap.push(id, e, err);
      } else if (!takeApart(t.nodes[id])) {
        return WindingSum{exact, 0.0, false};
      }
    }
    // The running totals screen (the same operations in the same order on
    // both drivers); a verdict or a give-up is taken from fresh totals.
    auto totals = [&] {
      return WindingSum{exact + heap.sumTotal, exactError + (heap.errorTotal > 0 ? heap.errorTotal : 0.0), true};
    };
    auto slacked = [&](const WindingSum& w) { return WindingSum{w.sum, w.error + slack, w.ok}; };
    WindingSum s = totals();
    if (windingVerdict(slacked(s), t.triangleCount) != kWindingUnsure || heap.count == 0) {
      heap.resum();
      s = totals();
      if (windingVerdict(slacked(s), t.triangleCount) != kWindingUnsure || heap.count == 0) return s;
    }
    // Over a box, the variation of the triangles summed exactly only grows as
    // nodes are opened: once it alone reaches 1/2, give up (split the box).
    const bool hopeless = rho > 0 && exactError >= fabs(s.sum - 2.0 * kWindingPi);
    if (hopeless || opened++ >= maxOpen) {
      heap.resum();
      s = totals();
      return WindingSum{s.sum, s.error, false};
    }
    if (!takeApart(t.nodes[heap.pop()])) return WindingSum{exact, 0.0, false}; // the worst approximation
  }
}

// The exact sum at a point over every triangle in tree order (the fallback).
HDT_HD double windingSumAll(const WindingTreeView& t, double px, double py, double pz) {
  double s = 0;
  for (uint32_t i = 0; i < t.triangleCount; ++i) s = s + triangleSolidAngle(t.triangles[i].v, px, py, pz);
  return s;
}

// The decision at one point: crossings and strips (winding_crossings.hpp)
// where they decide, else the refined sum, and where even the exact sum is
// within the rounding margin of 1/2, the exact sum in tree order; ties
// (w == 1/2 as computed) are inside.
HDT_HD bool windingInsideAt(const WindingTreeView& t, double px, double py, double pz) {
  const double p[3] = {px, py, pz};
  const int c = windingVerdict(windingCrossingSumAt(t, p), t.triangleCount);
  if (c != kWindingUnsure) return c == kWindingInside;
  const int v = windingVerdict(windingSumOverBox(t, p, p, 1 << 30), t.triangleCount);
  if (v != kWindingUnsure) return v == kWindingInside;
  return windingSumAll(t, px, py, pz) >= 2.0 * kWindingPi;
}

// ---- carrying a certified value across space that holds no triangle --------
//
// Off the mesh S, each triangle's solid angle is smooth and its gradient is
// the Biot-Savart field of the triangle's boundary loop (unit current): grad
// Omega(x) = -(loop integral of dl x (x - y) / |x - y|^3), up to sign. The
// triangles' loops add up to the boundary 1-chain (WindingEdge): an interior
// edge met in both directions cancels exactly (same segment, opposite dl),
// one met twice in the same direction counts twice. For one straight segment
// at distance d from x (d_perp: to its line, foot at t = 0, the segment from
// t1 to t2), the field is |int_t1^t2 d_perp dt / (t^2 + d_perp^2)^(3/2)|
// <= min(len / d^2, 2 / d): the integrand is at most 1 / d^2, and the
// integral is at most 2 / d_perp = 2 / d when the foot lies on the segment,
// at most (1 - t1 / d) / d_perp = d_perp / (d (d + t1)) <= 1 / d when not.
// So |grad Omega| <= sum_e weight_e min(len_e / d_e^2, 2 / d_e) at x, and for
// two points joined by a path inside a box that meets no triangle,
// |Omega(q) - Omega(p)| <= path length * that sum with d_e the distance from
// the box to edge e. On a closed, consistently oriented mesh there is no
// edge: w is constant on every connected piece of space off the mesh.

// The bound on |grad Omega| (steradians per voxel) over the box [lo, hi]:
// INFINITY when a boundary edge meets the box. A group of edges is bounded
// as one (its box's distance) unless its edges one by one say less.
HDT_HD double windingEdgeBound(double weightedLength, double weight, double d) {
  const double byLength = weightedLength / (d * d), byDistance = 2.0 * weight / d;
  return byLength < byDistance ? byLength : byDistance;
}

// The centre c of the box [lo, hi]; returns its half diagonal, rounded up
// (every point of the box lies within it of c): what windingEdgeDistance takes.
HDT_HD double windingBoxBall(const double* lo, const double* hi, double* c) {
  double rho2 = 0;
  for (int a = 0; a < 3; ++a) {
    c[a] = 0.5 * (lo[a] + hi[a]);
    rho2 = rho2 + 0.25 * (hi[a] - lo[a]) * (hi[a] - lo[a]);
  }
  return sqrt(rho2) * (1 + 1e-12);
}

// A lower bound on the distance from the box [lo, hi] (centre c, half
// diagonal rho) to edge e: its bounding box's distance, or the centre's
// distance to the segment less rho (1e-6 voxels below it: the rounding of a
// few operations on coordinates below 2^17).
HDT_HD double windingEdgeDistance(const WindingEdge& e, const double* lo, const double* hi, const double* c, double rho) {
  const double boxes = windingBoxDistance(e.lo, e.hi, lo, hi);
  double ab[3], ac[3], abab = 0, acab = 0;
  for (int a = 0; a < 3; ++a) {
    ab[a] = e.b[a] - e.a[a];
    ac[a] = c[a] - e.a[a];
    abab = abab + ab[a] * ab[a];
    acab = acab + ac[a] * ab[a];
  }
  const double f = abab > 0 ? (acab <= 0 ? 0.0 : (acab >= abab ? 1.0 : acab / abab)) : 0.0;
  double s = 0;
  for (int a = 0; a < 3; ++a) {
    const double g = ac[a] - f * ab[a];
    s = s + g * g;
  }
  const double segment = sqrt(s) - rho - 1e-6;
  return segment > boxes ? segment : boxes;
}

HDT_HD double windingGradientBound(const WindingTreeView& t, const double* lo, const double* hi) {
  double total = 0, c[3];
  const double rho = windingBoxBall(lo, hi, c);
  for (uint32_t g = 0; g < t.edgeGroupCount; ++g) {
    const WindingEdgeGroup& group = t.edgeGroups[g];
    const double dg = windingBoxDistance(group.lo, group.hi, lo, hi);
    const double asGroup = dg > 0 ? windingEdgeBound(group.weightedLength, group.weight, dg) : INFINITY;
    // A group farther than twice its own diagonal: its edges one by one would
    // say at most (1 + 1/2)^2 times less; not worth their divisions.
    double diag2 = 0;
    for (int a = 0; a < 3; ++a) diag2 = diag2 + (group.hi[a] - group.lo[a]) * (group.hi[a] - group.lo[a]);
    if (dg * dg > 4.0 * diag2) {
      total = total + asGroup;
      continue;
    }
    double oneByOne = 0;
    for (uint32_t i = group.first; i < group.first + group.count && oneByOne < asGroup; ++i) {
      const WindingEdge& e = t.edges[i];
      const double d = windingEdgeDistance(e, lo, hi, c, rho); // <= the distance to the segment
      if (!(d > 0)) return INFINITY;
      oneByOne = oneByOne + windingEdgeBound(e.weight * e.length, e.weight, d);
    }
    total = total + (oneByOne < asGroup ? oneByOne : asGroup);
  }
  return total;
}

// Openings a point query may spend to seed a region before the region falls
// back to the per-voxel decision.
constexpr int kWindingSeedOpenings = 4096;

// The verdict for every point within `reach` (path length, voxels) of point p
// inside a region whose gradient bound is `gradient`: inside / outside when
// the certified sum at p stays clear of 2 pi by reach * gradient more, else
// unsure. `s` is p's sum (windingSumOverBox at p).
HDT_HD int windingCarriedVerdict(const WindingSum& s, double reach, double gradient, uint32_t n) {
  if (!s.ok || !(reach * gradient < INFINITY)) return kWindingUnsure;
  return windingVerdict(WindingSum{s.sum, s.error + reach * gradient, true}, n);
}

// ---- leaves: face-connected pieces of non-surface voxels --------------------
//
// The closed box of a non-surface voxel meets no triangle (the surface rule,
// touching counts), so the segment between the centres of two face-adjacent
// non-surface voxels, which lies in the union of their closed boxes, meets
// none either. A breadth-first search from a seed voxel over face-adjacent
// non-surface voxels of a leaf gives each voxel a path of that many unit
// segments, inside the bounding box of the piece's voxel boxes.

// Labels the pieces of one leaf of edge L (at most 32): label[v] = piece
// (0xFFFF for surface voxels), steps[v] = path length from the piece's seed
// (its lowest voxel index), queue: L^3 scratch. Writes each piece's seed,
// voxel box [lo, hi) (leaf coordinates) and largest step count; returns the
// number of pieces (at most maxPieces; -1 when there are more).
struct WindingPiece {
  uint32_t seed;
  int lo[3], hi[3];
  int reach;
};

template <class IsSurface>
HDT_HD int windingLeafPieces(int L, IsSurface&& isSurface, uint16_t* label, uint16_t* steps, uint16_t* queue,
                             WindingPiece* pieces, int maxPieces) {
  const uint32_t n = uint32_t(L) * uint32_t(L) * uint32_t(L);
  for (uint32_t v = 0; v < n; ++v) label[v] = isSurface(v) ? uint16_t(0xFFFF) : uint16_t(0xFFFE);
  int count = 0;
  for (uint32_t seed = 0; seed < n; ++seed) {
    if (label[seed] != 0xFFFE) continue;
    if (count == maxPieces) return -1;
    WindingPiece& p = pieces[count];
    p.seed = seed;
    p.reach = 0;
    for (int a = 0; a < 3; ++a) {
      p.lo[a] = L;
      p.hi[a] = 0;
    }
    uint32_t head = 0, tail = 0;
    label[seed] = uint16_t(count);
    steps[seed] = 0;
    queue[tail++] = uint16_t(seed);
    while (head < tail) {
      const uint32_t v = queue[head++];
      const int c[3] = {int(v % uint32_t(L)), int((v / uint32_t(L)) % uint32_t(L)), int(v / (uint32_t(L) * uint32_t(L)))};
      for (int a = 0; a < 3; ++a) {
        if (c[a] < p.lo[a]) p.lo[a] = c[a];
        if (c[a] + 1 > p.hi[a]) p.hi[a] = c[a] + 1;
      }
      if (steps[v] > p.reach) p.reach = steps[v];
      const uint32_t stride[3] = {1u, uint32_t(L), uint32_t(L) * uint32_t(L)};
      for (int a = 0; a < 3; ++a) {
        for (int side = -1; side <= 1; side += 2) {
          const int to = c[a] + side;
          if (to < 0 || to >= L) continue;
          const uint32_t u = side < 0 ? v - stride[a] : v + stride[a];
          if (label[u] != 0xFFFE) continue;
          label[u] = uint16_t(count);
          steps[u] = uint16_t(steps[v] + 1);
          queue[tail++] = uint16_t(u);
        }
      }
    }
    ++count;
  }
  return count;
}

// Seeds a leaf piece may take before its remaining voxels fall back to the
// per-voxel decision, and the path lengths a seed's value is carried.
constexpr int kWindingPieceSeeds = 1024;
constexpr int kWindingSeedReach[5] = {16, 8, 4, 2, 1};

// Decides the voxels of piece k of a leaf (labels and scratch from
// windingLeafPieces; leaf origin in voxels): first its seed carried over the
// whole piece; where that is not enough, seeds taken in voxel order among the
// voxels still open, each carried up to the path length its clearance allows
// (the gradient bound over the box its paths can reach). state[v]: 0 open,
// 1 decided, 2 left to the per-voxel decision; settle(v, inside) for each
// decided voxel. visit: L^3 scratch of stamps (kept across pieces; *stamp
// counts).
template <class Settle>
HDT_HD void windingCarryPiece(const WindingTreeView& t, int L, const int* origin, const WindingPiece& piece, int k,
                              const uint16_t* label, uint16_t* steps, uint16_t* queue, uint32_t* visit,
                              uint32_t* stamp, uint8_t* state, Settle&& settle) {
  const uint32_t n = uint32_t(L) * uint32_t(L) * uint32_t(L), uL = uint32_t(L);
  double plo[3], phi[3];
  for (int a = 0; a < 3; ++a) {
    plo[a] = origin[a] + piece.lo[a];
    phi[a] = origin[a] + piece.hi[a];
  }
  auto centreOf = [&](uint32_t v, double* c) {
    c[0] = origin[0] + int(v % uL) + 0.5;
    c[1] = origin[1] + int((v / uL) % uL) + 0.5;
    c[2] = origin[2] + int(v / (uL * uL)) + 0.5;
  };
  // Breadth-first from `from` over the piece up to `depth` steps, deciding
  // each open voxel from s carried with the gradient bound.
  auto carry = [&](uint32_t from, int depth, const WindingSum& s, double gradient) {
    const uint32_t mark = ++*stamp;
    uint32_t head = 0, tail = 0;
    visit[from] = mark;
    steps[from] = 0;
    queue[tail++] = uint16_t(from);
    const uint32_t stride[3] = {1u, uL, uL * uL};
    while (head < tail) {
      const uint32_t v = queue[head++];
      if (state[v] == 0) {
        const int verdict = windingCarriedVerdict(s, steps[v], gradient, t.triangleCount);
        if (verdict != kWindingUnsure) {
          state[v] = 1;
          settle(v, verdict == kWindingInside);
        }
      }
      if (steps[v] >= depth) continue;
      const int c[3] = {int(v % uL), int((v / uL) % uL), int(v / (uL * uL))};
      for (int a = 0; a < 3; ++a)
        for (int side = -1; side <= 1; side += 2) {
          const int to = c[a] + side;
          if (to < 0 || to >= L) continue;
          const uint32_t u = side < 0 ? v - stride[a] : v + stride[a];
          if (label[u] != uint16_t(k) || visit[u] == mark) continue;
          visit[u] = mark;
          steps[u] = uint16_t(steps[v] + 1);
          queue[tail++] = uint16_t(u);
        }
    }
  };
  // The whole piece from its seed.
  const double gradient = windingGradientBound(t, plo, phi);
  double seedCentre[3];
  centreOf(piece.seed, seedCentre);
  if (piece.reach * gradient < 2.0 * kWindingPi) {
    WindingSum s = windingCrossingSumAt(t, seedCentre);
    if (!s.ok && piece.reach * gradient < kWindingPi)
      s = windingSumOverBox(t, seedCentre, seedCentre, kWindingSeedOpenings, piece.reach * gradient);
    if (windingCarriedVerdict(s, piece.reach, gradient, t.triangleCount) != kWindingUnsure) {
      carry(piece.seed, 1 << 15, s, gradient);
      return;
    }
  }
  // Seeds among the open voxels, in voxel order.
  int seeds = 0;
  for (uint32_t v = piece.seed; v < n; ++v) {
    if (label[v] != uint16_t(k) || state[v] != 0) continue;
    if (seeds++ == kWindingPieceSeeds) {
      for (uint32_t u = v; u < n; ++u)
        if (label[u] == uint16_t(k) && state[u] == 0) state[u] = 2;
      return;
    }
    double c[3];
    centreOf(v, c);
    // The gradient bound over the box that the paths of reach i stay in.
    auto boundFor = [&](int i) {
      const int r = kWindingSeedReach[i];
      double lo[3], hi[3];
      for (int a = 0; a < 3; ++a) {
        lo[a] = c[a] - 0.5 - r > plo[a] ? c[a] - 0.5 - r : plo[a];
        hi[a] = c[a] + 0.5 + r < phi[a] ? c[a] + 0.5 + r : phi[a];
      }
      return windingGradientBound(t, lo, hi);
    };
    double g[5] = {-1.0, -1.0, -1.0, -1.0, -1.0};
    WindingSum s = windingCrossingSumAt(t, c);
    if (!s.ok) {
      // The tree's sum, refined for the largest reach that a clear w (0 or
      // 1: 2 pi from the threshold) could carry.
      int want = 4;
      for (int i = 4; i >= 0; --i) {
        g[i] = boundFor(i);
        if (kWindingSeedReach[i] * g[i] < 1.5 * kWindingPi) want = i;
      }
      const double slack = kWindingSeedReach[want] * g[want] < 1.5 * kWindingPi ? 1.02 * kWindingSeedReach[want] * g[want] : 0.0;
      s = windingSumOverBox(t, c, c, kWindingSeedOpenings, slack);
    }
    const double clearance = fabs(s.sum - 2.0 * kWindingPi) - (s.error * 1.001 + windingMargin(t.triangleCount));
    if (!(clearance > 0)) {
      state[v] = 2; // w too close to 1/2 for this sum: the per-voxel decision
      continue;
    }
    // The largest reach the clearance allows, the bounds asked for reach 4,
    // then 8 and 16, or 2 and 1 (about three bounds of the edges, not five).
    auto allows = [&](int i) {
      if (g[i] < 0) g[i] = boundFor(i);
      return kWindingSeedReach[i] * g[i] * 1.01 < clearance;
    };
    int best = -1;
    if (allows(2)) {
      best = allows(1) ? (allows(0) ? 0 : 1) : 2;
    } else {
      best = allows(3) ? 3 : (allows(4) ? 4 : -1);
    }
    carry(v, best < 0 ? 0 : kWindingSeedReach[best], s, best < 0 ? 0.0 : g[best]);
  }
}

// A box query that needs more openings than this is split instead.
constexpr int kWindingBoxOpenings = 512;

// ---- small boxes: one traversal, then every voxel centre on its own --------
//
// A box of at most kWindingListBox^3 voxels is not split further: one walk of
// the tree lists the nodes far from every point of the box (centre more than
// 4 radii away), and the triangles of the leaves that are not: those whose
// centroid is more than 2 of their own radii away by their dipole, the others
// exactly. Each voxel centre p is then summed from the lists with every
// expansion evaluated at p itself, so there is no variation term: the error
// is the remainders alone, 3 A r^2 / (|p - centre| - r)^4 for a node (below
// 0.04 A / r^2), 3 M / (|p - centroid| - r)^4 for a dipole triangle (M: its
// second moment; its quadrupole about the centroid vanishes). A centre the
// lists leave unsure takes the adaptive point query (windingInsideAt).
// Cheaper than an adaptive walk per voxel, and as exact: every verdict is
// certified.
constexpr int kWindingListBox = 4;
constexpr double kWindingFarRatio2 = 16.0;   // far node: centre more than 4 radii from the box
constexpr double kWindingDipoleRatio2 = 4.0; // dipole triangle: centroid more than 2 radii from the box
constexpr int kWindingListMax = 2048; // far nodes, and near triangles, per box
constexpr int kWindingSmallBoxOpenings = 32; // a small box's own try before its lists

struct WindingBoxLists {
  uint32_t far[kWindingListMax];  // nodes: dipole + quadrupole
  uint32_t near[kWindingListMax]; // triangles: exact solid angle
  uint32_t dip[kWindingListMax];  // triangles: dipole about the centroid
  int farCount = 0, nearCount = 0, dipCount = 0;
};

// Squared distance from point c to the box [lo, hi].
HDT_HD double windingPointBoxDistance2(const double* c, const double* lo, const double* hi) {
  double s = 0;
  for (int a = 0; a < 3; ++a) {
    const double g = c[a] < lo[a] ? lo[a] - c[a] : (c[a] > hi[a] ? c[a] - hi[a] : 0.0);
    s = s + g * g;
  }
  return s;
}

// Fills the lists for the box of points [lo, hi]; false when one overflows.
HDT_HD bool windingBoxLists(const WindingTreeView& t, const double* lo, const double* hi, WindingBoxLists& l) {
  uint32_t stack[kWindingStack];
  int top = 0;
  stack[top++] = 0;
  l.farCount = l.nearCount = l.dipCount = 0;
  while (top > 0) {
    const WindingNode& n = t.nodes[stack[--top]];
    if (windingPointBoxDistance2(n.centre, lo, hi) > kWindingFarRatio2 * n.radius * n.radius) {
      if (l.farCount == kWindingListMax) return false;
      l.far[l.farCount++] = uint32_t(&n - t.nodes);
    } else if (n.count == 0) {
      stack[top++] = n.first + 1;
      stack[top++] = n.first;
    } else {
      if (l.nearCount + int(n.count) > kWindingListMax || l.dipCount + int(n.count) > kWindingListMax) return false;
      for (uint32_t i = n.first; i < n.first + n.count; ++i) {
        const WindingTriangle& tri = t.triangles[i];
        if (windingPointBoxDistance2(tri.centroid, lo, hi) > kWindingDipoleRatio2 * tri.radius * tri.radius) {
          l.dip[l.dipCount++] = i;
        } else {
          l.near[l.nearCount++] = i;
        }
      }
    }
  }
  return true;
}

// The sum at point p from the lists, with its error. Besides the remainders, the error
// holds the rounding of the sum itself: (terms + 16) ulps of the sum of the
// terms' magnitudes (windingMargin covers a few ulps of 2 pi per term only).
HDT_HD WindingSum windingSumFromLists(const WindingTreeView& t, const WindingBoxLists& l, const double* p) {
  double sum = 0, magnitude = 0, error = 0;
  for (int i = 0; i < l.farCount; ++i) {
    const WindingNode& n = t.nodes[l.far[i]];
    double d = 0;
    const double term = windingNodeExpansion(n, p, d);
    sum = sum + term;
    magnitude = magnitude + fabs(term);
    const double gap = d - n.radius;
    error = error + 3.0 * n.area * n.radius * n.radius / ((gap * gap) * (gap * gap));
  }
  for (int i = 0; i < l.nearCount; ++i) {
    const double term = triangleSolidAngle(t.triangles[l.near[i]].v, p[0], p[1], p[2]);
    sum = sum + term;
    magnitude = magnitude + fabs(term);
  }
  // A triangle about its centroid has no quadrupole (its first moment
  // vanishes): the dipole alone, off by at most 3 M / (d - r)^4 (M: its
  // second moment about the centroid; the second derivatives of the kernel
  // are at most 6 / dist^4 and dist >= d - r along the way).
  for (int i = 0; i < l.dipCount; ++i) {
    const WindingTriangle& tri = t.triangles[l.dip[i]];
    const double dx = tri.centroid[0] - p[0], dy = tri.centroid[1] - p[1], dz = tri.centroid[2] - p[2];
    const double d = sqrt(dx * dx + dy * dy + dz * dz);
    const double term = (tri.halfCross[0] * dx + tri.halfCross[1] * dy + tri.halfCross[2] * dz) / (d * d * d);
    sum = sum + term;
    magnitude = magnitude + fabs(term);
    const double gap = d - tri.radius;
    error = error + 3.0 * tri.secondMoment / ((gap * gap) * (gap * gap));
  }
  error = error + double(l.farCount + l.nearCount + l.dipCount + 16) * 2.3e-16 * magnitude;
  return WindingSum{sum, error, true};
}

// A box of voxels [lo, hi) (integer voxel coordinates).
struct VoxelBox {
  int lo[3], hi[3];
  HDT_HD int size(int a) const { return hi[a] - lo[a]; }
  HDT_HD bool single() const { return size(0) == 1 && size(1) == 1 && size(2) == 1; }
};

// The carried verdict over a box of voxels whose closed box meets no
// triangle: one certified sum at the box's centre (at least half a voxel from
// every triangle), carried along straight segments to every voxel centre.
// Where the crossings and strips cannot be evaluated at the centre (it lies
// in a strip's plane), the tree's sum is refined there, unless
// `refineInTree` is false (the device: up to kWindingSeedOpenings openings on
// one thread would hold a whole level; it splits the box instead).
HDT_HD int windingCarriedBoxVerdict(const WindingTreeView& t, const VoxelBox& b, bool refineInTree = true) {
  double lo[3], hi[3], centre[3], reach2 = 0;
  for (int a = 0; a < 3; ++a) {
    lo[a] = b.lo[a];
    hi[a] = b.hi[a];
    centre[a] = 0.5 * (lo[a] + hi[a]);
    const double half = 0.5 * (b.size(a) - 1); // to the farthest voxel centre
    reach2 = reach2 + half * half;
  }
  const double reach = sqrt(reach2) * (1 + 1e-12);
  const double gradient = windingGradientBound(t, lo, hi);
  if (!(reach * gradient < 2.0 * kWindingPi)) return kWindingUnsure;
  const WindingSum c = windingCrossingSumAt(t, centre);
  if (c.ok || !refineInTree) return windingCarriedVerdict(c, reach, gradient, t.triangleCount);
  if (!(reach * gradient < kWindingPi)) return kWindingUnsure;
  const WindingSum s = windingSumOverBox(t, centre, centre, kWindingSeedOpenings, reach * gradient);
  return windingCarriedVerdict(s, reach, gradient, t.triangleCount);
}

// Decides every voxel centre of `box`: calls settle(box, inside) for boxes
// whose centres are all certified on one side, settling single voxels by
// windingInsideAt. skip(box) drops boxes that need no answer (all surface);
// direct(box) says a box surely holds a triangle (it holds a surface voxel):
// it is split without a try; done() stops early. Boxes are split in halves along each axis longer than
// one voxel, in a fixed order.
template <class Skip, class Split, class Settle, class Done>
HDT_HD void windingDecideBox(const WindingTreeView& t, const VoxelBox& box, Skip&& skip, Split&& direct, Settle&& settle,
                             Done&& done) {
  VoxelBox stack[8 * 20];
  WindingBoxLists lists;
  int top = 0;
  stack[top++] = box;
  while (top > 0 && !done()) {
    const VoxelBox b = stack[--top];
    if (skip(b)) continue;
    const double lo[3] = {b.lo[0] + 0.5, b.lo[1] + 0.5, b.lo[2] + 0.5};
    const double hi[3] = {b.hi[0] - 0.5, b.hi[1] - 0.5, b.hi[2] - 0.5};
    if (b.single()) {
      settle(b, windingInsideAt(t, lo[0], lo[1], lo[2]));
      continue;
    }
    const bool small = b.size(0) <= kWindingListBox && b.size(1) <= kWindingListBox && b.size(2) <= kWindingListBox;
    int v = kWindingUnsure;
    if (!direct(b)) {
      v = windingCarriedBoxVerdict(t, b);
      if (v == kWindingUnsure)
        v = windingVerdict(windingSumOverBox(t, lo, hi, small ? kWindingSmallBoxOpenings : kWindingBoxOpenings),
                           t.triangleCount);
    }
    if (v != kWindingUnsure) {
      settle(b, v == kWindingInside);
      continue;
    }
    if (small) {
      // Each voxel centre by crossings and strips; the lists are filled
      // for the first centre that needs them (if they fit).
      int listed = 0; // 0 not yet, 1 filled, -1 overflow
      for (int z = b.lo[2]; z < b.hi[2] && !done(); ++z)
        for (int y = b.lo[1]; y < b.hi[1]; ++y)
          for (int x = b.lo[0]; x < b.hi[0]; ++x) {
            const VoxelBox one{{x, y, z}, {x + 1, y + 1, z + 1}};
            if (skip(one)) continue;
            const double p[3] = {x + 0.5, y + 0.5, z + 0.5};
            int pv = windingVerdict(windingCrossingSumAt(t, p), t.triangleCount);
            if (pv == kWindingUnsure) {
              if (listed == 0) listed = windingBoxLists(t, lo, hi, lists) ? 1 : -1;
              if (listed == 1) pv = windingVerdict(windingSumFromLists(t, lists, p), t.triangleCount);
            }
            settle(one, pv == kWindingUnsure ? windingInsideAt(t, p[0], p[1], p[2]) : pv == kWindingInside);
          }
      continue;
    }
    for (int k = 7; k >= 0; --k) { // child 0 (low x, y, z) is taken first
      VoxelBox s = b;
      bool exists = true;
      for (int a = 0; a < 3; ++a) {
        const int mid = b.lo[a] + b.size(a) / 2;
        if ((k >> a) & 1) {
          if (b.size(a) == 1) exists = false;
          s.lo[a] = mid;
        } else if (b.size(a) > 1) {
          s.hi[a] = mid;
        }
      }
      if (exists) stack[top++] = s;
    }
  }
}

} // namespace hdt
