#include "hdt/mesh.hpp"

#include "hdt/error.hpp"
#include "hdt/geometry.hpp"
#include "hdt/huge_pages.hpp" // HugePageAllocator, prefaultParallel
#include "hdt/volume.hpp"
#include "hdt/winding_tree.hpp"

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>
#include <tbb/parallel_reduce.h>
#include <tbb/parallel_invoke.h>

#include <algorithm>
#include <array>
#include <chrono>
#include <cmath>
#include <functional>
#include <sstream>
#include <type_traits>
#include <utility>

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
  // min and max are exact, so the bounds do not depend on how the work is split.
  const Box box = tbb::parallel_reduce(
      tbb::blocked_range<size_t>(0, mesh.triangles.size(), 1 << 14), Box{},
      [&](const tbb::blocked_range<size_t>& r, Box b) {
        for (size_t i = r.begin(); i != r.end(); ++i) {
          const uint32_t p = mesh.triangles[i];
          if (p >= np) {
            b.bad = true;
            break;
          }
          for (int a = 0; a < 3; ++a) {
            const double x = mesh.points[3 * size_t(p) + a];
            b.bad |= !std::isfinite(x);
            b.lo[a] = std::min(b.lo[a], x);
            b.hi[a] = std::max(b.hi[a], x);
          }
        }
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

// Fresh memory's pages are faulted in by several threads (one thread's page
// faults were most of prepareMesh's time); vectors that are written in
// parallel loops are not zeroed first, and large ones get 2 MiB pages (the
// edge keys are scattered over tens of MB: with 4 KiB pages, a TLB miss and
// often a page fault a write).
template <class T> struct ScratchAllocator : HugePageAllocator<T> {
  template <class U> struct rebind {
    using other = ScratchAllocator<U>;
  };
  ScratchAllocator() noexcept = default;
  template <class U> ScratchAllocator(const ScratchAllocator<U>&) noexcept {}
  template <class U> void construct(U* p) noexcept(std::is_nothrow_default_constructible<U>::value) {
    ::new (static_cast<void*>(p)) U;
  }
  template <class U, class... A> void construct(U* p, A&&... a) {
    ::new (static_cast<void*>(p)) U(std::forward<A>(a)...);
  }
};
template <class T> using Scratch = std::vector<T, ScratchAllocator<T>>;

// An undirected edge: its two lattice points as 96-bit keys, a < b.
struct Edge {
  unsigned __int128 a, b;
  bool operator<(const Edge& o) const { return a < o.a || (a == o.a && b < o.b); }
  bool operator==(const Edge& o) const { return a == o.a && b == o.b; }
};

unsigned __int128 pointKey(const int32_t* p) {
  return (static_cast<unsigned __int128>(uint32_t(p[0])) << 64) | (uint64_t(uint32_t(p[1])) << 32) | uint32_t(p[2]);
}

Edge edgeOf(const LatticeTriangle& t, int j) {
  const unsigned __int128 p = pointKey(t.v[j]), q = pointKey(t.v[(j + 1) % 3]);
  return p < q ? Edge{p, q} : Edge{q, p};
}

// A triangle's corners in increasing order (any order, any orientation).
struct Corners {
  unsigned __int128 p[3];
  bool operator<(const Corners& o) const {
    return p[0] < o.p[0] || (p[0] == o.p[0] && (p[1] < o.p[1] || (p[1] == o.p[1] && p[2] < o.p[2])));
  }
  bool operator==(const Corners& o) const { return p[0] == o.p[0] && p[1] == o.p[1] && p[2] == o.p[2]; }
};

Corners cornersOf(const LatticeTriangle& t, int) {
  Corners c{{pointKey(t.v[0]), pointKey(t.v[1]), pointKey(t.v[2])}};
  if (c.p[1] < c.p[0]) std::swap(c.p[0], c.p[1]);
  if (c.p[2] < c.p[1]) std::swap(c.p[1], c.p[2]);
  if (c.p[1] < c.p[0]) std::swap(c.p[0], c.p[1]);
  return c;
}

// Equal keys land in the same bucket: a hash of their 128-bit parts.
template <size_t K> uint32_t bucketOf(const unsigned __int128 (&parts)[K], int bits) { // bits in [1, 12]
  uint64_t h = 0x9E3779B97F4A7C15ull;
  for (unsigned __int128 k : parts) {
    h = (h ^ uint64_t(k)) * 0xFF51AFD7ED558CCDull;
    h = (h ^ uint64_t(k >> 64)) * 0xC4CEB9FE1A85EC53ull;
  }
  return uint32_t((h ^ (h >> 29)) >> (64 - bits));
}
uint32_t bucketOf(const Edge& e, int bits) {
  const unsigned __int128 parts[2] = {e.a, e.b};
  return bucketOf(parts, bits);
}
uint32_t bucketOf(const Corners& c, int bits) { return bucketOf(c.p, bits); }

// The K keys of every triangle (keyOf(triangle, j), j < K) scattered into
// hash buckets, so that equal keys share a bucket: counted per fixed block
// of triangles (the layout does not depend on the thread count), then each
// block writes its own slots. Linear and parallel; each bucket can then be
// sorted and its runs examined on its own (forEachRun).
template <class Key> struct Buckets {
  Scratch<Key> keys;
  std::vector<size_t> start; // bucket b: keys[start[b], start[b + 1])
};

template <int K, class Key, class KeyOf> Buckets<Key> bucketKeys(const std::vector<LatticeTriangle>& tris, KeyOf keyOf) {
  const size_t n = tris.size(), keys = K * n;
  // About 256 keys a bucket (at most 4096 buckets) and at most 64 blocks:
  // the count table stays small (2 MiB) for any mesh.
  const int bits = std::clamp(int(std::log2(double(keys) / 256.0 + 1.0)), 1, 12);
  const size_t buckets = size_t(1) << bits;
  const size_t blocks = std::clamp<size_t>((n + (1 << 14) - 1) >> 14, 1, 64), block = (n + blocks - 1) / blocks;
  Scratch<uint16_t> bucket(keys);
  std::vector<size_t> offset(blocks * buckets, 0); // per block and bucket: count, then first slot
  tbb::parallel_for(size_t(0), blocks, [&](size_t k) {
    size_t* count = offset.data() + k * buckets;
    for (size_t t = k * block; t < std::min(n, (k + 1) * block); ++t)
      for (int j = 0; j < K; ++j) ++count[bucket[K * t + j] = uint16_t(bucketOf(keyOf(tris[t], j), bits))];
  });
  Buckets<Key> out;
  out.start.assign(buckets + 1, 0);
  size_t slot = 0;
  for (size_t b = 0; b < buckets; ++b) {
    out.start[b] = slot;
    for (size_t k = 0; k < blocks; ++k) {
      const size_t c = offset[k * buckets + b];
      offset[k * buckets + b] = slot;
      slot += c;
    }
  }
  out.start[buckets] = slot;
  out.keys = Scratch<Key>(keys);
  tbb::parallel_for(size_t(0), blocks, [&](size_t k) {
    size_t* next = offset.data() + k * buckets;
    for (size_t t = k * block; t < std::min(n, (k + 1) * block); ++t)
      for (int j = 0; j < K; ++j) out.keys[next[bucket[K * t + j]]++] = keyOf(tris[t], j);
  });
  return out;
}

// Sums runLength -> value over the runs of equal keys, each bucket sorted in
// parallel (the sum does not depend on the order of the buckets).
template <class Key, class Value> size_t sumOverRuns(Buckets<Key>& b, Value value) {
  return tbb::parallel_reduce(
      tbb::blocked_range<size_t>(0, b.start.size() - 1), size_t(0),
      [&](const tbb::blocked_range<size_t>& r, size_t sum) {
        for (size_t k = r.begin(); k != r.end(); ++k) {
          Key* first = b.keys.data() + b.start[k];
          Key* last = b.keys.data() + b.start[k + 1];
          std::sort(first, last);
          for (Key* i = first; i != last;) {
            Key* j = i + 1;
            while (j != last && *j == *i) ++j;
            sum += value(size_t(j - i));
            i = j;
          }
        }
        return sum;
      },
      std::plus<size_t>());
}

// Every undirected edge, as a pair of lattice points, used an even number of
// times: the surface is a mod-2 cycle, so ray parity is the same along any
// direction and one ray axis is enough.
bool isClosed(const std::vector<LatticeTriangle>& tris) {
  Buckets<Edge> edges = bucketKeys<3, Edge>(tris, edgeOf);
  return sumOverRuns(edges, [](size_t run) { return run % 2; }) == 0;
}

// Triangles that repeat another one's corners (any order, any orientation).
size_t countDuplicates(const std::vector<LatticeTriangle>& tris) {
  Buckets<Corners> corners = bucketKeys<1, Corners>(tris, cornersOf);
  return sumOverRuns(corners, [](size_t run) { return run - 1; });
}

// `count` value-initialised elements; the pages are faulted in in parallel
// first, so the zeroing runs at memory speed.
template <class T> std::vector<T> sizedVector(size_t count) {
  std::vector<T> v;
  v.reserve(count);
  prefaultParallel(v.data(), count * sizeof(T));
  v.resize(count);
  return v;
}

LatticeTriangle snappedTriangle(const TriangleMesh& mesh, const Scratch<int32_t>& snapped, size_t t) {
  LatticeTriangle tri;
  for (int j = 0; j < 3; ++j)
    for (int a = 0; a < 3; ++a) tri.v[j][a] = snapped[3 * size_t(mesh.triangles[3 * t + j]) + a];
  return tri;
}

// The non-degenerate triangles, in input order: per fixed block a count, then
// each block writes its own range.
std::vector<LatticeTriangle> keptTriangles(const TriangleMesh& mesh, const Scratch<int32_t>& snapped) {
  const size_t n = mesh.triangleCount(), block = 1 << 14, blocks = (n + block - 1) / block;
  Scratch<uint8_t> keep(n);
  std::vector<size_t> start(blocks + 1, 0);
  tbb::parallel_for(size_t(0), blocks, [&](size_t k) {
    size_t c = 0;
    for (size_t t = k * block; t < std::min(n, (k + 1) * block); ++t)
      c += keep[t] = !isDegenerate(snappedTriangle(mesh, snapped, t));
    start[k + 1] = c;
  });
  for (size_t k = 0; k < blocks; ++k) start[k + 1] += start[k];
  std::vector<LatticeTriangle> out = sizedVector<LatticeTriangle>(start[blocks]);
  tbb::parallel_for(size_t(0), blocks, [&](size_t k) {
    size_t o = start[k];
    for (size_t t = k * block; t < std::min(n, (k + 1) * block); ++t)
      if (keep[t]) out[o++] = snappedTriangle(mesh, snapped, t);
  });
  return out;
}

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

PreparedMesh prepareMesh(const TriangleMesh& mesh, const BuildConfig& config, PrepareTimes* times) {
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
  const GridSpec& g = out.grid;
  Scratch<int32_t> snapped(mesh.points.size());
  tbb::parallel_for(size_t(0), mesh.pointCount(), [&](size_t p) {
    for (int a = 0; a < 3; ++a) snapped[3 * p + a] = snapToLattice(mesh.points[3 * p + a], g, a);
  });

  lap(&PrepareTimes::snap);
  out.triangles = keptTriangles(mesh, snapped);
  lap(&PrepareTimes::kept);
  out.degenerateTriangles = mesh.triangleCount() - out.triangles.size();
  if (out.triangles.empty()) {
    throw Error(ErrorKind::BadInput, "all " + std::to_string(mesh.triangleCount()) +
                                         " triangles are degenerate (zero area at this resolution)");
  }
  if (out.triangles.size() > (size_t(1) << 32) - 1) {
    throw Error(ErrorKind::OutOfResources, "more than 2^32 - 1 triangles are not supported");
  }
  // Two independent passes over the kept triangles, each parallel inside.
  tbb::parallel_invoke([&] { out.closed = isClosed(out.triangles); },
                       [&] { out.duplicateTriangles = countDuplicates(out.triangles); });
  lap(&PrepareTimes::closedAndDuplicates);
  out.requestedInsideTest = config.insideTest;
  out.insideTest = resolveInsideTest(config.insideTest, out.closed);
  return out;
}

} // namespace hdt
