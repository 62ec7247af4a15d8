// Mesh data onto surface voxels: a host pass after the build (hdt/transfer.hpp
// says what it computes and why it is deterministic).
#include "hdt/transfer.hpp"

#include "hdt/build_steps.hpp"
#include "hdt/error.hpp"
#include "hdt/geometry.hpp"
#include "hdt/labels.hpp"
#include "hdt/volume_walk.hpp"

#include <tbb/enumerable_thread_specific.h>
#include <tbb/parallel_for.h>
#include <tbb/parallel_sort.h>

#include <algorithm>
#include <cmath>
#include <limits>
#include <set>
#include <utility>

namespace hdt {

namespace {

using Vec3 = std::array<double, 3>;

double dot(const Vec3& a, const Vec3& b) { return a[0] * b[0] + a[1] * b[1] + a[2] * b[2]; }
Vec3 sub(const double* a, const double* b) { return {a[0] - b[0], a[1] - b[1], a[2] - b[2]}; }

// Where each leaf lies, and the leaf at a leaf-grid position.
struct LeafIndex {
  std::vector<std::array<int, 3>> origin;            // per leaf, voxels
  std::vector<uint64_t> element;                     // per leaf, its Boundary element
  std::vector<std::pair<uint64_t, uint64_t>> byPlace; // (packed leaf-grid position, leaf), sorted
  // Leaf-grid positions are below 65536 / 8 = 2^13 an axis.
  static uint64_t pack(int64_t x, int64_t y, int64_t z) { return uint64_t(x) | uint64_t(y) << 13 | uint64_t(z) << 26; }

  explicit LeafIndex(const Volume& v) : origin(v.leafCount()), element(v.leafCount()), byPlace(v.leafCount()) {
    const int L = v.grid.leafSize;
    parallelWalkVolume(v, v.grid.height, [&](const WalkedElement& e) {
      if (e.state() != ElementState::Boundary) return;
      origin[e.payload()] = e.origin;
      element[e.payload()] = e.index;
      byPlace[e.payload()] = {pack(e.origin[0] / L, e.origin[1] / L, e.origin[2] / L), e.payload()};
    });
    tbb::parallel_sort(byPlace.begin(), byPlace.end());
  }
  // The leaf at leaf-grid position (x, y, z), or -1.
  int64_t find(int64_t x, int64_t y, int64_t z) const {
    const uint64_t key = pack(x, y, z);
    const auto it = std::lower_bound(byPlace.begin(), byPlace.end(), std::make_pair(key, uint64_t(0)));
    return it != byPlace.end() && it->first == key ? int64_t(it->second) : -1;
  }
};

// The mesh's triangles on the volume's lattice; degenerate ones (which the
// build dropped) flagged.
struct LatticeMesh {
  std::vector<LatticeTriangle> triangles;
  std::vector<uint8_t> degenerate;
};

LatticeMesh snapMesh(const TriangleMesh& mesh, const GridSpec& g) {
  LatticeMesh out;
  const size_t n = mesh.triangleCount();
  out.triangles.resize(n);
  out.degenerate.resize(n);
  tbb::parallel_for(size_t(0), n, [&](size_t t) {
    LatticeTriangle& lt = out.triangles[t];
    for (int j = 0; j < 3; ++j)
      for (int a = 0; a < 3; ++a) lt.v[j][a] = snapToLattice(mesh.points[3 * size_t(mesh.triangles[3 * t + j]) + a], g, a);
    out.degenerate[t] = isDegenerate(lt);
  });
  return out;
}

void checkMesh(const TriangleMesh& mesh, const Volume& v) {
  if (mesh.points.size() % 3 != 0 || mesh.triangles.size() % 3 != 0 || mesh.triangleCount() == 0)
    throw Error(ErrorKind::InvalidArgument, "data transfer: the mesh has no triangles or broken arrays");
  if (mesh.triangleCount() > 0xFFFFFFFEu)
    throw Error(ErrorKind::InvalidArgument, "data transfer: more than 2^32 - 2 triangles");
  const size_t np = mesh.pointCount();
  for (uint32_t p : mesh.triangles)
    if (p >= np) throw Error(ErrorKind::InvalidArgument, "data transfer: a triangle refers to a missing point");
  if (!v.labels.empty() && mesh.triangleLabels.size() != mesh.triangleCount())
    throw Error(ErrorKind::InvalidArgument,
                "data transfer: the volume is labelled but the mesh has no label per triangle");
}

// (leaf << 32 | triangle) for every triangle and every leaf whose closed cube
// it touches, sorted: each leaf's triangles in increasing index.
std::vector<uint64_t> leafTrianglePairs(const LatticeMesh& m, const LeafIndex& leaves, const GridSpec& g) {
  const size_t n = m.triangles.size(), block = 1 << 14, blocks = (n + block - 1) / block;
  std::vector<std::vector<uint64_t>> perBlock(blocks);
  const int64_t L = g.leafSize, leafLattice = L * kLatticePerVoxel, perAxis = g.resolution / L;
  tbb::parallel_for(size_t(0), blocks, [&](size_t k) {
    for (size_t t = k * block; t < std::min(n, (k + 1) * block); ++t) {
      if (m.degenerate[t]) continue;
      int64_t lo[3], hi[3], first[3], last[3];
      triangleBounds(m.triangles[t], lo, hi);
      for (int a = 0; a < 3; ++a) cellRange(lo[a], hi[a], leafLattice, perAxis, first[a], last[a]);
      for (int64_t z = first[2]; z <= last[2]; ++z)
        for (int64_t y = first[1]; y <= last[1]; ++y)
          for (int64_t x = first[0]; x <= last[0]; ++x) {
            const int64_t leaf = leaves.find(x, y, z);
            if (leaf >= 0 && triangleOverlapsCube(m.triangles[t], x * leafLattice, y * leafLattice, z * leafLattice, leafLattice))
              perBlock[k].push_back(uint64_t(leaf) << 32 | t);
          }
    }
  });
  std::vector<uint64_t> pairs;
  for (auto& b : perBlock) pairs.insert(pairs.end(), b.begin(), b.end());
  tbb::parallel_sort(pairs.begin(), pairs.end());
  return pairs;
}

// Voxel centre of global voxel (x, y, z), mesh coordinates.
Vec3 voxelCentre(const GridSpec& g, int64_t x, int64_t y, int64_t z) {
  const double s = g.voxelSize;
  return {g.origin[0] + (double(x) + 0.5) * s, g.origin[1] + (double(y) + 0.5) * s, g.origin[2] + (double(z) + 0.5) * s};
}

const double* pointOf(const TriangleMesh& mesh, size_t t, int j) { return &mesh.points[3 * size_t(mesh.triangles[3 * t + size_t(j)])]; }

double squaredDistanceToTriangle(const TriangleMesh& mesh, size_t t, const Vec3& p) {
  const double *a = pointOf(mesh, t, 0), *b = pointOf(mesh, t, 1), *c = pointOf(mesh, t, 2);
  const Vec3 w = closestPointWeights(p.data(), a, b, c);
  double d2 = 0;
  for (int k = 0; k < 3; ++k) {
    const double q = w[0] * a[k] + w[1] * b[k] + w[2] * c[k];
    d2 += (p[size_t(k)] - q) * (p[size_t(k)] - q);
  }
  return d2;
}

// The label of voxel `voxel` of leaf `leaf` (labelled volumes).
Label leafVoxelLabel(const Volume& v, const LeafIndex& leaves, uint64_t leaf, uint32_t voxel) {
  return leafLabels(v, leaves.element[leaf])[voxel];
}

std::vector<uint32_t> chooseTriangles(const TriangleMesh& mesh, const Volume& v, const LeafIndex& leaves,
                                      const std::vector<uint64_t>& start) {
  checkMesh(mesh, v);
  const GridSpec& g = v.grid;
  const LatticeMesh m = snapMesh(mesh, g);
  const std::vector<uint64_t> pairs = leafTrianglePairs(m, leaves, g);
  const int L = g.leafSize;
  const uint32_t voxels = uint32_t(L * L * L);
  const bool labelled = !v.labels.empty();
  std::vector<uint32_t> chosen(start.back());
  struct Best {
    std::vector<double> distance;
    std::vector<uint32_t> triangle;
    RowClipper clipper;
  };
  tbb::enumerable_thread_specific<Best> scratch([&] { return Best{std::vector<double>(voxels), std::vector<uint32_t>(voxels), {}}; });
  constexpr uint32_t kNone = 0xFFFFFFFFu;
  tbb::parallel_for(uint64_t(0), v.leafCount(), [&](uint64_t leaf) {
    Best& best = scratch.local();
    const uint32_t* words = v.leaf(leaf);
    // Only surface voxels are ever read: reset those (a leaf holds few).
    for (uint32_t w = 0; w < voxels / kVoxelsPerWord; ++w) {
      for (uint32_t bits = planeOf(words[w], kSurfacePlane); bits; bits &= bits - 1) {
        const uint32_t vox = w * kVoxelsPerWord + uint32_t(__builtin_ctz(bits)) / 2;
        best.distance[vox] = std::numeric_limits<double>::infinity();
        best.triangle[vox] = kNone;
      }
    }
    const std::array<int, 3>& o = leaves.origin[leaf];
    const int64_t v0[3] = {o[0], o[1], o[2]};
    auto p = std::lower_bound(pairs.begin(), pairs.end(), leaf << 32);
    for (; p != pairs.end() && (*p >> 32) == leaf; ++p) { // increasing triangle index
      const uint32_t t = uint32_t(*p & 0xFFFFFFFFu);
      // The voxels the triangle touches, row by row as T3 finds them: rows
      // along the triangle's row axis, clipped by the 13 separating axes,
      // exactly the voxels triangleOverlapsCube accepts (build_steps.hpp).
      const int axis = rowAxisFor(m.triangles[t]);
      const LatticeTriangle tri = permuteToRowAxis(m.triangles[t], axis);
      RowClipper& clip = best.clipper;
      makeRowClipper(tri, clip);
      int64_t o[3], first[3], last[3];
      permutedOrigin(v0, axis, o);
      leafVoxelRanges(tri, o, L, g.resolution, first, last);
      for (int64_t pz = first[2]; pz <= last[2]; ++pz)
        for (int64_t py = first[1]; py <= last[1]; ++py) {
          int64_t f = first[0], l = last[0];
          clipRow(clip, py, pz, f, l);
          for (int64_t px = f; px <= l; ++px) {
            const int64_t q[3] = {px, py, pz}; // coordinate k of the row frame is (axis + k) % 3
            const int64_t x = q[(3 - axis) % 3], y = q[(4 - axis) % 3], z = q[(5 - axis) % 3];
            const uint32_t vox = uint32_t((x - v0[0]) + L * ((y - v0[1]) + L * (z - v0[2])));
            if (VoxelState((words[vox / kVoxelsPerWord] >> (2 * (vox % kVoxelsPerWord))) & 3u) != VoxelState::Surface) continue;
            if (labelled && leafVoxelLabel(v, leaves, leaf, vox) != mesh.triangleLabels[t]) continue;
            const double d = squaredDistanceToTriangle(mesh, t, voxelCentre(g, x, y, z));
            if (d < best.distance[vox]) { // strictly: ties keep the lower index
              best.distance[vox] = d;
              best.triangle[vox] = t;
            }
          }
        }
    }
    uint64_t s = start[leaf];
    for (uint32_t vox = 0; vox < voxels; ++vox) {
      if (VoxelState((words[vox / kVoxelsPerWord] >> (2 * (vox % kVoxelsPerWord))) & 3u) != VoxelState::Surface) continue;
      if (best.triangle[vox] == kNone)
        throw Error(ErrorKind::InvalidArgument,
                    "data transfer: a surface voxel touches no triangle of the mesh (of its label): "
                    "the mesh is not the one the volume was built from");
      chosen[s++] = best.triangle[vox];
    }
  });
  return chosen;
}

void checkArrays(const TriangleMesh& mesh, const std::vector<MeshArray>& arrays, const Volume& v) {
  std::set<std::string> names;
  for (const VoxelArray& a : v.arrays) names.insert(a.name);
  if (v.arrays.size() + arrays.size() > kMaxVoxelArrays)
    throw Error(ErrorKind::BadInput, "data transfer: more than " + std::to_string(kMaxVoxelArrays) + " arrays");
  for (const MeshArray& a : arrays) {
    const std::string what = "data transfer: array '" + a.name + "'";
    if (a.name.empty() || a.name.size() > kMaxArrayNameLength)
      throw Error(ErrorKind::BadInput, "data transfer: an array name is empty or longer than 255 bytes");
    if (!names.insert(a.name).second) throw Error(ErrorKind::BadInput, what + " is given twice");
    if (a.components < 1 || a.components > kMaxArrayComponents)
      throw Error(ErrorKind::BadInput, what + ": 1 to 64 components, not " + std::to_string(a.components));
    const size_t tuples = a.source == ArraySource::Point ? mesh.pointCount() : mesh.triangleCount();
    if (a.values.size() != tuples * a.components)
      throw Error(ErrorKind::BadInput, what + ": " + std::to_string(a.values.size()) + " values, expected " +
                                           std::to_string(tuples * a.components) + " (one tuple per " +
                                           (a.source == ArraySource::Point ? "point)" : "triangle)"));
  }
}

} // namespace

std::array<double, 3> closestPointWeights(const double* p, const double* a, const double* b, const double* c) {
  const Vec3 ab = sub(b, a), ac = sub(c, a), ap = sub(p, a);
  const double d1 = dot(ab, ap), d2 = dot(ac, ap);
  if (d1 <= 0 && d2 <= 0) return {1, 0, 0};
  const Vec3 bp = sub(p, b);
  const double d3 = dot(ab, bp), d4 = dot(ac, bp);
  if (d3 >= 0 && d4 <= d3) return {0, 1, 0};
  const double vc = d1 * d4 - d3 * d2;
  if (vc <= 0 && d1 >= 0 && d3 <= 0) {
    const double t = d1 / (d1 - d3);
    return {1 - t, t, 0};
  }
  const Vec3 cp = sub(p, c);
  const double d5 = dot(ab, cp), d6 = dot(ac, cp);
  if (d6 >= 0 && d5 <= d6) return {0, 0, 1};
  const double vb = d5 * d2 - d1 * d6;
  if (vb <= 0 && d2 >= 0 && d6 <= 0) {
    const double t = d2 / (d2 - d6);
    return {1 - t, 0, t};
  }
  const double va = d3 * d6 - d5 * d4;
  if (va <= 0 && d4 - d3 >= 0 && d5 - d6 >= 0) {
    const double t = (d4 - d3) / ((d4 - d3) + (d5 - d6));
    return {0, 1 - t, t};
  }
  const double sum = va + vb + vc;
  if (!(sum > 0)) return {1, 0, 0}; // zero area in mesh coordinates: not reached for a triangle the build kept
  const double v = vb / sum, w = vc / sum;
  return {1 - v - w, v, w};
}

std::vector<uint64_t> surfaceVoxelStart(const Volume& v) {
  const uint64_t leaves = v.leafCount();
  const uint32_t words = leafWordCount(v.grid.leafSize);
  std::vector<uint64_t> start(leaves + 1, 0);
  tbb::parallel_for(uint64_t(0), leaves, [&](uint64_t i) {
    const uint32_t* w = v.leaf(i);
    uint64_t c = 0;
    for (uint32_t j = 0; j < words; ++j) c += planeCount(w[j], kSurfacePlane);
    start[i + 1] = c;
  });
  for (uint64_t i = 0; i < leaves; ++i) start[i + 1] += start[i];
  return start;
}

std::vector<uint32_t> chosenTriangles(const TriangleMesh& mesh, const Volume& v) {
  const LeafIndex leaves(v);
  return chooseTriangles(mesh, v, leaves, surfaceVoxelStart(v));
}

void transferArrays(const TriangleMesh& mesh, const std::vector<MeshArray>& arrays, Volume& v) {
  if (arrays.empty()) return; // nothing asked: the mesh may be gone already
  checkMesh(mesh, v);
  checkArrays(mesh, arrays, v);
  const LeafIndex leaves(v);
  const std::vector<uint64_t> start = surfaceVoxelStart(v);
  const std::vector<uint32_t> chosen = chooseTriangles(mesh, v, leaves, start);
  std::vector<VoxelArray> out(arrays.size());
  for (size_t k = 0; k < arrays.size(); ++k) {
    out[k].name = arrays[k].name;
    out[k].source = arrays[k].source;
    out[k].components = arrays[k].components;
    out[k].values.resize(start.back() * arrays[k].components);
  }
  const GridSpec& g = v.grid;
  const int L = g.leafSize;
  tbb::parallel_for(uint64_t(0), v.leafCount(), [&](uint64_t leaf) {
    const uint32_t* words = v.leaf(leaf);
    const std::array<int, 3>& o = leaves.origin[leaf];
    uint64_t s = start[leaf];
    for (uint32_t vox = 0; vox < uint32_t(L * L * L); ++vox) {
      if (VoxelState((words[vox / kVoxelsPerWord] >> (2 * (vox % kVoxelsPerWord))) & 3u) != VoxelState::Surface) continue;
      const size_t t = chosen[s];
      const Vec3 p = voxelCentre(g, o[0] + int(vox % uint32_t(L)), o[1] + int((vox / uint32_t(L)) % uint32_t(L)),
                                 o[2] + int(vox / uint32_t(L * L)));
      const Vec3 w = closestPointWeights(p.data(), pointOf(mesh, t, 0), pointOf(mesh, t, 1), pointOf(mesh, t, 2));
      for (size_t k = 0; k < arrays.size(); ++k) {
        const MeshArray& a = arrays[k];
        const size_t c = a.components;
        float* dst = out[k].values.data() + s * c;
        if (a.source == ArraySource::Cell) {
          for (size_t j = 0; j < c; ++j) dst[j] = float(a.values[t * c + j]);
          continue;
        }
        const double* f0 = &a.values[size_t(mesh.triangles[3 * t]) * c];
        const double* f1 = &a.values[size_t(mesh.triangles[3 * t + 1]) * c];
        const double* f2 = &a.values[size_t(mesh.triangles[3 * t + 2]) * c];
        for (size_t j = 0; j < c; ++j) dst[j] = float(w[0] * f0[j] + w[1] * f1[j] + w[2] * f2[j]);
      }
      ++s;
    }
  });
  for (VoxelArray& a : out) v.arrays.push_back(std::move(a));
}

void validateVoxelArrays(const Volume& v) {
  if (v.arrays.empty()) return;
  if (v.arrays.size() > kMaxVoxelArrays)
    throw Error(ErrorKind::BadInput, "more than " + std::to_string(kMaxVoxelArrays) + " voxel arrays");
  const uint64_t surface = surfaceVoxelStart(v).back();
  std::set<std::string> names;
  for (const VoxelArray& a : v.arrays) {
    if (a.name.empty() || a.name.size() > kMaxArrayNameLength) throw Error(ErrorKind::BadInput, "voxel array with an empty or too long name");
    if (!names.insert(a.name).second) throw Error(ErrorKind::BadInput, "voxel array '" + a.name + "' appears twice");
    if (a.source != ArraySource::Point && a.source != ArraySource::Cell)
      throw Error(ErrorKind::BadInput, "voxel array '" + a.name + "': unknown source");
    if (a.components < 1 || a.components > kMaxArrayComponents)
      throw Error(ErrorKind::BadInput, "voxel array '" + a.name + "': 1 to 64 components");
    if (a.values.size() != surface * a.components)
      throw Error(ErrorKind::BadInput, "voxel array '" + a.name + "': " + std::to_string(a.values.size()) +
                                           " values for " + std::to_string(surface) + " surface voxels");
  }
}

uint64_t voxelArrayBytes(const Volume& v) {
  uint64_t bytes = 0;
  for (const VoxelArray& a : v.arrays) bytes += a.values.size() * sizeof(float) + a.name.size();
  return bytes;
}

float voxelArrayValue(const Volume& v, size_t array, uint32_t component, int x, int y, int z) {
  const GridSpec& g = v.grid;
  const float nan = std::numeric_limits<float>::quiet_NaN();
  if (array >= v.arrays.size() || component >= v.arrays[array].components || x < 0 || y < 0 || z < 0 ||
      x >= g.resolution || y >= g.resolution || z >= g.resolution)
    return nan;
  const WalkedElement e = locateElement(v, x, y, z, g.height);
  if (e.state() != ElementState::Boundary) return nan;
  const int L = g.leafSize;
  const uint32_t* words = v.leaf(e.payload());
  if (leafVoxel(words, L, x - e.origin[0], y - e.origin[1], z - e.origin[2]) != VoxelState::Surface) return nan;
  const uint32_t vox = uint32_t((x - e.origin[0]) + L * ((y - e.origin[1]) + L * (z - e.origin[2])));
  const uint64_t s = surfaceVoxelStart(v)[e.payload()] + surfaceRankInLeaf(words, vox);
  return v.arrays[array].values[s * v.arrays[array].components + component];
}

} // namespace hdt
