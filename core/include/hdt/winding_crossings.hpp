// The winding number at a lattice point from an exact crossing count and the
// boundary curve alone (docs/design.md, "Winding number", "crossings and
// strips"), shared by the CPU and CUDA drivers.
//
// Sweep every edge e = (a -> b) of the mesh's boundary 1-chain C (net count
// m_e, WindingEdge::net) to -infinity along x: the strips' boundary cancels
// C, so S + strips is closed up to a copy of S at -infinity, whose solid
// angle vanishes. For a closed surface the solid-angle sum is 4 pi times the
// signed count of crossings of any ray, and the +x ray from p meets a strip
// only where p lies in that strip's plane. Hence, for p on neither S nor a
// strip,
//
//   4 pi w(p) = 4 pi N(p) + K(p),   K(p) = sum_e m_e Omega(a - p, b - p, -x),
//
// N(p) the signed count of the triangles the +x ray crosses (the sign of the
// triangle's normal x component), Omega the Van Oosterom-Strackee solid angle
// of the spherical triangle whose third corner is the direction -x (the limit
// of the strip swept from e; tests/test_winding_crossings.cpp pins the signs
// against the brute-force sum).
//
// Exactness: p is a lattice point (voxel units * 256, as voxel centres and the
// centres of voxel boxes are). N uses the parity pass's exact predicate
// (rayHitsTriangle: the ray perturbed to (y + eps, z + eps^2), so a ray
// through an edge or a vertex is counted by exactly one of the triangles
// around it), and a crossing exactly at p (p on S) gives up. Each strip's
// determinant (a 2x2 determinant in y, z) is exact in double for lattice
// points; where it is 0 (p in the plane of a strip, so the ray may graze the
// boundary, or p on the line of an edge parallel to x) the evaluation gives
// up. K is taken as one running complex product and one atan2
// (windingStripProduct), or edge by edge (windingStripAngle) where the
// product cannot count its turns for certain; its rounding is bounded, so the result is
// a WindingSum with a rigorous error and windingVerdict decides from it as
// from any other bounded sum (its margin covers the brute-force sum's own
// rounding). Only + - * / and sqrt, fixed order, fixed stacks.
#pragma once

#include "hdt/geometry.hpp"
#include "hdt/lattice.hpp"
#include "hdt/platform.hpp"
#include "hdt/winding_basics.hpp"

#include <cstdint>

namespace hdt {

// Unit roundoff of double.
constexpr double kWindingUlp = 1.1102230246251565e-16; // 2^-53

// The +x ray from lattice point P against one triangle: 0 when it misses (or
// meets it only behind P), the sign of the triangle's normal x component when
// it crosses ahead of P, 2 when P lies on the triangle.
constexpr int kWindingOnTriangle = 2;

HDT_HD int windingRayCrossing(const LatticeTriangle& t, const int64_t* P) {
  if (!rayHitsTriangle(t, 0, P[1], P[2])) return 0; // the projection has area: n[0] != 0
  int64_t n[3];
  triangleNormal(t, n);
  // n . (X - v0) = 0 on the ray X = (x, P1, P2): n0 (x - P0) = D.
  const int128_t D = int128_t(n[0]) * (int64_t(t.v[0][0]) - P[0]) - int128_t(n[1]) * (P[1] - t.v[0][1]) -
                     int128_t(n[2]) * (P[2] - t.v[0][2]);
  if (D == 0) return kWindingOnTriangle;
  if ((D > 0) != (n[0] > 0)) return 0; // the crossing lies behind P
  return n[0] > 0 ? 1 : -1;
}

// N(P): the signed count of crossings ahead of P, the triangles found by a
// walk of the tree's node boxes that the ray can meet. False when P lies on a
// triangle (or the stack would overflow: not for trees of this depth).
HDT_HD bool windingRayCrossings(const WindingTreeView& t, const int64_t* P, int& count) {
  const double px = double(P[0]) / double(kLatticePerVoxel), py = double(P[1]) / double(kLatticePerVoxel),
               pz = double(P[2]) / double(kLatticePerVoxel);
  uint32_t stack[kWindingStack];
  int top = 0;
  stack[top++] = 0;
  count = 0;
  while (top > 0) {
    const WindingNode& n = t.nodes[stack[--top]];
    if (n.hi[0] < px || n.lo[1] > py || n.hi[1] < py || n.lo[2] > pz || n.hi[2] < pz) continue;
    if (n.count == 0) {
      if (top + 2 > kWindingStack) return false;
      stack[top++] = n.first + 1;
      stack[top++] = n.first;
      continue;
    }
    for (uint32_t i = n.first; i < n.first + n.count; ++i) {
      const int c = windingRayCrossing(t.lattice[i], P);
      if (c == kWindingOnTriangle) return false;
      count += c;
    }
  }
  return true;
}

// One strip's solid angle Omega(a - p, b - p, -x) = 2 atan2(det, den), as
// the pair (det, den) with a bound d on den's rounding: 0, or 1 for an edge
// parallel to x (a strip of no area: Omega = 0), or -1 when p lies in the
// strip's plane (or on the line of an edge parallel to x).
//
// With A = (a_y, a_z), B = (b_y, b_z) relative to p and c = -x, Van Oosterom
// and Strackee's numerator is a . (b x c) = a_z b_y - a_y b_z (exact for
// lattice points: products of multiples of 2^-8 below 2^17) and the
// denominator |a||b| + a.b + a.c |b| + b.c |a| = (|a| - a_x)(|b| - b_x) + A.B,
// with |a| - a_x = |A|^2 / (|a| + a_x) when a_x > 0 (no cancellation). Its
// rounding: ra and rb within 5 ulps each (squares, sums, root, quotient),
// their product and the last sum: below 16 ulps of the terms.
// What windingStripPair needs of p: the corners relative to p, the squares
// of their yz parts and their lengths (also what a segment's field takes:
// winding_far.hpp).
struct WindingStripGeometry {
  double ax, ay, az, bx, by, bz;
  double a2, b2; // ay^2 + az^2, by^2 + bz^2
  double la, lb; // |a - p|, |b - p|
};

HDT_HD WindingStripGeometry windingStripGeometry(const WindingEdge& e, const double* p) {
  WindingStripGeometry g;
  g.ax = e.a[0] - p[0];
  g.ay = e.a[1] - p[1];
  g.az = e.a[2] - p[2];
  g.bx = e.b[0] - p[0];
  g.by = e.b[1] - p[1];
  g.bz = e.b[2] - p[2];
  g.a2 = g.ay * g.ay + g.az * g.az;
  g.b2 = g.by * g.by + g.bz * g.bz;
  g.la = sqrt(g.ax * g.ax + g.a2);
  g.lb = sqrt(g.bx * g.bx + g.b2);
  return g;
}

// windingStripPair from p's geometry.
HDT_HD int windingStripPairOf(const WindingEdge& e, const WindingStripGeometry& g, double& det, double& den,
                              double& d) {
  det = 0;
  den = 1;
  d = 0;
  if (e.a[1] == e.b[1] && e.a[2] == e.b[2]) return (g.ay == 0 && g.az == 0) ? -1 : 1;
  det = g.az * g.by - g.ay * g.bz;
  if (det == 0) return -1;
  const double ra = g.ax > 0 ? g.a2 / (g.la + g.ax) : g.la - g.ax;
  const double rb = g.bx > 0 ? g.b2 / (g.lb + g.bx) : g.lb - g.bx;
  const double ab = g.ay * g.by + g.az * g.bz;
  den = ra * rb + ab;
  d = 16.0 * kWindingUlp * (ra * rb + fabs(g.ay * g.by) + fabs(g.az * g.bz));
  return 0;
}

HDT_HD int windingStripPair(const WindingEdge& e, const double* p, double& det, double& den, double& d) {
  return windingStripPairOf(e, windingStripGeometry(e, p), det, den, d);
}

// The strip's solid angle and a bound on its rounding; false when p lies in
// the strip's plane. atan2(y, x) moves by at most d |y| / ((|x| - d)^2 + y^2)
// when x moves by d; windingAtan2 itself is good to a few ulps of pi.
HDT_HD bool windingStripAngle(const WindingEdge& e, const double* p, double& angle, double& error) {
  double det, den, d;
  const int kind = windingStripPair(e, p, det, den, d);
  angle = 0;
  error = 0;
  if (kind != 0) return kind > 0;
  angle = 2.0 * windingAtan2(det, den);
  const double gap = fabs(den) - d > 0 ? fabs(den) - d : 0.0;
  error = 2.0 * d * fabs(det) / (gap * gap + det * det) * (1 + 1e-6) + 1e-14;
  return true;
}

// The running product of windingStripProductOf (below), one factor (a
// strip's pair from windingStripPair, kind 0) at a time.
struct WindingStripRunning {
  double zr = 1, zi = 0, rel = 0;
  int turns = 0;
};

// Multiplies in one strip's factor |net| times; false when a sign is not
// certain (the caller sums the edges one by one). Inlined into the edge loops
// on the host too (the device inlines every HDT_HD function).
#if defined(__GNUC__) && !defined(__CUDA_ARCH__)
__attribute__((always_inline))
#endif
HDT_HD bool windingStripProductStep(WindingStripRunning& z, double det, double den, double d, double net) {
  const double modulus = fabs(det) > fabs(den) - d ? fabs(det) : fabs(den) - d; // <= |den + i det| exact
  const double eta = d / modulus;
  if (!(eta < 1e-6)) return false;
  const int m = int(net);
  const double wi = m > 0 ? det : -det;
  for (int r = 0; r < (m > 0 ? m : -m); ++r) {
    const bool wasPositive = z.zi > 0, wasNegative = z.zi < 0;
    const double nr = z.zr * den - z.zi * wi, ni = z.zr * wi + z.zi * den;
    z.zr = nr;
    z.zi = ni;
    z.rel = z.rel + eta + 3.5e-16;
    const double size = fabs(z.zr) + fabs(z.zi);
    if (!(fabs(z.zi) > 1.01 * z.rel * size) || !(z.rel < 1e-6)) return false;
    if (wi > 0 && wasPositive && z.zi < 0) ++z.turns;
    if (wi < 0 && wasNegative && z.zi > 0) --z.turns;
    if (size > 0x1p200) {
      z.zr = z.zr * 0x1p-200;
      z.zi = z.zi * 0x1p-200;
    } else if (size < 0x1p-200) {
      z.zr = z.zr * 0x1p200;
      z.zi = z.zi * 0x1p200;
    }
  }
  return true;
}

// K and its rounding bound from the finished product.
HDT_HD void windingStripProductFinish(const WindingStripRunning& z, double& K, double& error) {
  const double angle = windingAtan2(z.zi, z.zr);
  K = 2.0 * (angle + 2.0 * kWindingPi * double(z.turns));
  error = 2.0 * (1.01 * z.rel + 1e-15 * (1.0 + fabs(angle)) + 1e-15 * double(z.turns > 0 ? z.turns : -z.turns)) +
          4.0 * kWindingUlp * fabs(K);
}

// K at p with one atan2 instead of one per edge: K / 2 is the argument of
// the product of den_e + i det_e over the edges (conjugated for m_e < 0,
// |m_e| times), up to whole turns. The turns are counted exactly: when a
// factor of positive argument psi takes the running argument A in (-pi, pi]
// past pi, A was > 0 and the new one is < 0 (and A + psi > pi is possible
// only with A > 0); the mirror case for psi < 0. So only the signs of the
// running product's imaginary part are needed, and each is taken only when
// it is certain: the product's relative rounding (each factor's den error
// over a lower bound of its modulus, plus sqrt(5) ulps a multiplication,
// Brent, Percival and Zimmermann) stays below its imaginary part. Powers of
// two keep it in range, exactly. Returns 0 with K and its error, 1 when a
// sign is not certain (the caller sums the edges one by one), -1 when p lies
// in a strip's plane.
// windingStripProductOf takes the edges edgeAt(0 .. count - 1), in order (a
// part of the boundary chain); windingStripProduct below takes them all.
template <class EdgeAt>
HDT_HD int windingStripProductOf(uint32_t count, EdgeAt&& edgeAt, const double* p, double& K, double& error) {
  WindingStripRunning z;
  for (uint32_t i = 0; i < count; ++i) {
    const WindingEdge& e = edgeAt(i);
    double det, den, d;
    const int kind = windingStripPair(e, p, det, den, d);
    if (kind < 0) return -1;
    if (kind > 0) continue;
    if (!windingStripProductStep(z, det, den, d, e.net)) return 1;
  }
  windingStripProductFinish(z, K, error);
  return 0;
}

HDT_HD int windingStripProduct(const WindingTreeView& t, const double* p, double& K, double& error) {
  return windingStripProductOf(t.edgeCount, [&](uint32_t i) -> const WindingEdge& { return t.edges[i]; }, p, K, error);
}

// 4 pi w at lattice point P (voxel units * 256) as a bounded sum: ok false
// when P lies on S or on a strip's plane (then the caller takes another
// evaluation). error covers K's rounding and that of the final sum.
HDT_HD WindingSum windingCrossingSum(const WindingTreeView& t, const int64_t* P) {
  int N = 0;
  if (!windingRayCrossings(t, P, N)) return WindingSum{0.0, 0.0, false};
  const double p[3] = {double(P[0]) / double(kLatticePerVoxel), double(P[1]) / double(kLatticePerVoxel),
                       double(P[2]) / double(kLatticePerVoxel)};
  double K = 0, magnitude = 0, error = 0;
  const int product = windingStripProduct(t, p, K, error);
  if (product < 0) return WindingSum{0.0, 0.0, false};
  if (product == 0) {
    const double whole = 4.0 * kWindingPi * double(N);
    return WindingSum{whole + K, error + 4.0 * kWindingUlp * (fabs(whole) + fabs(K)), true};
  }
  K = 0;
  error = 0;
  for (uint32_t i = 0; i < t.edgeCount; ++i) {
    const WindingEdge& e = t.edges[i];
    double angle, err;
    if (!windingStripAngle(e, p, angle, err)) return WindingSum{0.0, 0.0, false};
    const double term = e.net * angle;
    K = K + term;
    magnitude = magnitude + fabs(term);
    error = error + e.weight * err;
  }
  const double whole = 4.0 * kWindingPi * double(N);
  const double sum = whole + K;
  error = error + double(t.edgeCount + 16) * 2.3e-16 * (magnitude + fabs(whole));
  return WindingSum{sum, error, true};
}

// The lattice point of p (voxel units) when p is one (p * 256 an integer
// below 2^40 in magnitude), for windingCrossingSum.
HDT_HD bool windingLatticePoint(const double* p, int64_t* P) {
  for (int a = 0; a < 3; ++a) {
    const double q = p[a] * double(kLatticePerVoxel);
    if (!(fabs(q) < 1099511627776.0)) return false;
    P[a] = int64_t(q);
    if (double(P[a]) != q) return false;
  }
  return true;
}

// windingCrossingSum at p (voxel units); ok false when p is not a lattice point.
HDT_HD WindingSum windingCrossingSumAt(const WindingTreeView& t, const double* p) {
  int64_t P[3];
  if (t.lattice == nullptr || !windingLatticePoint(p, P)) return WindingSum{0.0, 0.0, false};
  return windingCrossingSum(t, P);
}

} // namespace hdt
