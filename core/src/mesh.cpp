#include "hdt/mesh.hpp"

#include "hdt/error.hpp"
#include "hdt/geometry.hpp"
#include "hdt/volume.hpp"

#include <tbb/parallel_for.h>
#include <tbb/parallel_sort.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <sstream>

namespace hdt {

void meshBounds(const TriangleMesh& mesh, std::array<double, 3>& lo, std::array<double, 3>& hi) {
  if (mesh.points.size() % 3 != 0 || mesh.triangles.size() % 3 != 0) {
    throw Error(ErrorKind::BadInput, "point or index array length is not a multiple of 3");
  }
  if (mesh.triangleCount() == 0) throw Error(ErrorKind::BadInput, "the mesh has no triangles");
  const size_t np = mesh.pointCount();
  lo = {HUGE_VAL, HUGE_VAL, HUGE_VAL};
  hi = {-HUGE_VAL, -HUGE_VAL, -HUGE_VAL};
  for (size_t i = 0; i < mesh.triangles.size(); ++i) {
    const uint32_t p = mesh.triangles[i];
    if (p >= np) {
      std::ostringstream msg;
      msg << "triangle " << i / 3 << " refers to point " << p << " but the mesh has " << np << " points";
      throw Error(ErrorKind::BadInput, msg.str());
    }
    for (int a = 0; a < 3; ++a) {
      const double x = mesh.points[3 * size_t(p) + a];
      if (!std::isfinite(x)) {
        std::ostringstream msg;
        msg << "point " << p << " (used by triangle " << i / 3 << ") has a non-finite coordinate";
        throw Error(ErrorKind::BadInput, msg.str());
      }
      lo[a] = std::min(lo[a], x);
      hi[a] = std::max(hi[a], x);
    }
  }
}

namespace {

// Every undirected edge, as a pair of lattice points, used an even number of
// times: the surface is a mod-2 cycle, so ray parity is the same along any
// direction and one ray axis is enough.
bool isClosed(const std::vector<LatticeTriangle>& tris) {
  struct Edge {
    int32_t a[3], b[3];
    bool operator<(const Edge& o) const {
      return std::lexicographical_compare(a, a + 3, o.a, o.a + 3) ||
             (std::equal(a, a + 3, o.a) && std::lexicographical_compare(b, b + 3, o.b, o.b + 3));
    }
    bool operator==(const Edge& o) const { return std::equal(a, a + 3, o.a) && std::equal(b, b + 3, o.b); }
  };
  std::vector<Edge> edges(tris.size() * 3);
  tbb::parallel_for(size_t(0), tris.size(), [&](size_t t) {
    for (int j = 0; j < 3; ++j) {
      const int32_t* p = tris[t].v[j];
      const int32_t* q = tris[t].v[(j + 1) % 3];
      Edge& e = edges[3 * t + j];
      const bool swap = std::lexicographical_compare(q, q + 3, p, p + 3);
      std::copy(swap ? q : p, (swap ? q : p) + 3, e.a);
      std::copy(swap ? p : q, (swap ? p : q) + 3, e.b);
    }
  });
  tbb::parallel_sort(edges.begin(), edges.end());
  for (size_t i = 0; i < edges.size();) {
    size_t j = i + 1;
    while (j < edges.size() && edges[j] == edges[i]) ++j;
    if ((j - i) % 2 != 0) return false;
    i = j;
  }
  return true;
}

// Triangles that repeat another one's corners (any order, any orientation).
size_t countDuplicates(const std::vector<LatticeTriangle>& tris) {
  struct Corners {
    std::array<std::array<int32_t, 3>, 3> p;
    bool operator<(const Corners& o) const { return p < o.p; }
    bool operator==(const Corners& o) const { return p == o.p; }
  };
  std::vector<Corners> sorted(tris.size());
  tbb::parallel_for(size_t(0), tris.size(), [&](size_t t) {
    for (int j = 0; j < 3; ++j)
      for (int a = 0; a < 3; ++a) sorted[t].p[size_t(j)][size_t(a)] = tris[t].v[j][a];
    std::sort(sorted[t].p.begin(), sorted[t].p.end());
  });
  tbb::parallel_sort(sorted.begin(), sorted.end());
  const size_t distinct = size_t(std::unique(sorted.begin(), sorted.end()) - sorted.begin());
  return tris.size() - distinct;
}

} // namespace

std::vector<std::string> buildWarnings(const PreparedMesh& mesh, const Volume& volume) {
  std::vector<std::string> out;
  if (mesh.duplicateTriangles > 0) {
    out.push_back(std::to_string(mesh.duplicateTriangles) + " of " + std::to_string(mesh.triangles.size()) +
                  " triangles repeat another triangle's corners (duplicated faces cancel in the "
                  "inside/outside parity)");
  }
  if (volume.closedMesh && !volume.surfaceOnly && volume.stats.insideVoxels == 0) {
    out.push_back("the mesh is closed but no voxel is inside it (a doubled or self-cancelling "
                  "surface, or a shell thinner than a voxel)");
  }
  return out;
}

PreparedMesh prepareMesh(const TriangleMesh& mesh, const BuildConfig& config) {
  validateConfig(config); // configuration errors first: they are the caller's
  std::array<double, 3> lo, hi;
  meshBounds(mesh, lo, hi);
  if (config.hasBounds) {
    for (int a = 0; a < 3; ++a) {
      if (lo[a] < config.boundsMin[a] || hi[a] > config.boundsMax[a]) {
        throw Error(ErrorKind::InvalidArgument, "the explicit bounds do not contain the mesh");
      }
    }
    lo = config.boundsMin;
    hi = config.boundsMax;
  }

  PreparedMesh out;
  out.grid = placeGrid(config, lo, hi);
  out.inputTriangles = mesh.triangleCount();
  out.surfaceOnly = config.surfaceOnly;

  // Snap every point once: the lattice coordinates are the only geometry the
  // drivers see. Points lie in [s, (N - 1) s] of the grid, so below 2^24.
  const GridSpec& g = out.grid;
  const double scale = double(kLatticePerVoxel) / g.voxelSize;
  std::vector<int32_t> snapped(mesh.points.size());
  tbb::parallel_for(size_t(0), mesh.pointCount(), [&](size_t p) {
    for (int a = 0; a < 3; ++a) {
      const double q = (mesh.points[3 * p + a] - g.origin[a]) * scale;
      // Unreferenced points may be anywhere; clamp them harmlessly.
      const double limit = double(int64_t(g.resolution) * kLatticePerVoxel);
      snapped[3 * p + a] = int32_t(std::llround(std::min(std::max(q, 0.0), limit)));
    }
  });

  std::vector<LatticeTriangle> all(mesh.triangleCount());
  std::vector<uint8_t> keep(all.size());
  tbb::parallel_for(size_t(0), all.size(), [&](size_t t) {
    for (int j = 0; j < 3; ++j)
      for (int a = 0; a < 3; ++a) all[t].v[j][a] = snapped[3 * size_t(mesh.triangles[3 * t + j]) + a];
    keep[t] = !isDegenerate(all[t]);
  });
  out.triangles.reserve(all.size());
  for (size_t t = 0; t < all.size(); ++t)
    if (keep[t]) out.triangles.push_back(all[t]);
  out.degenerateTriangles = all.size() - out.triangles.size();
  if (out.triangles.empty()) {
    throw Error(ErrorKind::BadInput, "all " + std::to_string(all.size()) +
                                         " triangles are degenerate (zero area at this resolution)");
  }
  if (out.triangles.size() > (size_t(1) << 32) - 1) {
    throw Error(ErrorKind::OutOfResources, "more than 2^32 - 1 triangles are not supported");
  }
  out.closed = isClosed(out.triangles);
  out.duplicateTriangles = countDuplicates(out.triangles);
  return out;
}

} // namespace hdt
