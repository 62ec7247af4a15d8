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
// of whole rows (yz halves) until each box is sheet free and decided, down to
// single rows; a row that is still not decided takes each voxel on its own
// (K at the voxel centre with N, then windingInsideAt). Every verdict is
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
HDT_HD bool windingBoxThreshold(const WindingTreeView& t, const double* lo, const double* hi, int& T) {
  double c[3], reach2 = 0;
  for (int a = 0; a < 3; ++a) {
    c[a] = 0.5 * (lo[a] + hi[a]);
    const double h = 0.5 * (hi[a] - lo[a]);
    reach2 = reach2 + h * h;
  }
  double K = 0, error = 0;
  if (!windingStripSum(t, c, K, error)) return false;
  double spread = 0;
  if (t.edgeCount > 0) {
    const double gradient = windingGradientBound(t, lo, hi);
    spread = sqrt(reach2) * (1 + 1e-12) * gradient;
    if (!(spread < 2.0 * kWindingPi)) return false; // a range of 4 pi or more always holds a tie
  }
  const double f = 0.5 - K / (4.0 * kWindingPi); // inside iff N >= f(p)
  if (!(fabs(f) < 16384.0)) return false;
  T = int(ceil(f));
  const double whole = 4.0 * kWindingPi * double(T);
  const WindingSum atT{whole + K, error + spread + 4.0 * kWindingUlp * (fabs(whole) + fabs(K)), true};
  const WindingSum below{(whole - 4.0 * kWindingPi) + K, atT.error + 4.0 * kWindingUlp * 4.0 * kWindingPi, true};
  return windingVerdict(atT, t.triangleCount) == kWindingInside &&
         windingVerdict(below, t.triangleCount) == kWindingOutside;
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

// Boxes of whole rows of a leaf: [y0, y1) x [z0, z1) (leaf coordinates).
struct WindingRowBox {
  int y0, y1, z0, z1;
};

constexpr int kWindingRowStack = 64; // 3 per level of 2 x 5 halvings, and the root

// Decides one leaf of edge L (8, 16 or 32) at `origin` (voxels).
// surfaceWords: the leaf's 2-bit words, read for the surface plane only.
// N: the signed crossing count of the +x ray from each voxel centre (x
// fastest, L^3 values; read at non-surface voxels only), the value
// windingRayCrossings gives there. insideWords (may be surfaceWords): the
// surface plane copied, the inside plane of every non-surface voxel set to
// its verdict (w >= 1/2 at its centre).
HDT_HD void windingDecideLeaf(const WindingTreeView& t, int L, const int* origin, const uint32_t* surfaceWords,
                              const int16_t* N, uint32_t* insideWords) {
  const uint32_t wordCount = leafWordCount(L);
  for (uint32_t i = 0; i < wordCount; ++i) insideWords[i] = surfaceWords[i] & kSurfacePlaneBits;
  const uint32_t uL = uint32_t(L);
  auto isSurface = [&](uint32_t v) { return ((insideWords[v / kVoxelsPerWord] >> (2 * (v % kVoxelsPerWord) + 1)) & 1u) != 0; };
  auto setInside = [&](uint32_t v) { insideWords[v / kVoxelsPerWord] |= 1u << (2 * (v % kVoxelsPerWord)); };
  WindingRowBox stack[kWindingRowStack];
  int top = 0;
  stack[top++] = WindingRowBox{0, L, 0, L};
  while (top > 0) {
    const WindingRowBox b = stack[--top];
    bool open = false; // a non-surface voxel to decide
    for (int z = b.z0; z < b.z1 && !open; ++z)
      for (int y = b.y0; y < b.y1 && !open; ++y)
        for (uint32_t x = 0; x < uL && !open; ++x) open = !isSurface(x + uL * (uint32_t(y) + uL * uint32_t(z)));
    if (!open) continue;
    const double lo[3] = {origin[0] + 0.5, origin[1] + b.y0 + 0.5, origin[2] + b.z0 + 0.5};
    const double hi[3] = {origin[0] + L - 0.5, origin[1] + b.y1 - 0.5, origin[2] + b.z1 - 0.5};
    int T = 0;
    if (!windingSheetsMeetBox(t, lo, hi) && windingBoxThreshold(t, lo, hi, T)) {
      for (int z = b.z0; z < b.z1; ++z)
        for (int y = b.y0; y < b.y1; ++y)
          for (uint32_t x = 0; x < uL; ++x) {
            const uint32_t v = x + uL * (uint32_t(y) + uL * uint32_t(z));
            if (!isSurface(v) && int(N[v]) >= T) setInside(v);
          }
      continue;
    }
    const int ny = b.y1 - b.y0, nz = b.z1 - b.z0;
    if (ny == 1 && nz == 1) { // one row: voxel by voxel
      for (uint32_t x = 0; x < uL; ++x) {
        const uint32_t v = x + uL * (uint32_t(b.y0) + uL * uint32_t(b.z0));
        if (isSurface(v)) continue;
        const double p[3] = {origin[0] + double(x) + 0.5, lo[1], lo[2]};
        if (windingInsideWithCount(t, p, int(N[v]))) setInside(v);
      }
      continue;
    }
    const int my = ny > 1 ? b.y0 + ny / 2 : b.y1, mz = nz > 1 ? b.z0 + nz / 2 : b.z1;
    // Pushed so that the low-y, low-z quarter is taken first.
    if (nz > 1 && ny > 1) stack[top++] = WindingRowBox{my, b.y1, mz, b.z1};
    if (nz > 1) stack[top++] = WindingRowBox{b.y0, my, mz, b.z1};
    if (ny > 1) stack[top++] = WindingRowBox{my, b.y1, b.z0, mz};
    stack[top++] = WindingRowBox{b.y0, my, b.z0, mz};
  }
}

} // namespace hdt
