#include "hdt/mesh.hpp"

#include "hdt/error.hpp"
#include "hdt/geometry.hpp"
#include "hdt/mesh_topology.hpp"
#include "hdt/warm_pages.hpp"
#include "hdt/volume.hpp"
#include "hdt/winding_tree.hpp"

#include "scratch.hpp"
#include "host_arena.hpp"

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>
#include <tbb/parallel_reduce.h>

#include <algorithm>
#include <array>
#include <chrono>
#include <cmath>
#include <sstream>
#include <thread>

namespace hdt {

namespace {

// The first bad index or coordinate, in triangle order: the message names the
// same triangle whatever the thread count.
[[noreturn]] void throwFirstBadReference(const TriangleMesh& mesh) {
  const size_t np = mesh.pointCount();
  for (size_t i = 0; i < mesh.triangles.size(); ++i) {
    const uint32_t p = mesh.triangles[i];
    if (p >= np) {
      std::ostringstream msg;
      msg << "triangle " << i / 3 << " refers to point " << p << " but the mesh has " << np << " points";
      throw Error(ErrorKind::BadInput, msg.str());
    }
    for (int a = 0; a < 3; ++a) {
      if (!std::isfinite(mesh.points[3 * size_t(p) + a])) {
        std::ostringstream msg;
        msg << "point " << p << " (used by triangle " << i / 3 << ") has a non-finite coordinate";
        throw Error(ErrorKind::BadInput, msg.str());
      }
    }
  }
  throw Error(ErrorKind::BadInput, "bad point reference"); // not reached: called after one was found
}

} // namespace

void meshBounds(const TriangleMesh& mesh, std::array<double, 3>& lo, std::array<double, 3>& hi) {
  if (mesh.points.size() % 3 != 0 || mesh.triangles.size() % 3 != 0) {
    throw Error(ErrorKind::BadInput, "point or index array length is not a multiple of 3");
  }
  if (mesh.triangleCount() == 0) throw Error(ErrorKind::BadInput, "the mesh has no triangles");
  struct Box {
    std::array<double, 3> lo{HUGE_VAL, HUGE_VAL, HUGE_VAL}, hi{-HUGE_VAL, -HUGE_VAL, -HUGE_VAL};
    bool bad = false;
  };
  const size_t np = mesh.pointCount();
  const uint32_t* triangles = mesh.triangles.data();
  const double* points = mesh.points.data();
  // min and max are exact, so the bounds do not depend on how the work is split.
  const Box box = tbb::parallel_reduce(
      tbb::blocked_range<size_t>(0, mesh.triangles.size(), 1 << 14), Box{},
      [&](const tbb::blocked_range<size_t>& r, Box b) {
        // Four independent lanes (min, max and add have latencies of several
        // cycles). x * 0 is 0 for a finite x and NaN for the others, so
        // `nonFinite` ends NaN where one was seen.
        double lo[3][4], hi[3][4], nonFinite[4] = {0, 0, 0, 0};
        for (int a = 0; a < 3; ++a)
          for (int k = 0; k < 4; ++k) lo[a][k] = b.lo[a], hi[a][k] = b.hi[a];
        auto add = [&](size_t p, int k) {
          for (int a = 0; a < 3; ++a) {
            const double x = points[3 * p + a];
            nonFinite[k] += x * 0.0;
            lo[a][k] = std::min(lo[a][k], x);
            hi[a][k] = std::max(hi[a][k], x);
          }
        };
        size_t i = r.begin();
        for (; i + 4 <= r.end() && !b.bad; i += 4) {
          const size_t p[4] = {triangles[i], triangles[i + 1], triangles[i + 2], triangles[i + 3]};
          b.bad = (p[0] >= np) | (p[1] >= np) | (p[2] >= np) | (p[3] >= np);
          if (!b.bad)
            for (int k = 0; k < 4; ++k) add(p[k], k);
        }
        for (; i < r.end() && !b.bad; ++i) {
          b.bad = triangles[i] >= np;
          if (!b.bad) add(triangles[i], 0);
        }
        for (int a = 0; a < 3; ++a) {
          b.lo[a] = std::min(std::min(lo[a][0], lo[a][1]), std::min(lo[a][2], lo[a][3]));
          b.hi[a] = std::max(std::max(hi[a][0], hi[a][1]), std::max(hi[a][2], hi[a][3]));
        }
        b.bad |= !(nonFinite[0] + nonFinite[1] + nonFinite[2] + nonFinite[3] == 0);
        return b;
      },
      [](Box a, const Box& b) {
        for (int k = 0; k < 3; ++k) {
          a.lo[k] = std::min(a.lo[k], b.lo[k]);
          a.hi[k] = std::max(a.hi[k], b.hi[k]);
        }
        a.bad |= b.bad;
        return a;
      });
  if (box.bad) throwFirstBadReference(mesh);
  lo = box.lo;
  hi = box.hi;
}

namespace {

// `count` unwritten triangles. Their pages are warm (warm_pages.hpp) or get
// faulted in by the blocks that write them, in parallel: no loop of its own.
LatticeTriangles sizedTriangles(size_t count) {
  LatticeTriangles v;
  v.resize(count);
  return v;
}

LatticeTriangle snappedTriangle(const TriangleMesh& mesh, const Scratch<NumberedPoint>& lattice, size_t t) {
  LatticeTriangle tri;
  for (int j = 0; j < 3; ++j) {
    const NumberedPoint& p = lattice[mesh.triangles[3 * t + j]];
    tri.v[j][0] = p.x, tri.v[j][1] = p.y, tri.v[j][2] = p.z;
  }
  return tri;
}

// The non-degenerate triangles, in input order (keep: which ones). Each block
// of triangles (itemBlocks) writes its kept ones from its own first slot on
// (file, run by the topology's pass over the same block); where some were
// dropped, the blocks' kept triangles are then moved together into an array
// of their size (finish).
struct KeptTriangles {
  const TriangleMesh& mesh;
  const Scratch<NumberedPoint>& lattice;
  Scratch<uint8_t> keep;
  LatticeTriangles all;
  ItemBlocks blocks;
  std::vector<size_t> start; // block k's kept count at k + 1, then where its triangles go

  KeptTriangles(const TriangleMesh& m, const Scratch<NumberedPoint>& l)
      : mesh(m), lattice(l), keep(m.triangleCount()), all(sizedTriangles(m.triangleCount())),
        blocks(itemBlocks(m.triangleCount())), start(blocks.count + 1, 0) {}

  void file(size_t k, size_t begin, size_t end) {
    size_t o = begin;
    for (size_t t = begin; t < end; ++t) {
      const LatticeTriangle tri = snappedTriangle(mesh, lattice, t);
      keep[t] = !isDegenerate(tri);
      if (keep[t]) all[o++] = tri;
    }
    start[k + 1] = o - begin;
  }

  LatticeTriangles finish() {
    for (size_t k = 0; k < blocks.count; ++k) start[k + 1] += start[k];
    if (start[blocks.count] == mesh.triangleCount()) return std::move(all);
    LatticeTriangles out = sizedTriangles(start[blocks.count]);
    tbb::parallel_for(size_t(0), blocks.count, [&](size_t k) {
      const auto from = all.begin() + ptrdiff_t(k * blocks.size);
      std::copy(from, from + ptrdiff_t(start[k + 1] - start[k]), out.begin() + ptrdiff_t(start[k]));
    });
    return out;
  }
};

} // namespace

std::vector<std::string> buildWarnings(const PreparedMesh& mesh, const Volume& volume) {
  std::vector<std::string> out;
  if (mesh.duplicateTriangles > 0) {
    out.push_back(std::to_string(mesh.duplicateTriangles) + " of " + std::to_string(mesh.triangles.size()) +
                  " triangles repeat another triangle's corners (duplicated faces cancel in the "
                  "inside/outside parity)");
  }
  if (!volume.closedMesh && !volume.surfaceOnly && volume.insideTest == InsideTest::Parity) {
    out.push_back("the mesh is open and the Parity inside test was asked for: its inside is a heuristic "
                  "(the majority of the +x, +y, +z ray parities; holes leak); the winding-number test "
                  "(Auto or Winding) decides open meshes exactly");
  }
  if (volume.closedMesh && !volume.surfaceOnly && volume.stats.insideVoxels == 0) {
    out.push_back("the mesh is closed but no voxel is inside it (a doubled or self-cancelling "
                  "surface, or a shell thinner than a voxel)");
  }
  return out;
}

PreparedMesh prepareMesh(const TriangleMesh& mesh, const BuildConfig& config) {
  return prepareMesh(mesh, config, nullptr);
}

namespace {
// The scatters' staging (mesh_topology.cpp): a block's values and their 16-bit
// buckets for each host thread.
size_t stagedBytes(size_t items, size_t valuesPerItem, size_t valueBytes) {
  const ItemBlocks blocks = itemBlocks(items);
  const size_t threads = std::max(1u, std::thread::hardware_concurrency());
  return detail::warmRounded(threads * blocks.size * valuesPerItem * (valueBytes + 2));
}
} // namespace

size_t prepareMeshWarmBytes(size_t triangles, size_t points) {
  using detail::warmRounded;
  // The two scatters' count tables (at most 64 blocks x 1041 counts) and the
  // topology's entries (two a triangle, 128 bits beyond 2^25 points).
  const size_t countTable = warmRounded(64 * 1041 * sizeof(size_t));
  const size_t entryBytes = points > (size_t(1) << 25) ? 16 : 8;
  return warmRounded(points * sizeof(NumberedPoint))         // snapped points and their numbers
         + warmRounded((points + 64) * 16)                   // bucketed points (blocks rounded up)
         + warmRounded(triangles)                            // keep
         + warmRounded(triangles * sizeof(LatticeTriangle))  // lattice triangles
         + warmRounded(2 * (triangles + 64) * entryBytes)    // edge and corner entries
         + 2 * countTable
         + std::max(stagedBytes(points, 1, sizeof(NumberedPoint)), stagedBytes(triangles, 2, entryBytes));
}

namespace {
PreparedMesh prepareInArena(const TriangleMesh& mesh, const BuildConfig& config, PrepareTimes* times);
} // namespace

// In the arena startHostThreads filled (host_arena.hpp): the first call of a
// process finds the workers there. A caller in an arena of fewer threads
// keeps its limit.
PreparedMesh prepareMesh(const TriangleMesh& mesh, const BuildConfig& config, PrepareTimes* times) {
  releaseHostThreads();
  if (tbb::this_task_arena::max_concurrency() < hostArena().max_concurrency()) return prepareInArena(mesh, config, times);
  return hostArena().execute([&] { return prepareInArena(mesh, config, times); });
}

namespace {
PreparedMesh prepareInArena(const TriangleMesh& mesh, const BuildConfig& config, PrepareTimes* times) {
  auto t = std::chrono::steady_clock::now();
  auto lap = [&t, times](double PrepareTimes::*field) {
    const auto now = std::chrono::steady_clock::now();
    if (times) times->*field = std::chrono::duration<double, std::milli>(now - t).count();
    t = now;
  };
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

  lap(&PrepareTimes::bounds);
  // Snap every point once: the lattice coordinates are the only geometry the
  // drivers see. Points lie in [s, (N - 1) s] of the grid, so below 2^24.
  // Then numbers for the lattice points: edges and corners compared as
  // numbers, not coordinates. Triangles refer to the first 2^32 points at
  // most, and only those are snapped: each block of them by the numbering's
  // pass that reads it next, while it is in cache.
  const GridSpec& g = out.grid;
  const size_t pointRange = std::min(mesh.pointCount(), size_t(1) << 32);
  Scratch<NumberedPoint> lattice(pointRange);
  numberLatticePoints(lattice.data(), pointRange, [&](size_t, size_t begin, size_t end) {
    const double* points = mesh.points.data();
    NumberedPoint* out = lattice.data();
    for (size_t p = begin; p != end; ++p) {
      out[p].x = snapToLattice(points[3 * p], g, 0);
      out[p].y = snapToLattice(points[3 * p + 1], g, 1);
      out[p].z = snapToLattice(points[3 * p + 2], g, 2);
    }
  });
  lap(&PrepareTimes::numbers);
  // The kept (non-degenerate) triangles are written block by block by the
  // topology's pass, which counts only those: kept triangles have three
  // distinct lattice points, so three distinct numbers.
  KeptTriangles kept(mesh, lattice);
  const SurfaceTopology topology =
      surfaceTopology(mesh.triangles.data(), kept.keep.data(), mesh.triangleCount(), lattice.data(), pointRange,
                      [&kept](size_t k, size_t begin, size_t end) { kept.file(k, begin, end); });
  out.triangles = kept.finish();
  out.closed = topology.closed;
  out.duplicateTriangles = topology.duplicateTriangles;
  lap(&PrepareTimes::closedAndDuplicates);
  out.degenerateTriangles = mesh.triangleCount() - out.triangles.size();
  if (out.triangles.empty()) {
    throw Error(ErrorKind::BadInput, "all " + std::to_string(mesh.triangleCount()) +
                                         " triangles are degenerate (zero area at this resolution)");
  }
  if (out.triangles.size() > (size_t(1) << 32) - 1) {
    throw Error(ErrorKind::OutOfResources, "more than 2^32 - 1 triangles are not supported");
  }
  out.requestedInsideTest = config.insideTest;
  out.insideTest = resolveInsideTest(config.insideTest, out.closed);
  return out;
}
} // namespace

} // namespace hdt
