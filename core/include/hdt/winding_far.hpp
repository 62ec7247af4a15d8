// The far part of K to first order: a leaf's anchored boxes (winding_leaf.hpp,
// "near and far edges of one leaf") with K_far(p) = K_far(c) + g . (p - c) + R,
// g the far part's gradient at the anchor's centre c (the Biot-Savart field of
// the far edges and of the side rays at the near part's open ends) and
// |R| <= |p - c| (eps_g + H |p - c| / 2), H a bound on the far field's
// derivative over the anchor and eps_g one on g's rounding. Where the zeroth
// order (windingDecideAnchored) pays G |p - c| for the far part, this pays
// about G |p - c|^2 / d (d >= 2 leaf edges, the far edges' distance), so far
// fewer voxels near a rim need K from every edge. Every verdict is certified
// as before, so the bits equal the brute-force sum's (and the other driver's,
// which may decide the same leaf by windingDecideLeaf).
#pragma once

#include "hdt/winding_leaf.hpp"

#include <cmath>
#include <cstdint>

namespace hdt {

// grad K = kWindingFieldSign * (sum of the chain's Biot-Savart fields); the
// sign is pinned by tests/test_winding_leaf.cpp against K's differences.
constexpr double kWindingFieldSign = 1.0;

// Anchors of 4^3 voxels, as windingDecideAnchored's (8^3 was slower: a box
// still pays |g| times its own reach for the linear term's spread).
constexpr int kWindingLinearAnchorBox = 4;

// coef times the field at p of the edge e (the segment a -> b, unit
// current, no 1 / 4 pi) added to f; err grows by a bound on its rounding. p
// off the segment; g its geometry (windingStripGeometry: a - p, b - p and
// their lengths, which the strip's pair at p shares). (d x ra) is exact for
// lattice coordinates (products of at most 26-bit numbers), the rest a few
// roundings each, bounded generously.
HDT_HD void windingAddSegmentField(const WindingEdge& e, const WindingStripGeometry& g, double coef, double* f,
                                   double& err) {
  double d[3];
  for (int k = 0; k < 3; ++k) d[k] = e.b[k] - e.a[k];
  const double ra[3] = {-g.ax, -g.ay, -g.az}, rb[3] = {-g.bx, -g.by, -g.bz}; // p - a, p - b (exact)
  const double cx = d[1] * ra[2] - d[2] * ra[1], cy = d[2] * ra[0] - d[0] * ra[2], cz = d[0] * ra[1] - d[1] * ra[0];
  const double c2 = cx * cx + cy * cy + cz * cz;
  if (c2 == 0) return; // p on the segment's line, off the segment: no field
  const double fa = (ra[0] * d[0] + ra[1] * d[1] + ra[2] * d[2]) / g.la;
  const double fb = (rb[0] * d[0] + rb[1] * d[1] + rb[2] * d[2]) / g.lb;
  const double s = coef * (fa - fb) / c2;
  f[0] = f[0] + s * cx;
  f[1] = f[1] + s * cy;
  f[2] = f[2] + s * cz;
  err = err + fabs(coef) * 64.0 * kWindingUlp * (e.length + fabs(fa - fb)) / sqrt(c2);
}

// coef times the field at p of the ray from v toward -x (traversed from v
// outward), added to f: (0, r_z, -r_y) / (|r| (|r| + r_x)), r = p - v, in the
// form without cancellation. p off the ray.
HDT_HD void windingAddRayField(const double* v, const double* p, double coef, double* f, double& err) {
  const double rx = p[0] - v[0], ry = p[1] - v[1], rz = p[2] - v[2];
  const double rho2 = ry * ry + rz * rz;
  if (rho2 == 0) return; // on the ray's line ahead of v: no field
  const double r = sqrt(rx * rx + rho2);
  const double q = rx >= 0 ? 1.0 / (r * (r + rx)) : (r - rx) / (r * rho2);
  const double s = coef * q;
  f[1] = f[1] + s * rz;
  f[2] = f[2] + s * (-ry);
  err = err + fabs(s) * 32.0 * kWindingUlp * sqrt(rho2);
}

// Edge e's share of H, the bound on the derivative of the chain's field over
// a box at distance d from it (weight * min(2 len / d^3, 4 / d^2)).
HDT_HD double windingEdgeHessianBound(const WindingEdge& e, double d) {
  const double byLength = 2.0 * e.length / (d * d * d), byDistance = 4.0 / (d * d);
  return e.weight * (byLength < byDistance ? byLength : byDistance);
}

// What the anchors of one leaf share: the near part's ends with their signed
// coefficients (outward rays; the far part's are their negatives: the whole
// chain is closed) and the far edges' part of H over the leaf's box (it holds
// over every anchor in it). The rays' part is taken per anchor: they pass
// close to the leaf.
struct WindingFarLeaf {
  double endCoef[kWindingOpenEnds];
  double edgeHessian;
};

// False when a far edge meets the leaf's box [lo, hi].
HDT_HD bool windingFarLeaf(const WindingTreeView& t, const WindingLeafSplit& split, const double* lo,
                           const double* hi, WindingFarLeaf& f) {
  for (int j = 0; j < split.endCount; ++j) f.endCoef[j] = 0;
  for (int k = 0; k < split.nearCount; ++k) {
    const WindingEdge& e = t.edges[split.near[k]];
    for (int j = 0; j < split.endCount; ++j) {
      if (split.end[j][0] == e.a[0] && split.end[j][1] == e.a[1] && split.end[j][2] == e.a[2]) f.endCoef[j] -= e.net;
      if (split.end[j][0] == e.b[0] && split.end[j][1] == e.b[1] && split.end[j][2] == e.b[2]) f.endCoef[j] += e.net;
    }
  }
  double c[3];
  const double rho = windingBoxBall(lo, hi, c);
  double H = 0;
  const bool clear = windingForEachFarEdge(t, split, [&](const WindingEdge& e) {
    const double d = windingEdgeDistance(e, lo, hi, c, rho);
    if (!(d > 0)) return false;
    H = H + windingEdgeHessianBound(e, d);
    return true;
  });
  f.edgeHessian = H;
  return clear;
}

// The far part of one anchor: K_far at its centre, the gradient there and
// the bounds for the remainder.
struct WindingFarExpansion {
  double c[3];
  double K, error; // K_far(c) and its rounding
  double g[3], gNorm;
  double gError;   // eps_g
  double hessian;  // H over the anchor box
};

// One edge's share of an expansion about x.c: its field added to x.g (its
// rounding to gError) and its factor of K's running product z. strips: 0 the
// product holds, 1 it cannot count its turns (K is then summed edge by edge),
// -1 x.c lies in a strip's plane (no expansion there).
HDT_HD void windingExpansionEdge(const WindingEdge& e, WindingFarExpansion& x, WindingStripRunning& z, int& strips,
                                 double& gError) {
  const WindingStripGeometry geometry = windingStripGeometry(e, x.c);
  windingAddSegmentField(e, geometry, e.net, x.g, gError);
  double det, den, d;
  const int kind = strips == 0 ? windingStripPairOf(e, geometry, det, den, d) : 1;
  if (kind < 0) strips = -1;
  if (kind == 0 && !windingStripProductStep(z, det, den, d, e.net)) strips = 1;
}

// The field's sign, its norm and the bounds, rounded up, once every edge
// and ray is in.
HDT_HD void windingExpansionBounds(WindingFarExpansion& x, double hessian, double gError) {
  for (int a = 0; a < 3; ++a) x.g[a] = kWindingFieldSign * x.g[a];
  x.gNorm = sqrt(x.g[0] * x.g[0] + x.g[1] * x.g[1] + x.g[2] * x.g[2]) * (1 + 1e-12);
  x.gError = gError * (1 + 1e-9) + 1e-300;
  x.hessian = hessian * (1 + 1e-9);
}

// K from the finished product (strips 0), with windingStripSumOf's rounding.
HDT_HD void windingExpansionValue(const WindingStripRunning& z, WindingFarExpansion& x) {
  windingStripProductFinish(z, x.K, x.error);
  x.error = x.error + 4.0 * kWindingUlp * fabs(x.K);
}

// False when the far part is not smooth over [lo, hi] (an edge or a ray meets
// it), K_far cannot be evaluated at c, or there are too many ends.
HDT_HD bool windingFarExpansion(const WindingTreeView& t, const WindingLeafSplit& split, const WindingFarLeaf& f,
                                const double* lo, const double* hi, WindingFarExpansion& x) {
  for (int a = 0; a < 3; ++a) {
    x.c[a] = 0.5 * (lo[a] + hi[a]);
    x.g[a] = 0;
  }
  const double* endCoef = f.endCoef;
  double H = f.edgeHessian, gErr = 0;
  // K_far(c) as windingPartStripSum takes it (one running product), in the
  // same pass as the far edges' field: the two share c's geometry.
  WindingStripRunning z;
  int strips = 0;
  windingForEachFarEdge(t, split, [&](const WindingEdge& e) {
    windingExpansionEdge(e, x, z, strips, gErr);
    return strips >= 0;
  });
  if (strips < 0) return false;
  for (int j = 0; j < split.endCount; ++j) {
    if (endCoef[j] == 0) continue;
    const double d = windingRayDistance(split.end[j], lo, hi);
    if (!(d > 0)) return false;
    H = H + fabs(endCoef[j]) * 4.0 / (d * d);
    windingAddRayField(split.end[j], x.c, -endCoef[j], x.g, gErr);
  }
  windingExpansionBounds(x, H, gErr);
  if (strips == 1) return windingPartStripSum(t, split, false, x.c, x.K, x.error); // edge by edge
  windingExpansionValue(z, x);
  return true;
}

// The whole chain's K to first order about the centre of a box [lo, hi]
// that no sheet meets (windingSheetsMeetBox false: K is smooth over it, and
// with the whole chain no open end's ray enters): K and the chain's field at
// the centre and H over the box, in one pass over the edges. Where the far
// part's expansion needs a leaf's split, this needs none, so one box of a
// breadth-first walk (the device's) can take it on its own. False when an
// edge meets the box or the centre lies in a strip's plane.
HDT_HD bool windingChainExpansion(const WindingTreeView& t, const double* lo, const double* hi,
                                  WindingFarExpansion& x) {
  const double rho = windingBoxBall(lo, hi, x.c);
  for (int a = 0; a < 3; ++a) x.g[a] = 0;
  double H = 0, gErr = 0;
  WindingStripRunning z;
  int strips = 0;
  for (uint32_t i = 0; i < t.edgeCount && strips >= 0; ++i) {
    const WindingEdge& e = t.edges[i];
    const double d = windingEdgeDistance(e, lo, hi, x.c, rho);
    if (!(d > 0)) return false;
    H = H + windingEdgeHessianBound(e, d);
    windingExpansionEdge(e, x, z, strips, gErr);
  }
  if (strips < 0) return false;
  windingExpansionBounds(x, H, gErr);
  if (strips == 1) return windingStripSum(t, x.c, x.K, x.error); // edge by edge
  windingExpansionValue(z, x);
  return true;
}

// K_far over the box [lo, hi] of the anchor: its value at the box centre from
// the expansion (`value`) and how far K_far strays from it over the box.
HDT_HD void windingFarOverBox(const WindingFarExpansion& x, const double* lo, const double* hi, double& value,
                              double& stray) {
  double lin = 0, reach2 = 0, far2 = 0, offset2 = 0;
  for (int a = 0; a < 3; ++a) {
    const double cb = 0.5 * (lo[a] + hi[a]);
    lin = lin + x.g[a] * (cb - x.c[a]);
    offset2 = offset2 + (cb - x.c[a]) * (cb - x.c[a]);
    reach2 = reach2 + 0.25 * (hi[a] - lo[a]) * (hi[a] - lo[a]);
    const double dlo = fabs(lo[a] - x.c[a]), dhi = fabs(hi[a] - x.c[a]);
    far2 = far2 + (dlo > dhi ? dlo : dhi) * (dlo > dhi ? dlo : dhi);
  }
  const double reach = sqrt(reach2) * (1 + 1e-12), farthest = sqrt(far2) * (1 + 1e-12);
  value = x.K + lin;
  stray = x.error + x.gNorm * reach + farthest * (x.gError + 0.5 * x.hessian * farthest) +
          8.0 * kWindingUlp * (fabs(x.K) + fabs(lin) + x.gNorm * sqrt(offset2) * (1 + 1e-12));
}

// Whether the expansion's remainder at the anchor's corners leaves a single
// voxel there any chance: where an open end's ray passes close to the
// anchor, the far part's remainder exceeds pi and every voxel near w = 1/2
// would fall back to K from every edge one by one; windingDecideBoxes (K
// from every edge, but the whole chain's gradient bound, which has no rays)
// settles such anchors in fewer, larger boxes.
HDT_HD bool windingFarExpansionUseful(const WindingFarExpansion& x, const double* lo, const double* hi) {
  double far2 = 0;
  for (int a = 0; a < 3; ++a) far2 = far2 + 0.25 * (hi[a] - lo[a]) * (hi[a] - lo[a]);
  const double r = sqrt(far2);
  return r * (x.gError + 0.5 * x.hessian * r) < kWindingPi;
}

// The verdict at a voxel centre p with crossing count N from an expansion of
// the whole of K (windingChainExpansion over a box holding p): 4 pi N +
// K(c) + g . (p - c), unsure when the remainder's bound leaves it within the
// margins of 2 pi (windingAnchoredBoxStep's single voxel with no near part).
HDT_HD int windingLinearVerdict(const WindingTreeView& t, const WindingFarExpansion& x, const double* p, int N) {
  double K = 0, stray = 0;
  windingFarOverBox(x, p, p, K, stray);
  const double whole = 4.0 * kWindingPi * double(N);
  const WindingSum s{whole + K, stray + 4.0 * kWindingUlp * (fabs(whole) + 2.0 * fabs(K)), true};
  return windingVerdict(s, t.triangleCount);
}

// The anchor as one box (windingAnchoredBoxStep) with the leaf's expansion
// (K_far to first order about the leaf's centre): true when that settles it,
// false when the step would halve it (nothing written then).
HDT_HD bool windingAnchorSettledByLeaf(const WindingTreeView& t, const int16_t* N, const WindingLeafWords& w,
                                       const WindingLeafSplit& split, const VoxelBox& anchor, const double* lo,
                                       const double* hi, const WindingFarExpansion& leaf) {
  VoxelBox halves[8];
  double known[8];
  int count = 0;
  double farK = 0, farStray = 0;
  windingFarOverBox(leaf, lo, hi, farK, farStray);
  windingAnchoredBoxStep(t, N, w, split, anchor, lo, hi, farK, 0.0, farStray, halves, known, count);
  return count == 0;
}

// windingDecideAnchored with the far part to first order: the anchor first
// by the leaf's expansion when there is one (`leaf`, may be null: the
// anchors of a leaf that lie well clear of w = 1/2 need no expansion of
// their own), else by its own expansion about its centre; where that cannot
// be had, windingDecideBoxes (K from every edge).
HDT_HD void windingDecideAnchoredLinear(const WindingTreeView& t, const int* origin, const int16_t* N,
                                        const WindingLeafWords& w, const VoxelBox& anchor,
                                        const WindingLeafSplit& split, const WindingFarLeaf& f,
                                        const WindingFarExpansion* leaf) {
  if (!w.open(anchor)) return;
  double alo[3], ahi[3];
  windingBoxCentres(origin, anchor, alo, ahi);
  if (leaf != nullptr && windingAnchorSettledByLeaf(t, N, w, split, anchor, alo, ahi, *leaf)) return;
  WindingFarExpansion x;
  if (!windingFarExpansion(t, split, f, alo, ahi, x) || !windingFarExpansionUseful(x, alo, ahi)) {
    windingDecideBoxes(t, origin, N, w, anchor, INFINITY);
    return;
  }
  windingWalkAnchor(t, origin, N, w, anchor, split,
                    [&](const double* lo, const double* hi, double& value, double& error, double& spread) {
                      windingFarOverBox(x, lo, hi, value, spread);
                      error = 0.0; // windingFarOverBox's stray holds K_far(c)'s rounding
                    });
}

// windingDecideLeaf with windingDecideAnchoredLinear for the anchored boxes
// (the CPU driver's; the same bits as windingDecideLeaf).
HDT_HD void windingDecideLeafLinear(const WindingTreeView& t, int L, const int* origin, const uint32_t* surfaceWords,
                                    const int16_t* N, uint32_t* insideWords) {
  WindingLeafStart start;
  if (!windingStartLeaf(t, L, origin, surfaceWords, N, insideWords, start)) return;
  const WindingLeafWords w{insideWords, uint32_t(L)};
  WindingLeafSplit split;
  WindingFarLeaf far;
  if (t.edgeCount > uint32_t(kWindingNearEdges) && windingSplitEdges(t, start.lo, start.hi, L, split) &&
      4 * uint32_t(split.nearCount) < t.edgeCount && windingFarLeaf(t, split, start.lo, start.hi, far)) {
    WindingFarExpansion leafExpansion;
    const bool byLeaf = windingFarExpansion(t, split, far, start.lo, start.hi, leafExpansion);
    const int M = kWindingLinearAnchorBox < L ? kWindingLinearAnchorBox : L;
    for (int z = 0; z < L; z += M)
      for (int y = 0; y < L; y += M)
        for (int x = 0; x < L; x += M)
          windingDecideAnchoredLinear(t, origin, N, w, VoxelBox{{x, y, z}, {x + M, y + M, z + M}}, split, far,
                                      byLeaf ? &leafExpansion : nullptr);
    return;
  }
  windingDecideLeafHalves(t, origin, N, w, L, start);
}

} // namespace hdt
