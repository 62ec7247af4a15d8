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

#include "hdt/platform.hpp"
#include "hdt/types.hpp"
#include "hdt/winding.hpp"

#include <cmath>
#include <cstdint>

namespace hdt {

// K at p (voxel units) with its rounding bound: the running product, or edge
// by edge where the product cannot count its turns; false when p lies in a
// strip's plane (or on the line of an edge parallel to x).
HDT_HD bool windingStripSum(const WindingTreeView& t, const double* p, double& K, double& error) {
  const int product = windingStripProduct(t, p, K, error);
  if (product < 0) return false;
  if (product == 0) {
    error = error + 4.0 * kWindingUlp * fabs(K);
    return true;
  }
  double magnitude = 0;
  K = 0;
  error = 0;
  for (uint32_t i = 0; i < t.edgeCount; ++i) {
    const WindingEdge& e = t.edges[i];
    double angle, err;
    if (!windingStripAngle(e, p, angle, err)) return false;
    const double term = e.net * angle;
    K = K + term;
    magnitude = magnitude + fabs(term);
    error = error + e.weight * err;
  }
  error = error + double(t.edgeCount + 16) * 2.3e-16 * magnitude;
  return true;
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
  const double f = 0.5 - K / (4.0 * kWindingPi); // inside iff N >= f(p)
  if (!(fabs(f) < 16384.0)) return false;
  T = int(ceil(f));
  const double whole = 4.0 * kWindingPi * double(T);
  const double rounding = error + 4.0 * kWindingUlp * (fabs(whole) + fabs(K) + 4.0 * kWindingPi);
  auto holds = [&](double spread) {
    const WindingSum atT{whole + K, rounding + spread, true};
    const WindingSum below{(whole - 4.0 * kWindingPi) + K, rounding + spread, true};
    return windingVerdict(atT, t.triangleCount) == kWindingInside &&
           windingVerdict(below, t.triangleCount) == kWindingOutside;
  };
  if (holds(reach * gradient)) return true;
  if (own) return false;
  gradient = windingGradientBound(t, lo, hi);
  return holds(reach * gradient);
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

// Decides one leaf of edge L (8, 16 or 32) at `origin` (voxels).
// surfaceWords: the leaf's 2-bit words, read for the surface plane only.
// N: the signed crossing count of the +x ray from each voxel centre (x
// fastest, L^3 values; read at non-surface voxels only), the value
// windingRayCrossings gives there. insideWords (may be surfaceWords): the
// surface plane copied, the inside plane of every non-surface voxel set to
// its verdict (w >= 1/2 at its centre).
//
// Boxes (leaf coordinates) are taken from a stack: one with no non-surface
// voxel is dropped; one that no sheet meets and whose threshold holds is
// settled; a single voxel takes windingInsideWithCount; otherwise the box is
// halved, in y and z only where a sheet meets it and it is wider than one row
// there (a sheet spans x behind its edge, so halving x rarely frees a part),
// along every axis longer than one voxel otherwise (the gradient bound's
// spread shrinks with the box).
HDT_HD void windingDecideLeaf(const WindingTreeView& t, int L, const int* origin, const uint32_t* surfaceWords,
                              const int16_t* N, uint32_t* insideWords) {
  const uint32_t wordCount = leafWordCount(L);
  for (uint32_t i = 0; i < wordCount; ++i) insideWords[i] = surfaceWords[i] & kSurfacePlaneBits;
  const uint32_t uL = uint32_t(L);
  auto isSurface = [&](uint32_t v) { return ((insideWords[v / kVoxelsPerWord] >> (2 * (v % kVoxelsPerWord) + 1)) & 1u) != 0; };
  auto setInside = [&](uint32_t v) { insideWords[v / kVoxelsPerWord] |= 1u << (2 * (v % kVoxelsPerWord)); };
  auto index = [&](int x, int y, int z) { return uint32_t(x) + uL * (uint32_t(y) + uL * uint32_t(z)); };
  VoxelBox stack[kWindingLeafStack];
  double known[kWindingLeafStack]; // a gradient bound over each box (its parent's)
  int top = 0;
  known[top] = INFINITY;
  stack[top++] = VoxelBox{{0, 0, 0}, {L, L, L}};
  while (top > 0) {
    --top;
    const VoxelBox b = stack[top];
    double gradient = known[top];
    bool open = false; // a non-surface voxel to decide
    for (int z = b.lo[2]; z < b.hi[2] && !open; ++z)
      for (int y = b.lo[1]; y < b.hi[1] && !open; ++y)
        for (int x = b.lo[0]; x < b.hi[0] && !open; ++x) open = !isSurface(index(x, y, z));
    if (!open) continue;
    double lo[3], hi[3];
    for (int a = 0; a < 3; ++a) {
      lo[a] = origin[a] + b.lo[a] + 0.5;
      hi[a] = origin[a] + b.hi[a] - 0.5;
    }
    if (b.single()) {
      const uint32_t v = index(b.lo[0], b.lo[1], b.lo[2]);
      if (windingInsideWithCount(t, lo, int(N[v]))) setInside(v);
      continue;
    }
    const bool sheet = windingSheetsMeetBox(t, lo, hi);
    int T = 0;
    if (!sheet && windingBoxThreshold(t, lo, hi, T, gradient)) {
      for (int z = b.lo[2]; z < b.hi[2]; ++z)
        for (int y = b.lo[1]; y < b.hi[1]; ++y)
          for (int x = b.lo[0]; x < b.hi[0]; ++x) {
            const uint32_t v = index(x, y, z);
            if (!isSurface(v) && int(N[v]) >= T) setInside(v);
          }
      continue;
    }
    bool halve[3] = {b.size(0) > 1, b.size(1) > 1, b.size(2) > 1};
    if (sheet && (halve[1] || halve[2])) halve[0] = false;
    for (int k = 7; k >= 0; --k) { // child 0 (low x, y, z) is taken first
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
}

} // namespace hdt
