// The pieces of the winding-number test that both of its evaluations use
// (winding.hpp: the tree's bounded sums; winding_crossings.hpp: crossings
// and boundary strips): our own atan2, the solid angle of a triangle, the
// tree's layout and the bounded-sum result. Only + - * / and sqrt.
#pragma once

#include "hdt/lattice.hpp"
#include "hdt/platform.hpp"

#include <cmath>
#include <cstdint>

namespace hdt {

constexpr double kWindingPi = 3.141592653589793116; // the double nearest pi
constexpr double kWindingHalfPi = 1.570796326794896558;

// atan(t) for t in [0, 1]: two half-angle steps atan t = 2 atan(t / (1 +
// sqrt(1 + t^2))) bring t below tan(pi / 16) < 0.2, then the Taylor series
// to t^27 (remainder below 1e-20).
HDT_HD double windingAtanUnit(double t) {
  double u = t / (1.0 + sqrt(1.0 + t * t));
  u = u / (1.0 + sqrt(1.0 + u * u));
  const double u2 = u * u;
  double s = 0;
  for (int k = 13; k >= 0; --k) s = s * u2 + ((k & 1) ? -1.0 : 1.0) / double(2 * k + 1);
  return 4.0 * (u * s);
}

// atan2(y, x) from windingAtanUnit: the same bits on host and device (the
// libraries' atan2 differ in the last places). atan2(0, 0) = 0.
HDT_HD double windingAtan2(double y, double x) {
  const double ay = fabs(y), ax = fabs(x);
  if (ax == 0 && ay == 0) return 0;
  double a = ay <= ax ? windingAtanUnit(ay / ax) : kWindingHalfPi - windingAtanUnit(ax / ay);
  if (x < 0) a = kWindingPi - a;
  return y < 0 ? -a : a;
}

// Signed solid angle of triangle (v[0..2], v[3..5], v[6..8]) seen from p
// (Van Oosterom & Strackee 1983): positive when p sees the triangle's back
// (counter-clockwise from outside), so a closed outward mesh gives 4 pi
// inside and 0 outside.
HDT_HD double triangleSolidAngle(const double* v, double px, double py, double pz) {
  const double ax = v[0] - px, ay = v[1] - py, az = v[2] - pz;
  const double bx = v[3] - px, by = v[4] - py, bz = v[5] - pz;
  const double cx = v[6] - px, cy = v[7] - py, cz = v[8] - pz;
  const double la = sqrt(ax * ax + ay * ay + az * az);
  const double lb = sqrt(bx * bx + by * by + bz * bz);
  const double lc = sqrt(cx * cx + cy * cy + cz * cz);
  const double det = ax * (by * cz - bz * cy) + ay * (bz * cx - bx * cz) + az * (bx * cy - by * cx);
  const double ab = ax * bx + ay * by + az * bz;
  const double ac = ax * cx + ay * cy + az * cz;
  const double bc = bx * cx + by * cy + bz * cz;
  const double den = la * lb * lc + ab * lc + ac * lb + bc * la;
  return 2.0 * windingAtan2(det, den);
}

// A node of the tree: a box of triangles with what the far field needs.
// Inner nodes have count == 0 and children first, first + 1; leaves hold
// triangles [first, first + count) of the tree's triangle order.
struct WindingNode {
  double lo[3], hi[3]; // bounding box of the triangles
  double centre[3];    // box centre
  double radius;       // half diagonal: every point of a triangle is this close to centre
  double area;         // sum of triangle areas
  double dipole[3];    // sum of area * unit normal (= half the cross products)
  double quad[9];      // sum of (area * normal) (centroid - centre)^T, row major
  uint32_t first, count;
};

// One triangle in tree order: corners, area and bounding box.
struct WindingTriangle {
  double v[9];
  double area;
  double lo[3], hi[3];
  double centroid[3];
  double halfCross[3]; // area * unit normal
  double radius;       // every point of the triangle is this close to the centroid
  double secondMoment; // integral of |x - centroid|^2 over the triangle: area * sum |v - centroid|^2 / 12
};

// An edge of the mesh's boundary 1-chain: the triangles' directed edges,
// identified by their exact lattice corners, with opposite directions
// cancelling and equal ones adding; only edges with a nonzero net count
// (weight = |count|) remain. A closed, consistently oriented mesh has none.
struct WindingEdge {
  double a[3], b[3];
  double weight; // |net count|
  double net;    // the net count: positive when the triangles run a -> b
  double length;
  double lo[3], hi[3];
};

// Consecutive boundary edges (in a spatial order) bounded together.
struct WindingEdgeGroup {
  double lo[3], hi[3];   // bounding box of the edges
  double weightedLength; // sum weight * length
  double weight;         // sum weight
  uint32_t first, count; // edges [first, first + count)
};

struct WindingTreeView {
  const WindingNode* nodes;
  const WindingTriangle* triangles;
  uint32_t triangleCount;
  const WindingEdge* edges = nullptr;
  const WindingEdgeGroup* edgeGroups = nullptr;
  uint32_t edgeGroupCount = 0;
  const LatticeTriangle* lattice = nullptr; // the triangles in tree order, exact (winding_crossings.hpp)
  uint32_t edgeCount = 0;
};

constexpr int kWindingStack = 96; // > 2 * tree depth (depth <= 40 for 2^32 triangles in leaves of 8)

// A sum of solid angles (steradians) with a bound on its distance from the
// exact sum over the points it stands for (winding.hpp, windingSumOverBox).
struct WindingSum {
  double sum;   // estimate at the box centre
  double error; // bound on |exact - sum| over the box
  bool ok;      // false: a triangle meets the box, or the refinement gave up
};

} // namespace hdt
