// One leaf of a winding-number build decided from signed crossing counts and
// one integer threshold per box, shared by the CPU and CUDA drivers
// (docs/design.md, "Winding number", "one threshold per box").
//
// From winding_crossings.hpp: 4 pi w(p) = 4 pi N(p) + K(p) off the mesh S
// and off the strip sheets (the sheet of boundary edge e is the set of points
// e(t) - s x, s >= 0), N the signed count of the triangles the +x ray crosses
// (the perturbed predicate), K the strips' solid angles. K is smooth except
// on the sheets (it is smooth across S), and where it is smooth its gradient
// is the Biot-Savart field of the boundary 1-chain (the strips' side rays
// cancel at the chain's vertices), the field windingGradientBound bounds.
// So over a box of points that no sheet crosses, K lies within G R of its
// value at the box centre (G the bound over the box, R the distance to the
// farthest point): when no integer T can make 4 pi T + K reach 2 pi from
// either side over that range, one integer T decides every non-surface voxel
// of the box: inside iff N >= T. Closed meshes (no boundary edge) give K = 0
// and T = 1: plain signed counting.
//
// A sheet contains the x direction, so it meets an x row of voxel centres in
// the whole row (behind the edge) or not at all: a leaf is split into boxes
// of rows (yz halves) until each box is sheet free, and boxes whose
// threshold fails are halved along every axis, down to single voxels (K at
// the voxel centre with N, then windingInsideAt). Every verdict is
// certified (windingVerdict's margins), so the bits equal the brute-force
// sum's at every voxel centre whichever way a voxel was decided. Fixed
// stacks, no allocation, only + - * / and sqrt in a fixed order.
#pragma once

#include "hdt/build_steps.hpp"
#include "hdt/platform.hpp"
#include "hdt/types.hpp"
#include "hdt/winding.hpp"

#include <cmath>
#include <cstdint>

namespace hdt {

// K at p (voxel units) from the edges edgeAt(0 .. count - 1) with its
// rounding bound: the running product, or edge by edge where the product
// cannot count its turns; false when p lies in one of their strips' planes
// (or on the line of an edge parallel to x). edgeAt is called with 0, 1, ...
// in order (once per loop).
template <class EdgeAt>
HDT_HD bool windingStripSumOf(uint32_t count, EdgeAt&& edgeAt, const double* p, double& K, double& error) {
  const int product = windingStripProductOf(count, edgeAt, p, K, error);
  if (product < 0) return false;
  if (product == 0) {
    error = error + 4.0 * kWindingUlp * fabs(K);
    return true;
  }
  double magnitude = 0;
  K = 0;
  error = 0;
  for (uint32_t i = 0; i < count; ++i) {
    const WindingEdge& e = edgeAt(i);
    double angle, err;
    if (!windingStripAngle(e, p, angle, err)) return false;
    const double term = e.net * angle;
    K = K + term;
    magnitude = magnitude + fabs(term);
    error = error + e.weight * err;
  }
  error = error + double(count + 16) * 2.3e-16 * magnitude;
  return true;
}

// K at p from every boundary edge.
HDT_HD bool windingStripSum(const WindingTreeView& t, const double* p, double& K, double& error) {
  return windingStripSumOf(t.edgeCount, [&](uint32_t i) -> const WindingEdge& { return t.edges[i]; }, p, K, error);
}

// Whether the sheet of edge e can meet the closed box [lo, hi]: its yz
// shadow (the edge's) meets the box's yz rectangle and the edge reaches the
// box's low x (the sheet lies behind the edge). The side tests are exact:
// coordinates are multiples of 2^-8 below 2^17, so each product has at most
// 50 significant bits and each difference 51. Touching counts. An edge
// parallel to x has a strip of no area (its solid angle is 0 everywhere).
HDT_HD bool windingSheetMeetsBox(const WindingEdge& e, const double* lo, const double* hi) {
  if (e.a[1] == e.b[1] && e.a[2] == e.b[2]) return false;
  if (e.hi[0] < lo[0] || e.hi[1] < lo[1] || e.lo[1] > hi[1] || e.hi[2] < lo[2] || e.lo[2] > hi[2]) return false;
  const double dy = e.b[1] - e.a[1], dz = e.b[2] - e.a[2];
  int positive = 0, negative = 0;
  for (int k = 0; k < 4; ++k) {
    const double y = (k & 1) ? hi[1] : lo[1], z = (k & 2) ? hi[2] : lo[2];
    const double side = dy * (z - e.a[2]) - dz * (y - e.a[1]);
    positive += side > 0;
    negative += side < 0;
  }
  return !(positive == 4 || negative == 4);
}

// Whether any boundary edge's sheet meets the box (groups first).
HDT_HD bool windingSheetsMeetBox(const WindingTreeView& t, const double* lo, const double* hi) {
  for (uint32_t g = 0; g < t.edgeGroupCount; ++g) {
    const WindingEdgeGroup& group = t.edgeGroups[g];
    if (group.hi[0] < lo[0] || group.hi[1] < lo[1] || group.lo[1] > hi[1] || group.hi[2] < lo[2] ||
        group.lo[2] > hi[2])
      continue;
    for (uint32_t i = group.first; i < group.first + group.count; ++i)
      if (windingSheetMeetsBox(t.edges[i], lo, hi)) return true;
  }
  return false;
}

// The threshold from K (at some point) with its rounding `error` and a bound
// `spread` on how far K moves over the points it stands for: true and T when
// 4 pi T + K clears 2 pi from above and 4 pi (T - 1) + K from below over the
// whole range (windingVerdict's margins), so that N >= T decides.
HDT_HD bool windingThresholdFrom(const WindingTreeView& t, double K, double error, double spread, int& T) {
  const double f = 0.5 - K / (4.0 * kWindingPi); // inside iff N >= f(p)
  if (!(fabs(f) < 16384.0) || !(spread < 2.0 * kWindingPi)) return false;
  T = int(ceil(f));
  const double whole = 4.0 * kWindingPi * double(T);
  const double rounding = error + 4.0 * kWindingUlp * (fabs(whole) + fabs(K) + 4.0 * kWindingPi);
  const WindingSum atT{whole + K, rounding + spread, true};
  const WindingSum below{(whole - 4.0 * kWindingPi) + K, rounding + spread, true};
  return windingVerdict(atT, t.triangleCount) == kWindingInside &&
         windingVerdict(below, t.triangleCount) == kWindingOutside;
}

// The threshold of a sheet-free box of points [lo, hi]: true and T when
// every point p of the box with a crossing count N is inside iff N >= T
// (w clear of 1/2 by the margins either way). False when p's K range holds a
// possible tie, K cannot be evaluated at the centre, or an edge meets the box.
// gradient: on entry a bound on |grad K| valid over the box (INFINITY when
// none is known: an enclosing box's bound holds for its parts); on return
// the box's own bound when it was computed (its parts may reuse it). The
// own bound is computed only where the known one cannot decide.
HDT_HD bool windingBoxThreshold(const WindingTreeView& t, const double* lo, const double* hi, int& T,
                                double& gradient) {
  double c[3], reach2 = 0;
  for (int a = 0; a < 3; ++a) {
    c[a] = 0.5 * (lo[a] + hi[a]);
    const double h = 0.5 * (hi[a] - lo[a]);
    reach2 = reach2 + h * h;
  }
  const double reach = sqrt(reach2) * (1 + 1e-12);
  if (t.edgeCount == 0) gradient = 0;
  // A range of 4 pi or more always holds a tie: then the own bound first.
  bool own = false;
  if (!(reach * gradient < 2.0 * kWindingPi)) {
    gradient = windingGradientBound(t, lo, hi);
    own = true;
    if (!(reach * gradient < 2.0 * kWindingPi)) return false;
  }
  double K = 0, error = 0;
  if (!windingStripSum(t, c, K, error)) return false;
  if (windingThresholdFrom(t, K, error, reach * gradient, T)) return true;
  if (own) return false;
  gradient = windingGradientBound(t, lo, hi);
  return windingThresholdFrom(t, K, error, reach * gradient, T);
}

// One voxel centre p with its crossing count N: K at p, else the point
// decision (windingInsideAt).
HDT_HD bool windingInsideWithCount(const WindingTreeView& t, const double* p, int N) {
  double K = 0, error = 0;
  if (windingStripSum(t, p, K, error)) {
    const double whole = 4.0 * kWindingPi * double(N);
    const WindingSum s{whole + K, error + 4.0 * kWindingUlp * (fabs(whole) + fabs(K)), true};
    const int v = windingVerdict(s, t.triangleCount);
    if (v != kWindingUnsure) return v == kWindingInside;
  }
  return windingInsideAt(t, p[0], p[1], p[2]);
}

constexpr int kWindingLeafStack = 64; // 7 per level of 5 halvings, and the root

// ---- near and far edges of one leaf ------------------------------------------
//
// Near an open rim the boxes shrink to about the rim distance, and each box
// paid K from every boundary edge. Split the edges per leaf: near ones (within
// kWindingNearReach leaf edges of the leaf's box, or whose sheet meets it) and
// far ones. No far sheet meets the leaf, so K_far is smooth over it; its
// gradient is the Biot-Savart field of the far edges plus the side rays (toward
// -x) at the vertices where the near part of the chain is open (the rays
// cancel at every other vertex: the whole chain is closed), and the near
// part's gradient is that of the near edges plus the same rays. A ray's field
// is at most 2 / d at distance d (as a segment's, with an infinite length).
// Each box of kWindingAnchorBox^3 voxels evaluates K_far once at its centre;
// its sub-boxes and voxels evaluate only the near edges.
constexpr int kWindingNearEdges = 64;
constexpr int kWindingOpenEnds = 32;
constexpr double kWindingNearReach = 2.0;
constexpr int kWindingAnchorBox = 4;

struct WindingLeafSplit {
  uint32_t near[kWindingNearEdges]; // ascending edge indices
  int nearCount = 0;
  double end[kWindingOpenEnds][3]; // the near part's open vertices
  double endNet[kWindingOpenEnds]; // |net count| there
  int endCount = 0;
};

// A lower bound on the distance from the box [lo, hi] to the ray from v
// toward -x (1e-6 voxels below it for the rounding), <= 0 when they meet.
HDT_HD double windingRayDistance(const double* v, const double* lo, const double* hi) {
  const double gx = lo[0] > v[0] ? lo[0] - v[0] : 0.0;
  const double gy = v[1] < lo[1] ? lo[1] - v[1] : (v[1] > hi[1] ? v[1] - hi[1] : 0.0);
  const double gz = v[2] < lo[2] ? lo[2] - v[2] : (v[2] > hi[2] ? v[2] - hi[2] : 0.0);
  return sqrt(gx * gx + gy * gy + gz * gz) - 1e-6;
}

// The split for the box [lo, hi] (a leaf's voxel centres, edge L voxels);
// false when there are more near edges or open ends than fit.
HDT_HD bool windingSplitEdges(const WindingTreeView& t, const double* lo, const double* hi, int L,
                              WindingLeafSplit& split) {
  double c[3];
  const double rho = windingBoxBall(lo, hi, c), reach = kWindingNearReach * L;
  split.nearCount = split.endCount = 0;
  auto addEnd = [&](const double* v, double net) {
    for (int k = 0; k < split.endCount; ++k)
      if (split.end[k][0] == v[0] && split.end[k][1] == v[1] && split.end[k][2] == v[2]) {
        split.endNet[k] = split.endNet[k] + net;
        return true;
      }
    if (split.endCount == kWindingOpenEnds) return false;
    for (int a = 0; a < 3; ++a) split.end[split.endCount][a] = v[a];
    split.endNet[split.endCount++] = net;
    return true;
  };
  for (uint32_t i = 0; i < t.edgeCount; ++i) {
    const WindingEdge& e = t.edges[i];
    if (!(windingEdgeDistance(e, lo, hi, c, rho) < reach) && !windingSheetMeetsBox(e, lo, hi)) continue;
    if (split.nearCount == kWindingNearEdges) return false;
    split.near[split.nearCount++] = i;
    if (!addEnd(e.a, -e.net) || !addEnd(e.b, e.net)) return false;
  }
  for (int k = 0; k < split.endCount; ++k) split.endNet[k] = fabs(split.endNet[k]);
  return true;
}

// fn(edge) for every edge of the split's far part, in index order (the
// near indices ascend); false, and no further calls, once fn returns false.
template <class Fn>
HDT_HD bool windingForEachFarEdge(const WindingTreeView& t, const WindingLeafSplit& split, Fn&& fn) {
  int k = 0;
  for (uint32_t i = 0; i < t.edgeCount; ++i) {
    if (k < split.nearCount && split.near[k] == i) {
      ++k;
      continue;
    }
    if (!fn(t.edges[i])) return false;
  }
  return true;
}

// The bound on the gradient of K_near (near true) or K_far over the box
// [lo, hi]: INFINITY when one of the part's edges or an open end's ray meets it.
HDT_HD double windingPartGradientBound(const WindingTreeView& t, const WindingLeafSplit& split, bool near,
                                       const double* lo, const double* hi) {
  double c[3];
  const double rho = windingBoxBall(lo, hi, c);
  double total = 0;
  auto add = [&](const WindingEdge& e) {
    const double d = windingEdgeDistance(e, lo, hi, c, rho);
    if (!(d > 0)) return false;
    total = total + windingEdgeBound(e.weight * e.length, e.weight, d);
    return true;
  };
  if (near) {
    for (int k = 0; k < split.nearCount; ++k)
      if (!add(t.edges[split.near[k]])) return INFINITY;
  } else if (!windingForEachFarEdge(t, split, add)) {
    return INFINITY;
  }
  for (int j = 0; j < split.endCount; ++j) {
    if (split.endNet[j] == 0) continue;
    const double d = windingRayDistance(split.end[j], lo, hi);
    if (!(d > 0)) return INFINITY;
    total = total + 2.0 * split.endNet[j] / d;
  }
  return total;
}

// K_near (near true) or K_far at p, with its rounding bound.
HDT_HD bool windingPartStripSum(const WindingTreeView& t, const WindingLeafSplit& split, bool near, const double* p,
                                double& K, double& error) {
  if (near) {
    return windingStripSumOf(uint32_t(split.nearCount),
                             [&](uint32_t i) -> const WindingEdge& { return t.edges[split.near[i]]; }, p, K, error);
  }
  uint32_t cursor = 0;
  int k = 0;
  auto farAt = [&](uint32_t i) -> const WindingEdge& { // called with 0, 1, 2, ... in order
    if (i == 0) {
      cursor = 0;
      k = 0;
    } else {
      ++cursor;
    }
    while (k < split.nearCount && split.near[k] == cursor) {
      ++cursor;
      ++k;
    }
    return t.edges[cursor];
  };
  return windingStripSumOf(t.edgeCount - uint32_t(split.nearCount), farAt, p, K, error);
}

// ---- a leaf's signed crossings --------------------------------------------------

// The sign a crossing of a +x ray with the triangle adds to N: that of the
// normal's x component (0: parallel to x, no ray crosses it).
HDT_HD int windingCrossingSign(const LatticeTriangle& tri) {
  int64_t normal[3];
  triangleNormal(tri, normal);
  return normal[0] > 0 ? 1 : (normal[0] < 0 ? -1 : 0);
}

// fn(i) for every candidate triangle of the leaf at `origin` (voxels; i
// indexes t.lattice): the tree's triangles whose node boxes meet the leaf's
// closed box (a crossing in the leaf lies in it), but those parallel to x.
template <class Fn>
HDT_HD void windingForEachLeafCandidate(const WindingTreeView& t, const int* origin, int L, Fn&& fn) {
  double lo[3], hi[3];
  for (int a = 0; a < 3; ++a) {
    lo[a] = origin[a];
    hi[a] = origin[a] + L;
  }
  uint32_t stack[kWindingStack];
  int top = 0;
  stack[top++] = 0;
  while (top > 0) {
    const WindingNode& n = t.nodes[stack[--top]];
    bool meets = true;
    for (int a = 0; a < 3; ++a) meets = meets && n.lo[a] <= hi[a] && n.hi[a] >= lo[a];
    if (!meets) continue;
    if (n.count == 0) {
      stack[top++] = n.first + 1;
      stack[top++] = n.first;
      continue;
    }
    for (uint32_t i = n.first; i < n.first + n.count; ++i)
      if (windingCrossingSign(t.lattice[i]) != 0) fn(i);
  }
}

// fn(row, before) for the crossings of candidate i with the leaf's rays of
// leaf-relative line dw alone: one line of a pair, for a driver that spreads
// a pair's lines over threads (the CUDA driver's crossings step).
template <class Fn>
HDT_HD void windingForEachPairLineCrossing(const WindingTreeView& t, uint32_t i, const int* origin, int L, int dw,
                                           Fn&& fn) {
  const LatticeTriangle& tri = t.lattice[i];
  const int64_t v0[3] = {origin[0], origin[1], origin[2]};
  int64_t u0, u1, w0, w1;
  const int64_t w = v0[2] + dw;
  if (!pairRayRange(tri, 0, v0, L, u0, u1, w0, w1) || w < w0 || w > w1) return;
  LeafCrossings crossings{};
  bool made = false;
  forEachLineCrossing(tri, 0, v0, L, w, u0, u1, crossings, made, fn);
}

// fn(row, before, sign) for every crossing of a +x ray of the leaf at
// `origin` (voxels) with a triangle inside the leaf's half-open x extent (the
// parity pass's exact crossings, forEachPairCrossing's steps; row = y + L z,
// before = the row's voxel centres strictly before it), sign =
// windingCrossingSign, over the leaf's candidates. Both drivers sum these
// into the counts N that windingDecideLeaf reads (the CUDA driver a pair's
// line at a time, windingForEachPairLineCrossing: the same crossings).
template <class Fn>
HDT_HD void windingForEachLeafCrossing(const WindingTreeView& t, const int* origin, int L, Fn&& fn) {
  const int64_t v0[3] = {origin[0], origin[1], origin[2]};
  windingForEachLeafCandidate(t, origin, L, [&](uint32_t i) {
    const LatticeTriangle& tri = t.lattice[i];
    const int sign = windingCrossingSign(tri);
    forEachPairCrossing(tri, 0, v0, L, [&](int row, int before) { fn(row, before, sign); });
  });
}

// ---- the leaf ------------------------------------------------------------------

// Leaf-local helpers over the output words (surface plane already copied).
struct WindingLeafWords {
  uint32_t* words;
  uint32_t L;
  HDT_HD uint32_t index(int x, int y, int z) const { return uint32_t(x) + L * (uint32_t(y) + L * uint32_t(z)); }
  HDT_HD bool surface(uint32_t v) const { return ((words[v / kVoxelsPerWord] >> (2 * (v % kVoxelsPerWord) + 1)) & 1u) != 0; }
  HDT_HD void setInside(uint32_t v) const { words[v / kVoxelsPerWord] |= 1u << (2 * (v % kVoxelsPerWord)); }
  HDT_HD bool open(const VoxelBox& b) const { // a non-surface voxel to decide
    for (int z = b.lo[2]; z < b.hi[2]; ++z)
      for (int y = b.lo[1]; y < b.hi[1]; ++y)
        for (int x = b.lo[0]; x < b.hi[0]; ++x)
          if (!surface(index(x, y, z))) return true;
    return false;
  }
  HDT_HD void settle(const VoxelBox& b, const int16_t* N, int T) const {
    for (int z = b.lo[2]; z < b.hi[2]; ++z)
      for (int y = b.lo[1]; y < b.hi[1]; ++y)
        for (int x = b.lo[0]; x < b.hi[0]; ++x) {
          const uint32_t v = index(x, y, z);
          if (!surface(v) && int(N[v]) >= T) setInside(v);
        }
  }
};

HDT_HD void windingBoxCentres(const int* origin, const VoxelBox& b, double* lo, double* hi) {
  for (int a = 0; a < 3; ++a) {
    lo[a] = origin[a] + b.lo[a] + 0.5;
    hi[a] = origin[a] + b.hi[a] - 0.5;
  }
}

// Pushes the halves of b: in y and z only when `sheet` and b is wider than
// one row there, along every axis longer than one voxel otherwise; child 0
// (low x, y, z) is taken first.
HDT_HD void windingPushHalves(const VoxelBox& b, bool sheet, VoxelBox* stack, double* known, int& top, double gradient) {
  bool halve[3] = {b.size(0) > 1, b.size(1) > 1, b.size(2) > 1};
  if (sheet && (halve[1] || halve[2])) halve[0] = false;
  for (int k = 7; k >= 0; --k) {
    VoxelBox s = b;
    bool exists = true;
    for (int a = 0; a < 3; ++a) {
      const int mid = b.lo[a] + b.size(a) / 2;
      if ((k >> a) & 1) {
        if (!halve[a]) exists = false;
        s.lo[a] = mid;
      } else if (halve[a]) {
        s.hi[a] = mid;
      }
    }
    if (exists) {
      known[top] = sheet ? INFINITY : gradient;
      stack[top++] = s;
    }
  }
}

// Every box of `start` with K from every edge: a box with no non-surface
// voxel is dropped; one that no sheet meets and whose threshold holds is
// settled; a single voxel takes windingInsideWithCount; otherwise it is
// halved (windingPushHalves; a child first tries its parent's gradient bound).
HDT_HD void windingDecideBoxes(const WindingTreeView& t, const int* origin, const int16_t* N,
                               const WindingLeafWords& w, const VoxelBox& start, double startGradient) {
  VoxelBox stack[kWindingLeafStack];
  double known[kWindingLeafStack]; // a gradient bound over each box (its parent's)
  int top = 0;
  known[top] = startGradient;
  stack[top++] = start;
  while (top > 0) {
    --top;
    const VoxelBox b = stack[top];
    double gradient = known[top];
    if (!w.open(b)) continue;
    double lo[3], hi[3];
    windingBoxCentres(origin, b, lo, hi);
    if (b.single()) {
      const uint32_t v = w.index(b.lo[0], b.lo[1], b.lo[2]);
      if (windingInsideWithCount(t, lo, int(N[v]))) w.setInside(v);
      continue;
    }
    const bool sheet = windingSheetsMeetBox(t, lo, hi);
    int T = 0;
    if (!sheet && windingBoxThreshold(t, lo, hi, T, gradient)) {
      w.settle(b, N, T);
      continue;
    }
    windingPushHalves(b, sheet, stack, known, top, gradient);
  }
}

// One box of an anchored walk: K = K_near (summed here over the split's
// near edges) + K_far, K_far known to farK within farError at the anchor's
// centre and farSpread more over the box. A single voxel is decided at its
// centre; a sheet-free box is settled by one threshold where that holds;
// otherwise its halves are pushed.
HDT_HD void windingAnchoredBoxStep(const WindingTreeView& t, const int16_t* N, const WindingLeafWords& w,
                                   const WindingLeafSplit& split, const VoxelBox& b, const double* lo,
                                   const double* hi, double farK, double farError, double farSpread,
                                   VoxelBox* stack, double* known, int& top) {
  if (b.single()) {
    const uint32_t v = w.index(b.lo[0], b.lo[1], b.lo[2]);
    double nearK = 0, nearError = 0;
    const bool near = windingPartStripSum(t, split, true, lo, nearK, nearError);
    const double whole = 4.0 * kWindingPi * double(N[v]);
    // K_near + K_far at the voxel centre, K_far within farError + farSpread.
    auto verdictWith = [&](double farValue, double farBound) {
      const double K = nearK + farValue;
      const WindingSum s{whole + K,
                         nearError + farBound + 4.0 * kWindingUlp * (fabs(whole) + fabs(nearK) + fabs(farValue) + fabs(K)),
                         true};
      return windingVerdict(s, t.triangleCount);
    };
    int verdict = near ? verdictWith(farK, farError + farSpread) : kWindingUnsure;
    // Unsure by the far part's bound: K_far summed at the centre itself (the
    // near part is known); where that cannot say either (w within the sums'
    // rounding of 1/2, or the centre in a strip's plane, where the sum over
    // every edge would fail too), the point decision.
    double exactFar = 0, exactFarError = 0;
    if (verdict == kWindingUnsure && near && windingPartStripSum(t, split, false, lo, exactFar, exactFarError))
      verdict = verdictWith(exactFar, exactFarError);
    const bool inside = verdict != kWindingUnsure ? verdict == kWindingInside : windingInsideAt(t, lo[0], lo[1], lo[2]);
    if (inside) w.setInside(v);
    return;
  }
  bool sheet = false;
  for (int k = 0; k < split.nearCount && !sheet; ++k) sheet = windingSheetMeetsBox(t.edges[split.near[k]], lo, hi);
  if (!sheet) {
    double c[3], reach2 = 0;
    for (int a = 0; a < 3; ++a) {
      c[a] = 0.5 * (lo[a] + hi[a]);
      reach2 = reach2 + 0.25 * (hi[a] - lo[a]) * (hi[a] - lo[a]);
    }
    const double nearGradient = windingPartGradientBound(t, split, true, lo, hi);
    const double spread = sqrt(reach2) * (1 + 1e-12) * nearGradient + farSpread;
    double nearK = 0, nearError = 0;
    int T = 0;
    if (spread < 2.0 * kWindingPi && windingPartStripSum(t, split, true, c, nearK, nearError)) {
      const double K = nearK + farK;
      const double error = nearError + farError + 4.0 * kWindingUlp * (fabs(nearK) + fabs(farK));
      if (windingThresholdFrom(t, K, error, spread, T)) {
        w.settle(b, N, T);
        return;
      }
    }
  }
  windingPushHalves(b, sheet, stack, known, top, INFINITY);
}

// The boxes of `anchor` (its open ones, halved as windingAnchoredBoxStep
// asks), each with the far part over it from farOverBox(lo, hi, value,
// error, spread): K_far within error of value at the box's centre and
// spread more over the box (the anchored walks' zeroth or first order).
template <class FarOverBox>
HDT_HD void windingWalkAnchor(const WindingTreeView& t, const int* origin, const int16_t* N,
                              const WindingLeafWords& w, const VoxelBox& anchor, const WindingLeafSplit& split,
                              FarOverBox&& farOverBox) {
  VoxelBox stack[kWindingLeafStack];
  double known[kWindingLeafStack]; // unused here: the near bound is cheap
  int top = 0;
  stack[top++] = anchor;
  while (top > 0) {
    const VoxelBox b = stack[--top];
    if (!w.open(b)) continue;
    double lo[3], hi[3];
    windingBoxCentres(origin, b, lo, hi);
    double farK = 0, farError = 0, farSpread = 0;
    farOverBox(lo, hi, farK, farError, farSpread);
    windingAnchoredBoxStep(t, N, w, split, b, lo, hi, farK, farError, farSpread, stack, known, top);
  }
}

// The boxes of `anchor` (at most kWindingAnchorBox^3 voxels) with K_far taken
// once at its centre: K(p) = K_near(p) + K_far(p), K_far(p) within G_far |p -
// centre| of its value there, K_near evaluated per box and bounded over it.
// Where K_far cannot be evaluated at the centre, windingDecideBoxes.
HDT_HD void windingDecideAnchored(const WindingTreeView& t, const int* origin, const int16_t* N,
                                  const WindingLeafWords& w, const VoxelBox& anchor, const WindingLeafSplit& split) {
  if (!w.open(anchor)) return;
  double alo[3], ahi[3], ac[3];
  windingBoxCentres(origin, anchor, alo, ahi);
  for (int a = 0; a < 3; ++a) ac[a] = 0.5 * (alo[a] + ahi[a]);
  double farK = 0, farError = 0;
  const double farGradient = windingPartGradientBound(t, split, false, alo, ahi);
  if (!(farGradient < INFINITY) || !windingPartStripSum(t, split, false, ac, farK, farError)) {
    windingDecideBoxes(t, origin, N, w, anchor, INFINITY);
    return;
  }
  // The farthest distance from the anchor's centre to a point of [lo, hi].
  auto farthest = [&](const double* lo, const double* hi) {
    double s = 0;
    for (int a = 0; a < 3; ++a) {
      const double d = fabs(lo[a] - ac[a]) > fabs(hi[a] - ac[a]) ? fabs(lo[a] - ac[a]) : fabs(hi[a] - ac[a]);
      s = s + d * d;
    }
    return sqrt(s) * (1 + 1e-12);
  };
  windingWalkAnchor(t, origin, N, w, anchor, split,
                    [&](const double* lo, const double* hi, double& value, double& error, double& spread) {
                      value = farK;
                      error = farError;
                      spread = farGradient * farthest(lo, hi);
                    });
}

// What the first step of a leaf's decision leaves to the next ones.
struct WindingLeafStart {
  double lo[3], hi[3]; // the leaf's voxel centres' box
  bool sheet;          // a strip sheet meets it
  double gradient;     // windingBoxThreshold's bound (INFINITY: none)
};

// The first step of windingDecideLeaf: insideWords gets the surface plane,
// then the whole leaf by one threshold where that holds. False when nothing
// is left to decide.
HDT_HD bool windingStartLeaf(const WindingTreeView& t, int L, const int* origin, const uint32_t* surfaceWords,
                             const int16_t* N, uint32_t* insideWords, WindingLeafStart& start) {
  const uint32_t wordCount = leafWordCount(L);
  for (uint32_t i = 0; i < wordCount; ++i) insideWords[i] = surfaceWords[i] & kSurfacePlaneBits;
  const WindingLeafWords w{insideWords, uint32_t(L)};
  const VoxelBox leaf{{0, 0, 0}, {L, L, L}};
  if (!w.open(leaf)) return false;
  windingBoxCentres(origin, leaf, start.lo, start.hi);
  start.sheet = windingSheetsMeetBox(t, start.lo, start.hi);
  start.gradient = INFINITY;
  int T = 0;
  if (!start.sheet && windingBoxThreshold(t, start.lo, start.hi, T, start.gradient)) {
    w.settle(leaf, N, T);
    return false;
  }
  return true;
}

// The last resort of windingDecideLeaf: the leaf's halves by windingDecideBoxes.
HDT_HD void windingDecideLeafHalves(const WindingTreeView& t, const int* origin, const int16_t* N,
                                    const WindingLeafWords& w, int L, const WindingLeafStart& start) {
  VoxelBox halves[8];
  double known[8];
  int count = 0;
  windingPushHalves(VoxelBox{{0, 0, 0}, {L, L, L}}, start.sheet, halves, known, count, start.gradient);
  while (count > 0) {
    --count;
    windingDecideBoxes(t, origin, N, w, halves[count], known[count]);
  }
}

// Decides one leaf of edge L (8, 16 or 32) at `origin` (voxels).
// surfaceWords: the leaf's 2-bit words, read for the surface plane only.
// N: the signed crossing count of the +x ray from each voxel centre (x
// fastest, L^3 values; read at non-surface voxels only), the value
// windingRayCrossings gives there. insideWords (may be surfaceWords): the
// surface plane copied, the inside plane of every non-surface voxel set to
// its verdict (w >= 1/2 at its centre).
//
// The whole leaf first (one K, one gradient bound); when that does not
// decide it and the boundary has many more edges than come near the leaf, its
// boxes of kWindingAnchorBox^3 voxels go by windingDecideAnchored, otherwise
// the leaf by windingDecideBoxes.
HDT_HD void windingDecideLeaf(const WindingTreeView& t, int L, const int* origin, const uint32_t* surfaceWords,
                              const int16_t* N, uint32_t* insideWords) {
  WindingLeafStart start;
  if (!windingStartLeaf(t, L, origin, surfaceWords, N, insideWords, start)) return;
  const WindingLeafWords w{insideWords, uint32_t(L)};
  WindingLeafSplit split;
  if (t.edgeCount > uint32_t(kWindingNearEdges) && windingSplitEdges(t, start.lo, start.hi, L, split) &&
      4 * uint32_t(split.nearCount) < t.edgeCount) {
    const int M = kWindingAnchorBox;
    for (int z = 0; z < L; z += M)
      for (int y = 0; y < L; y += M)
        for (int x = 0; x < L; x += M) windingDecideAnchored(t, origin, N, w, VoxelBox{{x, y, z}, {x + M, y + M, z + M}}, split);
    return;
  }
  windingDecideLeafHalves(t, origin, N, w, L, start);
}

} // namespace hdt
