// The test oracle. Written from the definitions in reference_voxelizer.hpp,
// independently of core/include/hdt/geometry.hpp and build_steps.hpp (do not
// include them here): clarity over speed, exact integers throughout.
#include "support/reference_voxelizer.hpp"

#include <algorithm>
#include <sstream>
#include <stdexcept>

namespace hdt {
namespace test {
namespace {

using i128 = __int128;
constexpr int64_t kUnit = int64_t(1) << kLatticeBits; // lattice units per voxel (256)
constexpr int64_t kHalf = kUnit / 2;

int sign128(i128 v) { return v > 0 ? 1 : (v < 0 ? -1 : 0); }

// floor(a / b) for b > 0 and any a.
int64_t floorDiv(int64_t a, int64_t b) { return a >= 0 ? a / b : -((-a + b - 1) / b); }
int64_t ceilDiv(int64_t a, int64_t b) { return -floorDiv(-a, b); }

void cross(const int64_t (&a)[3], const int64_t (&b)[3], int64_t (&r)[3]) {
  r[0] = a[1] * b[2] - a[2] * b[1];
  r[1] = a[2] * b[0] - a[0] * b[2];
  r[2] = a[0] * b[1] - a[1] * b[0];
}

i128 dot(const int64_t (&axis)[3], int64_t x, int64_t y, int64_t z) {
  return i128(axis[0]) * x + i128(axis[1]) * y + i128(axis[2]) * z;
}

// True when `axis` strictly separates the triangle from the box [lo, hi]:
// project all 3 vertices and all 8 corners and compare the intervals.
bool separates(const int64_t (&axis)[3], const LatticeTriangle& t, const int64_t (&lo)[3],
               const int64_t (&hi)[3]) {
  i128 tmin = 0, tmax = 0, bmin = 0, bmax = 0;
  for (int v = 0; v < 3; ++v) {
    const i128 p = dot(axis, t.v[v][0], t.v[v][1], t.v[v][2]);
    if (v == 0 || p < tmin) tmin = p;
    if (v == 0 || p > tmax) tmax = p;
  }
  for (int c = 0; c < 8; ++c) {
    const i128 p = dot(axis, (c & 1) ? hi[0] : lo[0], (c & 2) ? hi[1] : lo[1], (c & 4) ? hi[2] : lo[2]);
    if (c == 0 || p < bmin) bmin = p;
    if (c == 0 || p > bmax) bmax = p;
  }
  return tmax < bmin || bmax < tmin;
}

// Voxels [first, last] whose closed boxes [256 i, 256 (i+1)] meet [lo, hi], clamped.
void voxelRange(int64_t lo, int64_t hi, int n, int& first, int& last) {
  const int64_t f = ceilDiv(lo, kUnit) - 1, l = floorDiv(hi, kUnit);
  first = int(std::max<int64_t>(f, 0));
  last = int(std::min<int64_t>(l, n - 1));
}

// Rows [first, last] whose centre 256 j + 128 lies in [lo, hi], clamped.
void centreRange(int64_t lo, int64_t hi, int n, int& first, int& last) {
  const int64_t f = ceilDiv(lo - kHalf, kUnit), l = floorDiv(hi - kHalf, kUnit);
  first = int(std::max<int64_t>(f, 0));
  last = int(std::min<int64_t>(l, n - 1));
}

// Marks the surface voxels of one triangle inside the voxel block [lo, hi]
// (inclusive). Large blocks are culled with the same exact test on the
// block's closed box (a voxel's box is a subset of it) and split in two.
void markSurface(const LatticeTriangle& t, const int (&lo)[3], const int (&hi)[3], ReferenceVoxels& ref) {
  int64_t count = 1;
  for (int a = 0; a < 3; ++a) {
    if (hi[a] < lo[a]) return;
    count *= hi[a] - lo[a] + 1;
  }
  if (count > 8) {
    const int64_t blo[3] = {lo[0] * kUnit, lo[1] * kUnit, lo[2] * kUnit};
    const int64_t bhi[3] = {(hi[0] + 1) * kUnit, (hi[1] + 1) * kUnit, (hi[2] + 1) * kUnit};
    if (!refBoxMeetsTriangle(t, blo, bhi)) return;
    int axis = 0;
    for (int a = 1; a < 3; ++a)
      if (hi[a] - lo[a] > hi[axis] - lo[axis]) axis = a;
    const int mid = lo[axis] + (hi[axis] - lo[axis]) / 2;
    int hiA[3] = {hi[0], hi[1], hi[2]}, loB[3] = {lo[0], lo[1], lo[2]};
    hiA[axis] = mid;
    loB[axis] = mid + 1;
    markSurface(t, lo, hiA, ref);
    markSurface(t, loB, hi, ref);
    return;
  }
  for (int z = lo[2]; z <= hi[2]; ++z)
    for (int y = lo[1]; y <= hi[1]; ++y)
      for (int x = lo[0]; x <= hi[0]; ++x) {
        const int64_t vlo[3] = {x * kUnit, y * kUnit, z * kUnit};
        const int64_t vhi[3] = {vlo[0] + kUnit, vlo[1] + kUnit, vlo[2] + kUnit};
        if (refBoxMeetsTriangle(t, vlo, vhi)) ref.state[ref.index(x, y, z)] = uint8_t(VoxelState::Surface);
      }
}

// Number of voxel centres 256 i + 128 (0 <= i < n) strictly before num / den.
int centresBefore(i128 num, int64_t den, int n) {
  int lo = 0, hi = n; // answer in [lo, hi]
  while (lo < hi) {
    const int mid = lo + (hi - lo) / 2; // is centre `mid` before the crossing?
    if (i128(int64_t(mid) * kUnit + kHalf) * den < num)
      lo = mid + 1;
    else
      hi = mid;
  }
  return lo;
}

// Parity bit `axis` of every voxel: crossings strictly beyond its centre.
void computeParity(const PreparedMesh& mesh, int axis, ReferenceVoxels& ref) {
  const int n = ref.n;
  const int U = (axis + 1) % 3, W = (axis + 2) % 3;
  // toggle[row * n + k] flips the parity of the voxels 0..k of the row: a
  // crossing with k + 1 centres before it.
  std::vector<uint8_t> toggle(size_t(n) * n * n, 0);
  for (const LatticeTriangle& t : mesh.triangles) {
    int64_t lo[3], hi[3];
    for (int a = 0; a < 3; ++a) {
      lo[a] = std::min({t.v[0][a], t.v[1][a], t.v[2][a]});
      hi[a] = std::max({t.v[0][a], t.v[1][a], t.v[2][a]});
    }
    // A perturbed point strictly inside the projection lies in its closed
    // bounding rectangle, so rows outside it cannot hit.
    int u0, u1, w0, w1;
    centreRange(lo[U], hi[U], n, u0, u1);
    centreRange(lo[W], hi[W], n, w0, w1);
    for (int w = w0; w <= w1; ++w)
      for (int u = u0; u <= u1; ++u) {
        i128 num;
        int64_t den;
        if (!refRayCrossing(t, axis, int64_t(u) * kUnit + kHalf, int64_t(w) * kUnit + kHalf, num, den)) continue;
        const int before = centresBefore(num, den, n);
        if (before > 0) toggle[(size_t(u) + size_t(n) * size_t(w)) * n + size_t(before - 1)] ^= 1u;
      }
  }
  for (int w = 0; w < n; ++w)
    for (int u = 0; u < n; ++u) {
      const uint8_t* row = &toggle[(size_t(u) + size_t(n) * size_t(w)) * n];
      uint8_t acc = 0;
      for (int i = n - 1; i >= 0; --i) {
        acc ^= row[i];
        int c[3];
        c[axis] = i;
        c[U] = u;
        c[W] = w;
        if (acc) ref.parity[ref.index(c[0], c[1], c[2])] |= uint8_t(1u << axis);
      }
    }
}

} // namespace

// ---- primitives ---------------------------------------------------------------------

bool refBoxMeetsTriangle(const LatticeTriangle& t, const int64_t (&lo)[3], const int64_t (&hi)[3]) {
  // The 13 candidate axes of two convex polytopes: the box's 3 face normals,
  // the triangle's normal and the 9 cross products of their edge directions.
  // Disjoint compact convex sets are strictly separated along one of them; a
  // zero axis (parallel edges) separates nothing, which is right.
  int64_t e[3][3];
  for (int j = 0; j < 3; ++j)
    for (int a = 0; a < 3; ++a) e[j][a] = int64_t(t.v[(j + 1) % 3][a]) - t.v[j][a];
  static const int64_t unit[3][3] = {{1, 0, 0}, {0, 1, 0}, {0, 0, 1}};
  for (int a = 0; a < 3; ++a)
    if (separates(unit[a], t, lo, hi)) return false;
  int64_t normal[3];
  cross(e[0], e[1], normal);
  if (separates(normal, t, lo, hi)) return false;
  for (int a = 0; a < 3; ++a)
    for (int j = 0; j < 3; ++j) {
      int64_t axis[3];
      cross(unit[a], e[j], axis);
      if (separates(axis, t, lo, hi)) return false;
    }
  return true;
}

int refOrientPerturbed(int64_t au, int64_t aw, int64_t bu, int64_t bw, int64_t pu, int64_t pw) {
  // orient(A, B, P') with P' = (pu + eps, pw + eps^2)
  //   = o + eps * (-(bw - aw)) + eps^2 * (bu - au)
  const i128 o = i128(bu - au) * (pw - aw) - i128(bw - aw) * (pu - au);
  if (o != 0) return sign128(o);
  const int64_t epsCoefficient = -(bw - aw);
  if (epsCoefficient != 0) return epsCoefficient > 0 ? 1 : -1;
  const int64_t eps2Coefficient = bu - au;
  if (eps2Coefficient != 0) return eps2Coefficient > 0 ? 1 : -1;
  return 0;
}

bool refRayCrossing(const LatticeTriangle& t, int axis, int64_t pu, int64_t pw, i128& num, int64_t& den) {
  const int U = (axis + 1) % 3, W = (axis + 2) % 3;
  int s[3];
  for (int j = 0; j < 3; ++j) {
    const int k = (j + 1) % 3;
    s[j] = refOrientPerturbed(t.v[j][U], t.v[j][W], t.v[k][U], t.v[k][W], pu, pw);
  }
  if (s[0] == 0 || s[0] != s[1] || s[1] != s[2]) return false;
  int64_t e1[3], e2[3], nrm[3];
  for (int a = 0; a < 3; ++a) {
    e1[a] = int64_t(t.v[1][a]) - t.v[0][a];
    e2[a] = int64_t(t.v[2][a]) - t.v[0][a];
  }
  cross(e1, e2, nrm);
  // n . (X - v0) = 0 with X = (t along axis, pu, pw).
  num = i128(nrm[axis]) * t.v[0][axis] - i128(nrm[U]) * (pu - t.v[0][U]) - i128(nrm[W]) * (pw - t.v[0][W]);
  den = nrm[axis];
  // Strictly inside a projection implies a non-degenerate projection, whose
  // doubled area is exactly nrm[axis].
  if (den == 0) throw std::logic_error("reference: ray hit a triangle whose projection is degenerate");
  if (den < 0) {
    num = -num;
    den = -den;
  }
  return true;
}

// ---- the reference volume -----------------------------------------------------------------

ReferenceVoxels referenceVoxelize(const PreparedMesh& mesh, bool surfaceOnly) {
  ReferenceVoxels ref;
  ref.n = mesh.grid.resolution;
  ref.closed = mesh.closed;
  ref.surfaceOnly = surfaceOnly;
  if (ref.n < 1 || ref.n > 1024) throw std::invalid_argument("reference voxelizer: N must be in [1, 1024]");
  const int n = ref.n;
  ref.state.assign(size_t(n) * n * n, uint8_t(VoxelState::Outside));
  ref.parity.assign(ref.state.size(), 0);

  for (const LatticeTriangle& t : mesh.triangles) {
    int lo[3], hi[3];
    for (int a = 0; a < 3; ++a) {
      const int64_t mn = std::min({t.v[0][a], t.v[1][a], t.v[2][a]});
      const int64_t mx = std::max({t.v[0][a], t.v[1][a], t.v[2][a]});
      voxelRange(mn, mx, n, lo[a], hi[a]);
    }
    markSurface(t, lo, hi, ref);
  }

  if (!surfaceOnly)
    for (int axis = 0; axis < 3; ++axis) computeParity(mesh, axis, ref);

  for (int z = 0; z < n; ++z)
    for (int y = 0; y < n; ++y)
      for (int x = 0; x < n; ++x) {
        const size_t i = ref.index(x, y, z);
        if (ref.state[i] == uint8_t(VoxelState::Surface)) {
          ++ref.surfaceCount;
          continue;
        }
        if (surfaceOnly) continue;
        const uint8_t p = ref.parity[i];
        if (p != 0 && p != 7) {
          if (ref.axisDisagreements++ == 0) {
            std::ostringstream s;
            s << "voxel (" << x << "," << y << "," << z << ") parities x=" << (p & 1) << " y=" << ((p >> 1) & 1)
              << " z=" << ((p >> 2) & 1);
            ref.firstDisagreement = s.str();
          }
        }
        const int votes = (p & 1) + ((p >> 1) & 1) + ((p >> 2) & 1);
        const bool inside = mesh.closed ? (p & 1) != 0 : votes >= 2;
        if (inside) {
          ref.state[i] = uint8_t(VoxelState::Inside);
          ++ref.insideCount;
        }
      }
  return ref;
}

// ---- walking a volume -------------------------------------------------------------------------

const char* stateName(VoxelState s) {
  switch (s) {
  case VoxelState::Outside: return "Outside";
  case VoxelState::Inside: return "Inside";
  case VoxelState::Surface: return "Surface";
  }
  return "Invalid(3)";
}

const char* stateName(ElementState s) {
  switch (s) {
  case ElementState::Empty: return "Empty";
  case ElementState::Full: return "Full";
  case ElementState::Branch: return "Branch";
  case ElementState::Boundary: return "Boundary";
  }
  return "?";
}

namespace {

std::string describeElement(const ElementInfo& e) {
  std::ostringstream s;
  s << "level " << e.level << " element #" << e.index << " cell (" << e.cell[0] << "," << e.cell[1] << ","
    << e.cell[2] << ") [" << stateName(e.state) << ", voxels (" << e.voxel(0) << "," << e.voxel(1) << ","
    << e.voxel(2) << ")+" << e.edge << "]";
  return s.str();
}

struct Problems {
  std::vector<std::string>& out;
  size_t total = 0;
  void add(const std::string& m) {
    if (total++ < 20) out.push_back(m);
  }
};

} // namespace

TreeView walkVolume(const Volume& v) {
  TreeView tv;
  Problems problems{tv.problems};
  const GridSpec& g = v.grid;
  const int R = g.rootGrid, L = g.leafSize, h = g.height;
  tv.n = g.resolution;
  if (R < 1 || (L != 8 && L != 16 && L != 32) || h < 0 || h > 16 ||
      int64_t(R) * (int64_t(1) << h) * L != g.resolution || g.resolution > 1024) {
    std::ostringstream s;
    s << "grid spec is inconsistent or too large to walk: N=" << g.resolution << " R=" << R << " L=" << L
      << " height=" << h;
    problems.add(s.str());
    return tv;
  }
  const int n = g.resolution;
  const uint64_t roots = uint64_t(R) * R * R;
  const size_t levels = size_t(h) + 1;
  if (v.levelStart.size() != levels + 1) {
    problems.add("levelStart has " + std::to_string(v.levelStart.size()) + " entries, expected height + 2 = " +
                 std::to_string(levels + 1));
    return tv;
  }
  if (v.levelStart[0] != 0) problems.add("levelStart[0] = " + std::to_string(v.levelStart[0]) + ", expected 0");
  if (v.levelStart[1] != roots)
    problems.add("levelStart[1] = " + std::to_string(v.levelStart[1]) + ", expected R^3 = " + std::to_string(roots));
  if (v.levelStart.back() != v.elements.size())
    problems.add("levelStart.back() = " + std::to_string(v.levelStart.back()) + " but there are " +
                 std::to_string(v.elements.size()) + " elements");
  for (size_t k = 0; k + 1 < v.levelStart.size(); ++k)
    if (v.levelStart[k + 1] < v.levelStart[k]) problems.add("levelStart decreases at " + std::to_string(k));
  const uint32_t wordsPerLeaf = leafWordCount(L);
  if (v.leafWords.size() % wordsPerLeaf != 0)
    problems.add("leafWords.size() = " + std::to_string(v.leafWords.size()) + " is not a multiple of " +
                 std::to_string(wordsPerLeaf));
  if (!tv.problems.empty()) return tv;

  const uint64_t leafCount = v.leafWords.size() / wordsPerLeaf;
  std::vector<uint8_t> leafUsed(leafCount, 0);
  constexpr uint8_t kUnset = 0xFF;
  tv.dense.assign(size_t(n) * n * n, kUnset);
  auto fillBox = [&](const ElementInfo& e, VoxelState s) {
    for (int z = e.voxel(2); z < e.voxel(2) + e.edge; ++z)
      for (int y = e.voxel(1); y < e.voxel(1) + e.edge; ++y)
        std::fill_n(&tv.dense[size_t(e.voxel(0)) + size_t(n) * (size_t(y) + size_t(n) * size_t(z))], e.edge,
                    uint8_t(s));
  };

  std::vector<ElementInfo> current(roots);
  for (uint64_t i = 0; i < roots; ++i) {
    ElementInfo& e = current[i];
    e.index = i;
    e.level = 0;
    e.cell[0] = int(i % R);
    e.cell[1] = int((i / R) % R);
    e.cell[2] = int(i / (uint64_t(R) * R));
    e.edge = g.rootCellVoxels();
  }
  uint64_t boundaryOrdinal = 0;
  // An order violation shifts everything after it: report the first only.
  int leafOrderReported = 0;
  for (int k = 0; k <= h; ++k) {
    const uint64_t start = v.levelStart[k], end = v.levelStart[k + 1];
    if (current.size() != end - start) {
      problems.add("level " + std::to_string(k) + " holds " + std::to_string(end - start) +
                   " elements but its parents own " + std::to_string(current.size()));
      return tv;
    }
    const bool last = k == h;
    const uint64_t nextStart = last ? 0 : v.levelStart[k + 1], nextEnd = last ? 0 : v.levelStart[k + 2];
    std::vector<ElementInfo> next(nextEnd - nextStart);
    std::vector<uint8_t> claimed(next.size(), 0);
    uint64_t branchOrdinal = 0;
    int branchOrderReported = 0;
    for (uint64_t i = 0; i < current.size(); ++i) {
      ElementInfo e = current[i];
      e.index = start + i;
      const ElementWord w = v.elements[e.index];
      e.state = elementState(w);
      const uint32_t payload = elementPayload(w);
      tv.elements.push_back(e);
      switch (e.state) {
      case ElementState::Empty:
      case ElementState::Full:
        if (payload != 0)
          problems.add(describeElement(e) + " carries payload " + std::to_string(payload) +
                       " (uniform elements carry 0: the bytes must be canonical)");
        fillBox(e, e.state == ElementState::Full ? VoxelState::Inside : VoxelState::Outside);
        break;
      case ElementState::Branch: {
        if (last) {
          problems.add(describeElement(e) + " is a Branch at the last level");
          break;
        }
        const uint64_t expected = nextStart + 8 * branchOrdinal++;
        if (payload != expected && !branchOrderReported++)
          problems.add(describeElement(e) + " has children at " + std::to_string(payload) +
                       ", canonical breadth-first order puts them at " + std::to_string(expected) +
                       " (first violation on this level)");
        if (payload < nextStart || uint64_t(payload) + 8 > nextEnd || (payload - nextStart) % 8 != 0) {
          problems.add(describeElement(e) + " has child block " + std::to_string(payload) + " outside level " +
                       std::to_string(k + 1) + " [" + std::to_string(nextStart) + ", " + std::to_string(nextEnd) +
                       ") or misaligned");
          break;
        }
        for (int c = 0; c < 8; ++c) {
          const uint64_t j = payload - nextStart + c;
          if (claimed[j]++) {
            problems.add("element #" + std::to_string(payload + c) + " is claimed by two parents");
            continue;
          }
          ElementInfo& child = next[j];
          child.level = k + 1;
          child.edge = e.edge / 2;
          child.cell[0] = 2 * e.cell[0] + (c & 1);
          child.cell[1] = 2 * e.cell[1] + ((c >> 1) & 1);
          child.cell[2] = 2 * e.cell[2] + ((c >> 2) & 1);
        }
        break;
      }
      case ElementState::Boundary: {
        if (!last) {
          problems.add(describeElement(e) + " is a Boundary above the last level");
          break;
        }
        if (payload != boundaryOrdinal && !leafOrderReported++)
          problems.add(describeElement(e) + " uses leaf " + std::to_string(payload) +
                       ", canonical order (leaves in element order) says " + std::to_string(boundaryOrdinal) +
                       " (first violation; later ones not listed)");
        ++boundaryOrdinal;
        if (payload >= leafCount) {
          problems.add(describeElement(e) + " uses leaf " + std::to_string(payload) + " of " +
                       std::to_string(leafCount));
          break;
        }
        if (leafUsed[payload]++) problems.add("leaf " + std::to_string(payload) + " is used by two elements");
        const uint32_t* words = v.leaf(payload);
        bool reported = false;
        for (int z = 0; z < L; ++z)
          for (int y = 0; y < L; ++y)
            for (int x = 0; x < L; ++x) {
              const VoxelState s = leafVoxel(words, L, x, y, z);
              if (uint8_t(s) == 3 && !reported) {
                problems.add(describeElement(e) + " leaf " + std::to_string(payload) + " voxel (" +
                             std::to_string(x) + "," + std::to_string(y) + "," + std::to_string(z) +
                             ") has the invalid 2-bit value 3");
                reported = true;
              }
              tv.dense[size_t(e.voxel(0) + x) + size_t(n) * (size_t(e.voxel(1) + y) + size_t(n) * size_t(e.voxel(2) + z))] =
                  uint8_t(s);
            }
        break;
      }
      }
    }
    if (!last) {
      for (size_t j = 0; j < next.size(); ++j)
        if (!claimed[j]) {
          problems.add("element #" + std::to_string(nextStart + j) + " of level " + std::to_string(k + 1) +
                       " has no parent");
          return tv;
        }
      current.swap(next);
    }
  }
  tv.boundaryCount = boundaryOrdinal;
  for (uint64_t l = 0; l < leafCount; ++l)
    if (!leafUsed[l]) {
      problems.add("leaf " + std::to_string(l) + " of " + std::to_string(leafCount) + " is used by no element");
      break;
    }
  for (size_t i = 0; i < tv.dense.size(); ++i) {
    const uint8_t s = tv.dense[i];
    if (s == kUnset) {
      problems.add("voxel #" + std::to_string(i) + " is covered by no element");
      break;
    }
    tv.surfaceVoxels += s == uint8_t(VoxelState::Surface);
    tv.insideVoxels += s == uint8_t(VoxelState::Inside);
  }
  return tv;
}

std::string describeVoxel(const Volume& v, int x, int y, int z) {
  const GridSpec& g = v.grid;
  std::ostringstream s;
  int edge = g.rootCellVoxels();
  const int R = g.rootGrid;
  int cell[3] = {x / edge, y / edge, z / edge};
  uint64_t index = uint64_t(cell[0]) + uint64_t(R) * (uint64_t(cell[1]) + uint64_t(R) * uint64_t(cell[2]));
  for (int level = 0;; ++level) {
    if (index >= v.elements.size()) {
      s << "level " << level << " element #" << index << " out of range";
      return s.str();
    }
    const ElementWord w = v.elements[index];
    s << "level " << level << " element #" << index << " cell (" << cell[0] << "," << cell[1] << "," << cell[2]
      << ") " << stateName(elementState(w));
    if (elementState(w) == ElementState::Boundary) {
      s << " leaf #" << elementPayload(w) << " leaf voxel (" << x % g.leafSize << "," << y % g.leafSize << ","
        << z % g.leafSize << ")";
      return s.str();
    }
    if (elementState(w) != ElementState::Branch || edge <= 1) return s.str();
    s << " -> ";
    edge /= 2;
    const int c = ((x / edge) & 1) | (((y / edge) & 1) << 1) | (((z / edge) & 1) << 2);
    for (int a = 0; a < 3; ++a) cell[a] = 2 * cell[a] + ((c >> a) & 1);
    index = uint64_t(elementPayload(w)) + uint64_t(c);
  }
}

::testing::AssertionResult volumeMatchesReference(const Volume& v, const TreeView& view, const ReferenceVoxels& ref) {
  std::vector<std::string> lines;
  size_t failures = 0;
  auto fail = [&](const std::string& m) {
    if (failures++ < 12) lines.push_back(m);
  };
  auto finish = [&]() {
    if (failures == 0) return ::testing::AssertionSuccess();
    auto r = ::testing::AssertionFailure();
    r << failures << " problem(s):";
    for (const std::string& l : lines) r << "\n  " << l;
    if (failures > lines.size()) r << "\n  ... and " << failures - lines.size() << " more";
    return r;
  };

  for (const std::string& p : view.problems) fail("structure: " + p);
  if (!view.problems.empty()) return finish();
  if (view.n != ref.n) {
    fail("resolution " + std::to_string(view.n) + " vs reference " + std::to_string(ref.n));
    return finish();
  }
  if (v.surfaceOnly != ref.surfaceOnly)
    fail(std::string("volume.surfaceOnly = ") + (v.surfaceOnly ? "true" : "false") + " but the reference is " +
         (ref.surfaceOnly ? "surface-only" : "solid"));
  const int n = ref.n;
  auto voxelLine = [&](int x, int y, int z, VoxelState expected, VoxelState actual) {
    std::ostringstream s;
    const uint8_t p = ref.parity[ref.index(x, y, z)];
    s << "voxel (" << x << "," << y << "," << z << "): expected " << stateName(expected) << ", got "
      << stateName(actual);
    if (!ref.surfaceOnly) s << " (reference parities x=" << (p & 1) << " y=" << ((p >> 1) & 1) << " z=" << ((p >> 2) & 1) << ")";
    s << " in " << describeVoxel(v, x, y, z);
    return s.str();
  };

  // Element level: touched <=> holds a reference surface voxel; uniform
  // elements take the reference state of their lowest-corner voxel.
  for (const ElementInfo& e : view.elements) {
    int found[3] = {-1, -1, -1};
    for (int z = e.voxel(2); z < e.voxel(2) + e.edge && found[0] < 0; ++z)
      for (int y = e.voxel(1); y < e.voxel(1) + e.edge && found[0] < 0; ++y)
        for (int x = e.voxel(0); x < e.voxel(0) + e.edge; ++x)
          if (ref.at(x, y, z) == VoxelState::Surface) {
            found[0] = x, found[1] = y, found[2] = z;
            break;
          }
    const bool touched = found[0] >= 0;
    if (e.state == ElementState::Branch || e.state == ElementState::Boundary) {
      if (!touched) fail(describeElement(e) + ": no triangle meets its box (the reference has no surface voxel in it)");
      continue;
    }
    if (touched) {
      std::ostringstream s;
      s << describeElement(e) << ": a triangle meets its box (reference surface voxel (" << found[0] << ","
        << found[1] << "," << found[2] << ")) but it is uniform";
      fail(s.str());
      continue;
    }
    const VoxelState corner = ref.at(e.voxel(0), e.voxel(1), e.voxel(2));
    const ElementState expected = corner == VoxelState::Inside ? ElementState::Full : ElementState::Empty;
    if (e.state != expected) {
      const uint8_t p = ref.parity[ref.index(e.voxel(0), e.voxel(1), e.voxel(2))];
      std::ostringstream s;
      s << describeElement(e) << ": expected " << stateName(expected) << " (reference lowest-corner voxel is "
        << stateName(corner) << ", parities x=" << (p & 1) << " y=" << ((p >> 1) & 1) << " z=" << ((p >> 2) & 1)
        << ")";
      fail(s.str());
    }
  }

  // Voxel level.
  if (ref.closed || ref.surfaceOnly) {
    for (int z = 0; z < n; ++z)
      for (int y = 0; y < n; ++y)
        for (int x = 0; x < n; ++x) {
          const size_t i = ref.index(x, y, z);
          if (view.dense[i] != ref.state[i]) fail(voxelLine(x, y, z, VoxelState(ref.state[i]), VoxelState(view.dense[i])));
        }
  } else {
    for (const ElementInfo& e : view.elements) {
      if (e.state != ElementState::Boundary) continue;
      for (int z = e.voxel(2); z < e.voxel(2) + e.edge; ++z)
        for (int y = e.voxel(1); y < e.voxel(1) + e.edge; ++y)
          for (int x = e.voxel(0); x < e.voxel(0) + e.edge; ++x) {
            const size_t i = ref.index(x, y, z);
            if (view.dense[i] != ref.state[i])
              fail(voxelLine(x, y, z, VoxelState(ref.state[i]), VoxelState(view.dense[i])));
          }
    }
  }
  return finish();
}

} // namespace test
} // namespace hdt
