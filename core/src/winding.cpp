// The winding-number tree and the classification of a volume by it
// (winding.hpp, docs/design.md "Winding number").
#include "hdt/winding_tree.hpp"

#include "hdt/build_steps.hpp"
#include "hdt/error.hpp"
#include "hdt/huge_pages.hpp"
#include "hdt/mesh.hpp"
#include "hdt/progress.hpp"
#include "hdt/volume.hpp"
#include "hdt/volume_walk.hpp"
#include "hdt/winding_far.hpp"
#include "hdt/winding_leaf.hpp"

#include <algorithm>
#include <atomic>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <future>
#include <memory>
#include <new>
#include <numeric>
#include <stdexcept>
#include <type_traits>

#include <tbb/enumerable_thread_specific.h>
#include <tbb/parallel_for.h>
#include <tbb/parallel_invoke.h>
#include <tbb/parallel_reduce.h>
#include <tbb/parallel_sort.h>

namespace hdt {
namespace {

constexpr uint32_t kLeafTriangles = 4;

// The phase the inside test reports (BuildOptions::progress), and a report
// of `fraction` of it when the build has a poll: it throws Error(Aborted)
// when the caller asked to stop, also inside the loops since the last one
// (they poll with abortRequested and return early, leaving work undone that
// nothing reads after the throw).
constexpr const char* kWindingPhase = "inside test: winding number";
void reportWinding(ProgressPoll* progress, double fraction) {
  if (progress) progress->report(fraction, kWindingPhase);
}

// HDT_WINDING_TRACE set: the host's phases of the inside test on stderr (the
// device passes print theirs, cuda/src/winding_device.cu).
void traceWindingMs(const char* phase, double ms) {
  static const bool on = std::getenv("HDT_WINDING_TRACE") != nullptr;
  if (on) std::fprintf(stderr, "winding host: %s %.2f ms\n", phase, ms);
}
void traceWinding(const char* phase, std::chrono::steady_clock::time_point since) {
  traceWindingMs(phase, std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - since).count());
}

// The corners, box, area, centroid and half cross product of a triangle:
// what the tree's sums read (windingTriangle adds the rest).
WindingTriangle windingTriangleBasics(const LatticeTriangle& t) {
  WindingTriangle w;
  for (int j = 0; j < 3; ++j)
    for (int a = 0; a < 3; ++a) w.v[3 * j + a] = double(t.v[j][a]) / double(kLatticePerVoxel);
  for (int a = 0; a < 3; ++a) {
    w.lo[a] = std::min({w.v[a], w.v[3 + a], w.v[6 + a]});
    w.hi[a] = std::max({w.v[a], w.v[3 + a], w.v[6 + a]});
  }
  const double ex = w.v[3] - w.v[0], ey = w.v[4] - w.v[1], ez = w.v[5] - w.v[2];
  const double fx = w.v[6] - w.v[0], fy = w.v[7] - w.v[1], fz = w.v[8] - w.v[2];
  const double cx = ey * fz - ez * fy, cy = ez * fx - ex * fz, cz = ex * fy - ey * fx;
  w.area = 0.5 * std::sqrt(cx * cx + cy * cy + cz * cz);
  for (int a = 0; a < 3; ++a) {
    w.centroid[a] = (w.v[a] + w.v[3 + a] + w.v[6 + a]) / 3.0;
    w.halfCross[a] = 0.5 * (a == 0 ? cx : a == 1 ? cy : cz);
  }
  return w;
}

WindingTriangle windingTriangle(const LatticeTriangle& t) {
  WindingTriangle w = windingTriangleBasics(t);
  double r2 = 0;
  for (int j = 0; j < 3; ++j) {
    double d2 = 0;
    for (int a = 0; a < 3; ++a) d2 += (w.v[3 * j + a] - w.centroid[a]) * (w.v[3 * j + a] - w.centroid[a]);
    r2 = std::max(r2, d2);
  }
  w.radius = std::sqrt(r2) * (1 + 1e-12); // covers the rounding of the centroid and the root
  double spread = 0;
  for (int j = 0; j < 3; ++j)
    for (int a = 0; a < 3; ++a) spread += (w.v[3 * j + a] - w.centroid[a]) * (w.v[3 * j + a] - w.centroid[a]);
  w.secondMoment = w.area * spread / 12.0 * (1 + 1e-12);
  return w;
}

// Nodes below a node of `count` triangles, with those below count + 1: the
// median splits make a subtree's layout a function of its count alone.
std::pair<uint32_t, uint32_t> nodesBelowPair(uint32_t count) {
  if (count + 1 <= kLeafTriangles) return {0, 0};
  const uint32_t m = count / 2;
  const std::pair<uint32_t, uint32_t> below = nodesBelowPair(m); // m and m + 1 triangles
  const auto nodesBelow = [&](uint32_t n) -> uint32_t {
    if (n <= kLeafTriangles) return 0;
    const uint32_t half = n / 2;
    return 2 + (half == m ? below.first : below.second) + (n - half == m ? below.first : below.second);
  };
  return {nodesBelow(count), nodesBelow(count + 1)};
}

uint32_t nodesBelow(uint32_t count) { return nodesBelowPair(count).first; }

// A triangle's place in the median splits: what the splits compare (the exact
// centroid keys, the index as tie-break) and where its sums sit. Small, so
// that the selection moves 32 bytes a swap, not a whole triangle's sums.
struct TreeKey {
  std::array<int64_t, 3> key; // 3 x centroid, exact
  uint32_t triangle;          // input index
  uint32_t at;                // its TreeSums in the buffer of the node's depth
};

// What a node's sums read of one triangle (as windingTriangle computes them),
// those summed in order first; the box on the lattice (windingTriangle's box
// is it / 256, exactly: the conversion and the division keep the order).
struct TreeSums {
  double halfCross[3];
  double centroid[3];
  double area;
  int32_t lo[3], hi[3];
};

// The boxes of a node's triangles (on the lattice) and of their keys:
// minima and maxima of integers, the same in any order, so they are reduced
// in parallel. The box gives the node's centre, the keys' its axis.
struct NodeBox {
  int32_t lo[3] = {INT32_MAX, INT32_MAX, INT32_MAX}, hi[3] = {INT32_MIN, INT32_MIN, INT32_MIN};
  int64_t klo[3] = {INT64_MAX, INT64_MAX, INT64_MAX}, khi[3] = {INT64_MIN, INT64_MIN, INT64_MIN};
  void add(const TreeSums& s, const TreeKey& k) {
    for (int a = 0; a < 3; ++a) {
      lo[a] = std::min(lo[a], s.lo[a]);
      hi[a] = std::max(hi[a], s.hi[a]);
      klo[a] = std::min(klo[a], k.key[size_t(a)]);
      khi[a] = std::max(khi[a], k.key[size_t(a)]);
    }
  }
  void add(const NodeBox& b) {
    for (int a = 0; a < 3; ++a) {
      lo[a] = std::min(lo[a], b.lo[a]);
      hi[a] = std::max(hi[a], b.hi[a]);
      klo[a] = std::min(klo[a], b.klo[a]);
      khi[a] = std::max(khi[a], b.khi[a]);
    }
  }
};

// Fills the tree top-down: a node's children sit at the next free pair of
// slots and its first child's subtree before its second's (pre-order), as a
// serial recursion would place them; subtrees of many triangles are filled
// in parallel at those precomputed places.
//
// A node's sums (area, dipole, quadrupole) run over its triangles in the
// order its parent's selection left them, in one pass, so the tree is the
// same whatever the thread count. The selection (nth_element) runs on the
// keys alone: it only compares and swaps, so it leaves the order one on the
// triangles' whole records would. The records then follow into the other
// of two buffers (a node at depth d reads buffer d % 2, its triangles at
// [first, first + count) in order), in parallel for large nodes, with the
// children's boxes reduced on the way: the serial work of the top levels is
// the selection and one streaming pass.
//
// The keys and both buffers live in the tree's triangle array, sized first
// and written only after the fill (TreeScratch): fresh pages are faulted in
// once, and on a VM that costs about as much as the fill itself.
struct TreeBuilder {
  static constexpr uint32_t kParallelTriangles = 4096;
  TreeKey* keys;     // permuted in place; written before read
  TreeSums* sums[2]; // by depth parity; written before read
  WindingTree& tree;

  // Moves the records of [first, last) into the next depth's buffer in the
  // keys' order; returns their box.
  NodeBox follow(uint32_t first, uint32_t last, int depth) {
    const TreeSums* const in = sums[depth & 1];
    TreeSums* const out = sums[(depth + 1) & 1];
    const auto move = [&](uint32_t from, uint32_t to, NodeBox b) {
      for (uint32_t i = from; i < to; ++i) {
        TreeKey& k = keys[i];
        out[i] = in[k.at];
        k.at = i;
        b.add(out[i], k);
      }
      return b;
    };
    if (last - first < kParallelTriangles) return move(first, last, NodeBox());
    return tbb::parallel_reduce(
        tbb::blocked_range<uint32_t>(first, last, 2048), NodeBox(),
        [&](const tbb::blocked_range<uint32_t>& r, NodeBox b) { return move(r.begin(), r.end(), b); },
        [](NodeBox a, const NodeBox& b) {
          a.add(b);
          return a;
        });
  }

  void fill(uint32_t node, uint32_t first, uint32_t count, uint32_t freeSlot, const NodeBox& box, int depth) {
    WindingNode n{};
    double r2 = 0;
    for (int a = 0; a < 3; ++a) {
      n.lo[a] = double(box.lo[a]) / double(kLatticePerVoxel);
      n.hi[a] = double(box.hi[a]) / double(kLatticePerVoxel);
      n.centre[a] = 0.5 * (n.lo[a] + n.hi[a]);
      const double h = 0.5 * (n.hi[a] - n.lo[a]);
      r2 += h * h;
    }
    n.radius = std::sqrt(r2) * (1 + 1e-12); // covers the rounding of the half diagonal
    // The quadrupole moment: integral of n (x - centre)^T = area n (centroid - centre)^T.
    const TreeSums* const in = sums[depth & 1];
    for (const TreeSums *it = in + first, *end = it + count; it != end; ++it) {
      for (int a = 0; a < 3; ++a) n.dipole[a] += it->halfCross[a];
      n.area += it->area;
      for (int r = 0; r < 3; ++r)
        for (int c = 0; c < 3; ++c) n.quad[3 * r + c] += it->halfCross[r] * (it->centroid[c] - n.centre[c]);
    }
    const auto at = [this](uint32_t i) { return keys + i; };
    if (count <= kLeafTriangles) {
      std::sort(at(first), at(first + count), [](const TreeKey& x, const TreeKey& y) { return x.triangle < y.triangle; });
      n.first = first;
      n.count = count;
      tree.nodes[node] = n;
      return;
    }
    int axis = 0;
    for (int a = 1; a < 3; ++a)
      if (box.khi[a] - box.klo[a] > box.khi[axis] - box.klo[axis]) axis = a;
    const uint32_t half = count / 2;
    std::nth_element(at(first), at(first + half), at(first + count), [axis](const TreeKey& x, const TreeKey& y) {
      const int64_t kx = x.key[size_t(axis)], ky = y.key[size_t(axis)];
      return kx != ky ? kx < ky : x.triangle < y.triangle;
    });
    const uint32_t child = freeSlot;
    n.first = child;
    n.count = 0;
    tree.nodes[node] = n;
    const uint32_t firstFree = child + 2, secondFree = firstFree + nodesBelow(half);
    // Both halves follow before either subtree reuses this depth's buffer (a
    // record of one half may sit in the other's range).
    const NodeBox leftBox = follow(first, first + half, depth);
    const NodeBox rightBox = follow(first + half, first + count, depth);
    const auto fillLeft = [&] { fill(child, first, half, firstFree, leftBox, depth + 1); };
    const auto fillRight = [&] { fill(child + 1, first + half, count - half, secondFree, rightBox, depth + 1); };
    if (count >= kParallelTriangles) {
      tbb::parallel_invoke(fillLeft, fillRight);
    } else {
      fillLeft();
      fillRight();
    }
  }
};


// The builder's arrays in the storage of tree.triangles (n WindingTriangles,
// unwritten): records of depth parity 0, then 1, then the keys. Each is
// created there (trivial types: no write) and is dead before the triangles
// are created over them.
static_assert(2 * sizeof(TreeSums) + sizeof(TreeKey) <= sizeof(WindingTriangle), "the builder's arrays fit");
static_assert(sizeof(TreeSums) % alignof(TreeKey) == 0 && alignof(WindingTriangle) >= alignof(TreeKey), "aligned");
TreeBuilder builderInTriangles(WindingTree& tree, size_t n) {
  unsigned char* const base = reinterpret_cast<unsigned char*>(tree.triangles.data());
  // Element by element (an array new may ask for more room than n elements).
  const auto createdAt = [n](unsigned char* at, auto* type) {
    using T = std::remove_pointer_t<decltype(type)>;
    T* const first = reinterpret_cast<T*>(at);
    std::uninitialized_default_construct_n(first, n); // trivial: writes nothing
    return first;
  };
  TreeSums* const even = createdAt(base, static_cast<TreeSums*>(nullptr));
  TreeSums* const odd = createdAt(base + n * sizeof(TreeSums), static_cast<TreeSums*>(nullptr));
  TreeKey* const keys = createdAt(base + 2 * n * sizeof(TreeSums), static_cast<TreeKey*>(nullptr));
  return TreeBuilder{keys, {even, odd}, tree};
}

} // namespace

WindingTree buildWindingTree(const LatticeTriangles& triangles) {
  WindingTree tree;
  if (triangles.empty()) return tree;
  const size_t n = triangles.size();
  tree.triangles.resize(n);
  tree.lattice.resize(n);
  TreeBuilder b = builderInTriangles(tree, n);
  // The nodes and the boundary edges write different members of the tree:
  // side by side (the top of the node recursion is mostly serial).
  tbb::parallel_invoke(
      [&] {
        const NodeBox root = tbb::parallel_reduce(
            tbb::blocked_range<size_t>(0, n, 2048), NodeBox(),
            [&](const tbb::blocked_range<size_t>& r, NodeBox box) {
              for (size_t t = r.begin(); t < r.end(); ++t) {
                const LatticeTriangle& l = triangles[t];
                const WindingTriangle w = windingTriangleBasics(l);
                TreeKey& k = b.keys[t];
                TreeSums& s = b.sums[0][t];
                for (int a = 0; a < 3; ++a) {
                  k.key[size_t(a)] = int64_t(l.v[0][a]) + l.v[1][a] + l.v[2][a];
                  s.lo[a] = std::min({l.v[0][a], l.v[1][a], l.v[2][a]});
                  s.hi[a] = std::max({l.v[0][a], l.v[1][a], l.v[2][a]});
                  s.halfCross[a] = w.halfCross[a];
                  s.centroid[a] = w.centroid[a];
                }
                s.area = w.area;
                k.triangle = uint32_t(t);
                k.at = uint32_t(t);
                box.add(s, k);
              }
              return box;
            },
            [](NodeBox x, const NodeBox& y) {
              x.add(y);
              return x;
            });
        tree.nodes.resize(1 + size_t(nodesBelow(uint32_t(n))));
        b.fill(0, 0, uint32_t(n), 1, root, 0);
        // The keys' order read out before the triangles overwrite them; each shape
        // computed again in tree order rather than kept from above: an array of
        // them in input order would only be copied, its pages faulted in.
        tbb::parallel_for(size_t(0), n, [&](size_t i) { tree.lattice[i] = triangles[b.keys[i].triangle]; });
        tbb::parallel_for(size_t(0), n,
                          [&](size_t i) { new (&tree.triangles[i]) WindingTriangle(windingTriangle(tree.lattice[i])); });
      },
      [&] { buildWindingEdges(triangles, tree); });
  return tree;
}

namespace {

using Corner = std::array<int32_t, 3>;

// A triangle's directed edge by its corners in lexicographic order.
struct DirectedEdge {
  Corner lo, hi;
  int32_t sign; // +1: the triangle runs lo -> hi
};

// The corners' lexicographic order, element by element (std::array's
// operators compare through memcmp calls).
bool cornerLess(const Corner& x, const Corner& y) {
  return x[0] != y[0] ? x[0] < y[0] : x[1] != y[1] ? x[1] < y[1] : x[2] < y[2];
}
bool sameCorner(const Corner& x, const Corner& y) { return x[0] == y[0] && x[1] == y[1] && x[2] == y[2]; }
bool edgeLess(const DirectedEdge& x, const DirectedEdge& y) {
  return !sameCorner(x.lo, y.lo) ? cornerLess(x.lo, y.lo) : cornerLess(x.hi, y.hi);
}
bool sameEdge(const DirectedEdge& x, const DirectedEdge& y) { return sameCorner(x.lo, y.lo) && sameCorner(x.hi, y.hi); }

DirectedEdge directedEdge(const LatticeTriangle& t, int j) {
  const Corner from{t.v[j][0], t.v[j][1], t.v[j][2]};
  const Corner to{t.v[(j + 1) % 3][0], t.v[(j + 1) % 3][1], t.v[(j + 1) % 3][2]};
  return cornerLess(from, to) ? DirectedEdge{from, to, 1} : DirectedEdge{to, from, -1};
}

// The top `bits` bits of a hash of the edge's corners: equal edges land in
// the same bucket, different ones spread evenly over the buckets.
uint32_t edgeBucket(const DirectedEdge& e, int bits) {
  uint64_t h = 0x9e3779b97f4a7c15ull;
  for (int a = 0; a < 3; ++a) {
    h = (h ^ uint32_t(e.lo[size_t(a)])) * 0xff51afd7ed558ccdull;
    h = (h ^ uint32_t(e.hi[size_t(a)])) * 0xc4ceb9fe1a85ec53ull;
  }
  h ^= h >> 29;
  return bits == 0 ? 0 : uint32_t(h >> (64 - bits));
}

// An edge with a nonzero net count, with the key of the final order.
struct KeyedEdge {
  uint64_t key; // Morton key of the midpoint
  Corner lo, hi;
  int count;
};

// Interleaves the low 21 bits of x, y, z (x lowest).
uint64_t mortonKey(uint64_t x, uint64_t y, uint64_t z) {
  uint64_t key = 0;
  for (int b = 0; b < 21; ++b)
    key |= (((x >> b) & 1) << (3 * b)) | (((y >> b) & 1) << (3 * b + 1)) | (((z >> b) & 1) << (3 * b + 2));
  return key;
}

// The directed edges with a nonzero net count, in no particular order. The
// edges are scattered into buckets by a hash of their corners (a counting
// pass and a scatter pass over chunks of triangles, in parallel), then each
// bucket, small and in cache, is sorted by corners and its runs of equal
// edges summed: the nets do not depend on the order within a run, so the
// set is that of one sort of all the edges.
std::vector<KeyedEdge> openEdges(const LatticeTriangles& triangles) {
  const size_t edges = 3 * triangles.size();
  int bits = 0;
  // About 64 edges a bucket, at most 4096 buckets: the scatter's write
  // streams stay few enough for the caches (65,536 made 6 M edges slower
  // than one sort); a bucket of 1,500 edges still sorts in cache.
  while ((size_t(64) << bits) < edges && bits < 12) ++bits;
  const size_t buckets = size_t(1) << bits;
  // Up to 32 chunks of at least 16,384 triangles: the counts stay below 8 MB.
  const size_t chunks = std::min<size_t>(32, std::max<size_t>(1, triangles.size() / 16384));
  const size_t chunkTriangles = (triangles.size() + chunks - 1) / chunks;
  // start[c * buckets + b]: where chunk c's edges of bucket b go, buckets in
  // order and the chunks in order within each.
  std::vector<uint32_t> start(chunks * buckets + 1, 0);
  const auto chunkRange = [&](size_t c) {
    return std::make_pair(c * chunkTriangles, std::min(triangles.size(), (c + 1) * chunkTriangles));
  };
  tbb::parallel_for(size_t(0), chunks, [&](size_t c) {
    uint32_t* count = start.data() + c * buckets;
    for (size_t t = chunkRange(c).first; t < chunkRange(c).second; ++t)
      for (int j = 0; j < 3; ++j) ++count[edgeBucket(directedEdge(triangles[t], j), bits)];
  });
  std::vector<uint32_t> bucketStart(buckets + 1);
  uint32_t sum = 0;
  for (size_t b = 0; b < buckets; ++b) {
    bucketStart[b] = sum;
    for (size_t c = 0; c < chunks; ++c) {
      const uint32_t n = start[c * buckets + b];
      start[c * buckets + b] = sum;
      sum += n;
    }
  }
  bucketStart[buckets] = sum;
  std::vector<DirectedEdge, HugePageScratchAllocator<DirectedEdge>> all(edges); // each written below
  tbb::parallel_for(size_t(0), chunks, [&](size_t c) {
    uint32_t* next = start.data() + c * buckets;
    for (size_t t = chunkRange(c).first; t < chunkRange(c).second; ++t)
      for (int j = 0; j < 3; ++j) {
        const DirectedEdge e = directedEdge(triangles[t], j);
        all[next[edgeBucket(e, bits)]++] = e;
      }
  });
  tbb::enumerable_thread_specific<std::vector<KeyedEdge>> found;
  tbb::parallel_for(tbb::blocked_range<size_t>(0, buckets, 64), [&](const tbb::blocked_range<size_t>& r) {
    std::vector<KeyedEdge>& mine = found.local();
    for (size_t b = r.begin(); b < r.end(); ++b) {
      const auto first = all.begin() + bucketStart[b], last = all.begin() + bucketStart[b + 1];
      std::sort(first, last, edgeLess);
      for (auto i = first; i != last;) {
        auto j = i;
        int net = 0;
        for (; j != last && sameEdge(*j, *i); ++j) net += j->sign;
        if (net != 0) {
          // Midpoint key in whole voxels (lattice coordinates are non-negative).
          const auto mid = [&](int a) { return uint64_t((int64_t(i->lo[size_t(a)]) + i->hi[size_t(a)]) / 512); };
          mine.push_back({mortonKey(mid(0), mid(1), mid(2)), i->lo, i->hi, net});
        }
        i = j;
      }
    }
  });
  std::vector<KeyedEdge> open;
  for (const std::vector<KeyedEdge>& v : found) open.insert(open.end(), v.begin(), v.end());
  return open;
}

} // namespace

uint64_t windingTreeDigest(const WindingTree& t) {
  uint64_t h = 14695981039346656037ull;
  const auto add = [&h](const void* data, size_t bytes) {
    const unsigned char* p = static_cast<const unsigned char*>(data);
    for (size_t i = 0; i < bytes; ++i) h = (h ^ p[i]) * 1099511628211ull;
  };
  add(t.nodes.data(), t.nodes.size() * sizeof(t.nodes[0]));
  add(t.triangles.data(), t.triangles.size() * sizeof(t.triangles[0]));
  add(t.lattice.data(), t.lattice.size() * sizeof(t.lattice[0]));
  add(t.edges.data(), t.edges.size() * sizeof(t.edges[0]));
  add(t.edgeGroups.data(), t.edgeGroups.size() * sizeof(t.edgeGroups[0]));
  return h;
}

void buildWindingEdges(const LatticeTriangles& triangles, WindingTree& tree) {
  using Keyed = KeyedEdge;
  std::vector<Keyed> open = openEdges(triangles);
  // A total order (the corners tell distinct edges apart): the same list
  // whatever order openEdges found them in.
  tbb::parallel_sort(open.begin(), open.end(), [&](const Keyed& x, const Keyed& y) {
    if (x.key != y.key) return x.key < y.key;
    return !sameCorner(x.lo, y.lo) ? cornerLess(x.lo, y.lo) : cornerLess(x.hi, y.hi);
  });
  tree.edges.clear();
  tree.edgeGroups.clear();
  for (const Keyed& k : open) {
    WindingEdge e;
    for (int a = 0; a < 3; ++a) {
      e.a[a] = double(k.lo[size_t(a)]) / double(kLatticePerVoxel);
      e.b[a] = double(k.hi[size_t(a)]) / double(kLatticePerVoxel);
      e.lo[a] = std::min(e.a[a], e.b[a]);
      e.hi[a] = std::max(e.a[a], e.b[a]);
    }
    e.weight = double(std::abs(k.count));
    e.net = double(k.count);
    const double dx = e.b[0] - e.a[0], dy = e.b[1] - e.a[1], dz = e.b[2] - e.a[2];
    e.length = std::sqrt(dx * dx + dy * dy + dz * dz) * (1 + 1e-12); // covers the root's rounding
    tree.edges.push_back(e);
  }
  for (uint32_t first = 0; first < tree.edges.size(); first += kWindingEdgeGroup) {
    WindingEdgeGroup g{};
    g.first = first;
    g.count = std::min<uint32_t>(kWindingEdgeGroup, uint32_t(tree.edges.size()) - first);
    for (int a = 0; a < 3; ++a) {
      g.lo[a] = INFINITY;
      g.hi[a] = -INFINITY;
    }
    for (uint32_t i = first; i < first + g.count; ++i) {
      const WindingEdge& e = tree.edges[i];
      for (int a = 0; a < 3; ++a) {
        g.lo[a] = std::min(g.lo[a], e.lo[a]);
        g.hi[a] = std::max(g.hi[a], e.hi[a]);
      }
      g.weightedLength += e.weight * e.length;
      g.weight += e.weight;
    }
    g.weightedLength *= 1 + 1e-12; // the sum's rounding
    tree.edgeGroups.push_back(g);
  }
}

InsideTest resolveInsideTest(InsideTest requested, bool closedMesh) {
  if (requested != InsideTest::Auto) return requested;
  return closedMesh ? InsideTest::Parity : InsideTest::WindingNumber;
}

const char* insideTestName(InsideTest test) {
  switch (test) {
  case InsideTest::Auto: return "auto";
  case InsideTest::Parity: return "parity";
  case InsideTest::WindingNumber: return "winding";
  }
  return "unknown";
}

std::string insideTestReason(InsideTest requested, InsideTest ran, bool closedMesh) {
  const std::string mesh = closedMesh ? "the mesh is closed" : "the mesh is open";
  if (requested == InsideTest::Auto) {
    return "Auto: " + mesh + (ran == InsideTest::WindingNumber ? ", winding number" : ", exact ray parity");
  }
  return std::string(ran == InsideTest::Parity ? "Parity" : "Winding number") + " as requested; " + mesh;
}

namespace {

// Sets the inside plane of the non-surface voxels of box b in one leaf.
void settleLeafBox(uint32_t* words, int L, const VoxelBox& b, bool inside) {
  if (!inside) return; // the plane was cleared first
  for (int z = b.lo[2]; z < b.hi[2]; ++z)
    for (int y = b.lo[1]; y < b.hi[1]; ++y)
      for (int x = b.lo[0]; x < b.hi[0]; ++x) {
        const uint32_t v = uint32_t(x + L * (y + L * z));
        uint32_t& w = words[v / kVoxelsPerWord];
        const uint32_t shift = 2 * (v % kVoxelsPerWord);
        if (((w >> shift) & 3u) == 0) w |= 1u << shift;
      }
}

bool hasSurfaceVoxel(const LeafView& view, const VoxelBox& b) {
  for (int z = b.lo[2]; z < b.hi[2]; ++z)
    for (int y = b.lo[1]; y < b.hi[1]; ++y)
      for (int x = b.lo[0]; x < b.hi[0]; ++x)
        if (view.voxel(x, y, z) == VoxelState::Surface) return true;
  return false;
}

// The per-voxel decision (windingDecideBox) of the non-surface voxels of a
// leaf that `decided` does not mark (all of them when decided is empty).
void decideLeafVoxels(const WindingTreeView& t, uint32_t* words, int L, const std::array<int, 3>& origin,
                      const std::vector<uint8_t>& decided) {
  const LeafView view{words, L};
  VoxelBox box;
  for (int a = 0; a < 3; ++a) {
    box.lo[a] = origin[size_t(a)];
    box.hi[a] = origin[size_t(a)] + L;
  }
  auto local = [&](const VoxelBox& b) {
    VoxelBox l = b;
    for (int a = 0; a < 3; ++a) {
      l.lo[a] -= origin[size_t(a)];
      l.hi[a] -= origin[size_t(a)];
    }
    return l;
  };
  auto settled = [&](int x, int y, int z) {
    return view.voxel(x, y, z) == VoxelState::Surface || (!decided.empty() && decided[size_t(x + L * (y + L * z))]);
  };
  windingDecideBox(
      t, box,
      [&](const VoxelBox& b) { // nothing left to decide in b
        const VoxelBox l = local(b);
        for (int z = l.lo[2]; z < l.hi[2]; ++z)
          for (int y = l.lo[1]; y < l.hi[1]; ++y)
            for (int x = l.lo[0]; x < l.hi[0]; ++x)
              if (!settled(x, y, z)) return false;
        return true;
      },
      [&](const VoxelBox& b) { return hasSurfaceVoxel(view, local(b)); },
      [&](const VoxelBox& b, bool inside) { settleLeafBox(words, L, local(b), inside); }, [] { return false; });
}

// One leaf: each face-connected piece of its non-surface voxels is decided
// from one certified sum at its seed carried along the pieces' paths
// (windingGradientBound over the piece's box); the voxels it leaves unsure
// take the per-voxel decision.
void classifyLeaf(const WindingTreeView& t, uint32_t* words, int L, const std::array<int, 3>& origin) {
  for (uint32_t i = 0; i < leafWordCount(L); ++i) words[i] &= kSurfacePlaneBits;
  const LeafView view{words, L};
  const size_t n = size_t(L) * size_t(L) * size_t(L);
  // Scratch kept per thread (filling it afresh for every leaf cost more than
  // the leaf's sums): label is written whole by windingLeafPieces, steps,
  // queue and pieces before they are read, visit is compared with a stamp
  // that only grows.
  struct Scratch {
    std::vector<uint16_t> label, steps, queue;
    std::vector<WindingPiece> pieces;
    std::vector<uint32_t> visit;
    uint32_t stamp = 0;
  };
  thread_local Scratch scratch;
  Scratch& sc = scratch;
  if (sc.label.size() < n || sc.stamp > 0xF0000000u) {
    sc.label.resize(n);
    sc.steps.resize(n);
    sc.queue.resize(n);
    sc.pieces.resize(n / 2 + 1);
    sc.visit.assign(n, 0);
    sc.stamp = 0;
  }
  uint16_t* label = sc.label.data();
  const int count = windingLeafPieces(
      L, [&](uint32_t v) { return view.voxel(int(v % uint32_t(L)), int((v / uint32_t(L)) % uint32_t(L)), int(v / uint32_t(L * L))) == VoxelState::Surface; },
      label, sc.steps.data(), sc.queue.data(), sc.pieces.data(), int(n / 2 + 1));
  std::vector<uint8_t> decided(n, 0); // 0 open, 1 decided, 2 per-voxel decision
  for (int k = 0; k < count; ++k) {
    windingCarryPiece(t, L, origin.data(), sc.pieces[size_t(k)], k, label, sc.steps.data(), sc.queue.data(),
                      sc.visit.data(), &sc.stamp, decided.data(), [&](uint32_t v, bool inside) {
                        if (inside) words[v / kVoxelsPerWord] |= 1u << (2 * (v % kVoxelsPerWord));
                      });
  }
  bool allDecided = true;
  for (size_t v = 0; v < n; ++v)
    if (label[v] != 0xFFFF && decided[v] != 1) {
      allDecided = false;
      decided[v] = 0;
    }
  if (count < 0) std::fill(decided.begin(), decided.end(), uint8_t(0));
  if (count < 0 || !allDecided) decideLeafVoxels(t, words, L, origin, decided);
}

// A fresh leaf (a child of a refined uniform element: no surface voxel) by
// windingDecideLeaf, as the volume's leaves: N at each row's last voxel
// centre by one ray walk (windingRayCrossings), the rest of the row from the
// leaf's own crossings (a crossing with `before` = L lies ahead of the last
// centre, so its walk counted it). False when a centre lies on a triangle or
// a count does not fit 16 bits (then classifyLeaf).
bool decideFreshLeaf(const WindingTreeView& t, uint32_t* words, int L, const std::array<int, 3>& origin) {
  thread_local std::vector<int32_t> wide;
  thread_local std::vector<int16_t> counts;
  const size_t n = size_t(L) * size_t(L) * size_t(L);
  wide.resize(n);
  counts.resize(n);
  for (int z = 0; z < L; ++z)
    for (int y = 0; y < L; ++y) {
      const int64_t P[3] = {latticeOfVoxelCentre(origin[0] + L - 1), latticeOfVoxelCentre(origin[1] + y),
                            latticeOfVoxelCentre(origin[2] + z)};
      int count = 0;
      if (!windingRayCrossings(t, P, count)) return false;
      std::fill_n(wide.data() + size_t(y + L * z) * size_t(L), L, count);
    }
  windingForEachLeafCrossing(t, origin.data(), L, [&](int row, int before, int sign) {
    if (before >= L) return;
    for (int x = 0; x < before; ++x) wide[size_t(row) * size_t(L) + size_t(x)] += sign;
  });
  for (size_t v = 0; v < n; ++v) {
    if (wide[v] < INT16_MIN || wide[v] > INT16_MAX) return false;
    counts[v] = int16_t(wide[v]);
  }
  windingDecideLeafLinear(t, L, origin.data(), words, counts.data(), words);
  return true;
}

// Leaves and uniform elements are grouped in aligned blocks of kCoarseLeaves
// leaf edges a side; a block that no strip sheet meets and whose K range holds
// no tie (windingBoxThreshold over the block's voxel centres) certifies one
// threshold T for every point in it: inside iff N >= T. A leaf in it is
// settled by T at once (the verdict windingDecideLeaf's first step would
// certify leaf by leaf); a uniform element in it takes the verdict of one of
// its voxel centres (N there by one ray walk): w is continuous over the
// element (no triangle touches it) and never 1/2 in the block.
constexpr int kCoarseLeaves = 4;

uint64_t coarseKey(const std::array<int, 3>& origin, int blockEdge) {
  return mortonKey(uint64_t(origin[0] / blockEdge), uint64_t(origin[1] / blockEdge), uint64_t(origin[2] / blockEdge));
}

struct CoarseThresholds {
  int blockEdge = 0;
  std::vector<uint64_t> keys; // ascending block keys
  std::vector<int> T;
  std::vector<uint8_t> holds;
  // The threshold of the block holding the voxel `origin`, or false.
  bool find(const std::array<int, 3>& origin, int& threshold) const {
    const auto it = std::lower_bound(keys.begin(), keys.end(), coarseKey(origin, blockEdge));
    if (it == keys.end() || *it != coarseKey(origin, blockEdge) || !holds[size_t(it - keys.begin())]) return false;
    threshold = T[size_t(it - keys.begin())];
    return true;
  }
};

// The blocks holding the voxels `origins`, each clipped to the volume's
// `resolution` voxels a side.
CoarseThresholds coarseThresholds(const WindingTreeView& t, const std::vector<std::array<int, 3>>& origins, int L,
                                  int resolution, ProgressPoll* progress) {
  const int blockEdge = kCoarseLeaves * L;
  CoarseThresholds c;
  c.blockEdge = blockEdge;
  c.keys.reserve(origins.size());
  for (const std::array<int, 3>& o : origins) c.keys.push_back(coarseKey(o, blockEdge));
  std::sort(c.keys.begin(), c.keys.end());
  c.keys.erase(std::unique(c.keys.begin(), c.keys.end()), c.keys.end());
  c.T.assign(c.keys.size(), 0);
  c.holds.assign(c.keys.size(), 0);
  std::vector<std::array<int, 3>> corner(c.keys.size());
  for (const std::array<int, 3>& o : origins) {
    const uint64_t key = coarseKey(o, blockEdge);
    const size_t i = size_t(std::lower_bound(c.keys.begin(), c.keys.end(), key) - c.keys.begin());
    for (int a = 0; a < 3; ++a) corner[i][size_t(a)] = o[size_t(a)] / blockEdge * blockEdge;
  }
  tbb::parallel_for(size_t(0), c.keys.size(), [&](size_t i) {
    if (abortRequested(progress)) return;
    double lo[3], hi[3];
    for (int a = 0; a < 3; ++a) {
      lo[a] = corner[i][size_t(a)] + 0.5;
      hi[a] = std::min(corner[i][size_t(a)] + blockEdge, resolution) - 0.5;
    }
    double gradient = INFINITY;
    c.holds[i] = !windingSheetsMeetBox(t, lo, hi) && windingBoxThreshold(t, lo, hi, c.T[i], gradient);
  });
  return c;
}

// A uniform element's verdict: inside, or split when its voxel centres lie
// on both sides of w = 1/2 (then it must be refined).
struct UniformVerdict {
  bool inside = false;
  bool split = false;
};

// Decided box by box (windingDecideBox): each box first tries one certified
// sum at its centre carried to its voxel centres (windingCarriedBoxVerdict).
UniformVerdict classifyUniform(const WindingTreeView& t, const std::array<int, 3>& origin, int edge) {
  VoxelBox box;
  for (int a = 0; a < 3; ++a) {
    box.lo[a] = origin[size_t(a)];
    box.hi[a] = origin[size_t(a)] + edge;
  }
  bool seen[2] = {false, false};
  windingDecideBox(
      t, box, [](const VoxelBox&) { return false; }, [](const VoxelBox&) { return false; },
      [&](const VoxelBox&, bool inside) { seen[inside] = true; },
      [&] { return seen[0] && seen[1]; });
  if (seen[0] && seen[1]) return {false, true};
  return {seen[1], false};
}

// An element within a block whose threshold holds: N at one voxel centre
// against T. False when the ray walk cannot say (then classifyUniform).
bool uniformByBlock(const WindingTreeView& t, const WindingUniformJob& job, const CoarseThresholds* coarse,
                    UniformVerdict& verdict) {
  int T = 0;
  if (coarse == nullptr || job.edge > coarse->blockEdge || !coarse->find(job.origin, T)) return false;
  const int64_t P[3] = {latticeOfVoxelCentre(job.origin[0] + job.edge / 2),
                        latticeOfVoxelCentre(job.origin[1] + job.edge / 2),
                        latticeOfVoxelCentre(job.origin[2] + job.edge / 2)};
  int N = 0;
  if (!windingRayCrossings(t, P, N)) return false;
  verdict = UniformVerdict{N >= T, false};
  return true;
}

// The verdicts of uniform elements: by the pass when there is one and it
// runs (verdict bit 0 inside, bit 1 split), here otherwise (by their block's
// threshold where `coarse` has one, else classifyUniform).
std::vector<UniformVerdict> decideUniformJobs(const WindingTree& tree, const std::vector<WindingUniformJob>& jobs,
                                              const WindingUniformPass& pass, ProgressPoll* progress,
                                              const CoarseThresholds* coarse = nullptr) {
  std::vector<UniformVerdict> out(jobs.size());
  std::vector<uint8_t> verdicts;
  if (pass && pass(tree, jobs, verdicts)) {
    for (size_t i = 0; i < jobs.size(); ++i) out[i] = UniformVerdict{(verdicts[i] & 1) != 0, (verdicts[i] & 2) != 0};
    return out;
  }
  const WindingTreeView t = tree.view();
  tbb::parallel_for(size_t(0), jobs.size(), [&](size_t i) {
    if (abortRequested(progress)) return;
    if (!uniformByBlock(t, jobs[i], coarse, out[i])) out[i] = classifyUniform(t, jobs[i].origin, jobs[i].edge);
  });
  return out;
}

std::array<int, 3> childOrigin(const std::array<int, 3>& o, int edge, int c) {
  const int h = edge / 2;
  return {o[0] + (c & 1) * h, o[1] + ((c >> 1) & 1) * h, o[2] + ((c >> 2) & 1) * h};
}

// An element of the refined layout: an old one (by index) or a new child of
// a split element.
// No member initializers: a level is sized unwritten (LaidLevel) and each
// element written whole, `LaidElement()` (zeros) first.
struct LaidElement {
  uint64_t old;
  bool fresh;
  bool split;
  bool inside; // fresh uniform elements
  std::array<int, 3> origin;
};
// One level of the refined layout (tens of MB at 8192^3: huge pages, sized
// without writing it, then written in parallel).
using LaidLevel = std::vector<LaidElement, HugePageScratchAllocator<LaidElement>>;

// Counts carried along a level by scanInChunks.
struct LaySums {
  uint64_t a = 0, b = 0;
  LaySums& operator+=(const LaySums& o) {
    a += o.a;
    b += o.b;
    return *this;
  }
};

// A serial loop `for i in [0, n): step(i, sums, write)` run in parallel:
// the chunks counted first (write false), then sized(total) (the outputs
// sized), then each chunk walked again from the sums of those before it
// (write true). The results are the serial loop's. (Not tbb::parallel_scan:
// its final pass may start before every chunk is counted, and the outputs
// are sized from the total first.)
template <class Step, class Sized>
LaySums scanInChunks(size_t n, const Step& step, const Sized& sized) {
  constexpr size_t kChunk = 8192;
  const size_t chunks = (n + kChunk - 1) / kChunk;
  std::vector<LaySums> before(chunks + 1);
  tbb::parallel_for(size_t(0), chunks, [&](size_t c) {
    LaySums s;
    for (size_t i = c * kChunk, end = std::min(n, i + kChunk); i < end; ++i) step(i, s, false);
    before[c + 1] = s;
  });
  for (size_t c = 0; c < chunks; ++c) before[c + 1] += before[c];
  sized(before[chunks]);
  tbb::parallel_for(size_t(0), chunks, [&](size_t c) {
    LaySums s = before[c];
    for (size_t i = c * kChunk, end = std::min(n, i + kChunk); i < end; ++i) step(i, s, true);
  });
  return before[chunks];
}

// Element payloads (branch places, leaf indices) hold 30 bits.
[[noreturn]] void throwRefinementTooLarge() {
  throw Error(ErrorKind::OutOfResources, "refining the winding number's w = 1/2 surface exceeds 2^30 elements");
}

// The elements of the refined layout from its levels (LaidElement, level
// order), each level in parallel: Branch payloads and leaf indices are prefix
// sums. Returns the number of leaves (old and fresh).
uint64_t layOutRefined(const Volume& v, const std::vector<LaidLevel>& levels, std::vector<uint64_t>& levelStart,
                       std::vector<ElementWord>& elements) {
  const int height = v.grid.height;
  for (int k = 0; k <= height; ++k) levelStart[size_t(k) + 1] = levelStart[size_t(k)] + levels[size_t(k)].size();
  if (levelStart.back() - 1 > kMaxElementPayload) throwRefinementTooLarge();
  elements.resize(levelStart.back());
  uint64_t leaves = 0;
  for (int k = 0; k <= height; ++k) {
    const LaidLevel& level = levels[size_t(k)];
    ElementWord* out = elements.data() + levelStart[size_t(k)];
    const uint64_t leafBase = leaves;
    // a: branches before element i, b: leaves.
    leaves += scanInChunks(
                  level.size(),
                  [&](size_t i, LaySums& s, bool write) {
                    const LaidElement& e = level[i];
                    const ElementWord old = e.fresh
                                                ? makeElement(e.inside ? ElementState::Full : ElementState::Empty, 0)
                                                : v.elements[e.old];
                    const ElementState state = elementState(old);
                    if (state == ElementState::Branch || (e.split && k < height)) {
                      if (write) out[i] = makeElement(ElementState::Branch, uint32_t(levelStart[size_t(k) + 1] + 8 * s.a));
                      ++s.a;
                    } else if (state == ElementState::Boundary || e.split) {
                      if (write) out[i] = makeElement(ElementState::Boundary, uint32_t(leafBase + s.b));
                      ++s.b;
                    } else if (write) {
                      out[i] = old;
                    }
                  },
                  [&](const LaySums& sums) {
                    if (leafBase + sums.b > kMaxElementPayload) throwRefinementTooLarge();
                  })
                  .b;
  }
  return leaves;
}

// Copies the old leaves' words into the refined layout: old leaf l goes to
// l + (fresh leaves before it), where fresh leaf j has cuts[j] old leaves
// before it (cuts ascending). Runs of old leaves between two fresh ones move
// by one offset: copied in blocks, in parallel.
void copyOldLeaves(const uint32_t* from, uint64_t oldLeaves, const std::vector<uint64_t>& cuts, uint32_t wc,
                   uint32_t* to) {
  constexpr uint64_t kBlock = 1024; // leaves
  tbb::parallel_for(uint64_t(0), (oldLeaves + kBlock - 1) / kBlock, [&](uint64_t block) {
    uint64_t l = block * kBlock;
    const uint64_t end = std::min(oldLeaves, l + kBlock);
    // fresh leaves before old leaf l: those with cuts[j] <= l
    uint64_t j = uint64_t(std::upper_bound(cuts.begin(), cuts.end(), l) - cuts.begin());
    while (l < end) {
      const uint64_t runEnd = j < cuts.size() ? std::min(end, cuts[j]) : end;
      std::copy(from + l * wc, from + runEnd * wc, to + (l + j) * wc);
      l = runEnd;
      while (j < cuts.size() && cuts[j] <= l) ++j;
    }
  });
}

// Re-lays the tree in canonical level order with every split uniform element
// refined: a Branch of 8 fresh children above the last level, a Boundary
// with a new leaf grid (no surface voxel; every centre decided) at it.
// Each level is laid out in parallel (scanInChunks: the places of children,
// branches and leaves are prefix sums). Returns the number of elements refined.
uint64_t refineSplitElements(const WindingTree& tree, Volume& v, const std::vector<uint8_t>& split,
                             const WindingUniformPass& uniformPass, const WindingFreshLeafPass& freshPass,
                             ProgressPoll* progress) {
  auto t0 = std::chrono::steady_clock::now();
  const WindingTreeView t = tree.view();
  const GridSpec& g = v.grid;
  const int L = g.leafSize, height = g.height;
  const uint64_t R = uint64_t(g.rootGrid);
  std::vector<LaidLevel> levels(size_t(height) + 1);
  levels[0].resize(R * R * R);
  tbb::parallel_for(uint64_t(0), R * R * R, [&](uint64_t i) {
    LaidElement& e = levels[0][i];
    e = LaidElement();
    e.old = i;
    e.split = split[i];
    const int edge = g.rootCellVoxels();
    e.origin = {int(i % R) * edge, int((i / R) % R) * edge, int(i / (R * R)) * edge};
  });
  uint64_t refined = 0;
  double passMs = 0; // the fresh children's passes
  for (int k = 0; k < height; ++k) {
    const LaidLevel& level = levels[size_t(k)];
    LaidLevel& next = levels[size_t(k) + 1];
    const int edge = g.elementVoxels(k), childEdge = g.elementVoxels(k + 1);
    std::vector<WindingUniformJob> jobs; // the fresh children
    std::vector<uint64_t> at;            // their places in next
    // a: children before element i, b: split elements before it (each has 8
    // fresh children, the jobs).
    const LaySums total = scanInChunks(
        level.size(),
        [&](size_t i, LaySums& s, bool write) {
          const LaidElement& e = level[i];
          const bool oldBranch = !e.fresh && elementState(v.elements[e.old]) == ElementState::Branch;
          if (!oldBranch && !e.split) return;
          for (int c = 0; write && c < 8; ++c) {
            LaidElement& child = next[s.a + uint64_t(c)];
            child = LaidElement();
            child.origin = childOrigin(e.origin, edge, c);
            if (oldBranch) {
              child.old = uint64_t(elementPayload(v.elements[e.old])) + uint64_t(c);
              child.split = split[child.old];
            } else {
              child.fresh = true;
              jobs[8 * s.b + uint64_t(c)] = {0, child.origin, childEdge};
              at[8 * s.b + uint64_t(c)] = s.a + uint64_t(c);
            }
          }
          s.a += 8;
          s.b += e.split;
        },
        [&](const LaySums& sums) {
          next.resize(sums.a);
          jobs.resize(8 * sums.b);
          at.resize(8 * sums.b);
        });
    refined += total.b;
    if (jobs.empty()) continue; // no pass to run (nor a device call to make)
    const auto passStart = std::chrono::steady_clock::now();
    const std::vector<UniformVerdict> verdicts = decideUniformJobs(tree, jobs, uniformPass, progress);
    reportWinding(progress, 0.85 + 0.05 * double(k + 1) / double(height));
    passMs += std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - passStart).count();
    tbb::parallel_for(size_t(0), jobs.size(), [&](size_t j) {
      next[at[j]].inside = verdicts[j].inside;
      next[at[j]].split = verdicts[j].split;
    });
  }
  for (const LaidElement& e : levels[size_t(height)]) refined += e.split;
  traceWinding("re-lay: levels (fresh children's passes included)", t0);
  traceWindingMs("re-lay: fresh children's passes", passMs);
  t0 = std::chrono::steady_clock::now();

  // The fresh leaves: the split elements of the last level, in level order,
  // and the old leaves before each. Old leaves keep their order (a level's
  // old elements do, and leaf i is the i-th Boundary element); the leaves
  // of the last level follow those above it.
  const LaidLevel& last = levels[size_t(height)];
  const uint32_t wc = leafWordCount(L);
  const uint64_t oldLeaves = v.leafWords.size() / wc;
  std::vector<std::array<int, 3>> freshLeaves;
  std::vector<uint64_t> cuts; // old leaves before fresh leaf j
  uint64_t lastBase = 0;      // old leaves above the last level
  {
    std::atomic<bool> canonical{true}; // each old leaf where its order says
    // a: fresh leaves before element i, b: old leaves of the last level before it.
    scanInChunks(
        last.size(),
        [&](size_t i, LaySums& s, bool write) {
          const LaidElement& e = last[i];
          if (e.split) {
            if (write) {
              freshLeaves[s.a] = e.origin;
              cuts[s.a] = lastBase + s.b;
            }
            ++s.a;
          } else if (!e.fresh && elementState(v.elements[e.old]) == ElementState::Boundary) {
            if (write && elementPayload(v.elements[e.old]) != lastBase + s.b) canonical = false;
            ++s.b;
          }
        },
        [&](const LaySums& sums) {
          if (sums.b > oldLeaves) throw std::logic_error("refined layout: more leaves than leaf grids");
          lastBase = oldLeaves - sums.b;
          freshLeaves.resize(sums.a);
          cuts.resize(sums.a);
        });
    if (!canonical) throw std::logic_error("refined layout: the volume's leaves are not in level order");
  }
  // The new elements and the old leaves' words (host work) on a host thread
  // while the fresh leaves' pass runs (on the device, in the CUDA driver).
  std::vector<uint64_t> levelStart(size_t(height) + 2, 0);
  std::vector<ElementWord> elements;
  LeafWordVector words;
  auto layout = std::async(std::launch::async, [&] {
    uint64_t leaves = 0;
    tbb::parallel_invoke([&] { leaves = layOutRefined(v, levels, levelStart, elements); },
                         [&] {
                           words.resize((oldLeaves + freshLeaves.size()) * wc);
                           // written once below: few page faults
                           adviseHugePages(words.data(), words.size() * sizeof(uint32_t));
                           copyOldLeaves(v.leafWords.data(), oldLeaves, cuts, wc, words.data());
                         });
    if (leaves != oldLeaves + freshLeaves.size()) throw std::logic_error("refined layout: leaves out of step");
  });
  // Fresh leaves by the pass first (into their own array), the rest below.
  // (Should the pass throw, `layout`'s destructor waits for the task before
  // what it writes is destroyed: a future of std::async does.)
  std::vector<uint32_t> freshWords;
  std::vector<uint8_t> freshDone(freshLeaves.size(), 0);
  if (freshPass && !freshLeaves.empty()) {
    freshWords.assign(freshLeaves.size() * wc, 0u);
    std::vector<uint32_t> left;
    if (freshPass(tree, L, freshLeaves, freshWords.data(), left)) {
      std::fill(freshDone.begin(), freshDone.end(), uint8_t(1));
      for (uint32_t i : left) freshDone[i] = 0;
    }
  }
  traceWinding("re-lay: fresh leaves' pass", t0);
  layout.get();
  traceWinding("re-lay: elements and old leaves (beside the fresh leaves' pass)", t0);
  t0 = std::chrono::steady_clock::now();
  tbb::parallel_for(size_t(0), freshLeaves.size(), [&](size_t f) {
    if (abortRequested(progress)) return;
    uint32_t* to = words.data() + (cuts[f] + f) * wc;
    if (freshDone[f]) {
      std::copy_n(freshWords.data() + f * wc, wc, to);
    } else {
      std::fill_n(to, wc, 0u);
      if (!decideFreshLeaf(t, to, L, freshLeaves[f])) classifyLeaf(t, to, L, freshLeaves[f]);
    }
  });
  v.elements = std::move(elements);
  v.levelStart = std::move(levelStart);
  v.leafWords = std::move(words);
  traceWinding("re-lay: fresh leaves' words", t0);
  return refined;
}

// ---- leaves from signed crossing counts (winding_leaf.hpp) --------------------

// One +x crossing of a leaf's row (windingForEachLeafCrossing): it counts
// for the row's voxel centres x < before.
struct LeafCrossing {
  uint16_t row;
  uint8_t before;
  int8_t sign;
};

// One leaf's crossings, in the pool of the thread that found them (a vector
// that grows to many MB: huge pages, fewer page faults).
using LeafCrossingPool = std::vector<LeafCrossing, HugePageAllocator<LeafCrossing>>;
struct LeafCrossingSpan {
  const LeafCrossingPool* pool = nullptr;
  size_t first = 0, count = 0;
  const LeafCrossing* begin() const { return pool->data() + first; }
  const LeafCrossing* end() const { return pool->data() + first + count; }
};

// A leaf in a block whose threshold holds: the surface plane kept, each
// non-surface voxel inside iff its count N >= T. A row's count is the count
// beyond the leaf (`exit`) up to its last crossing, so a row with no crossing
// before its end is one bit; the others are walked down from `exit` with
// their crossings. Whole words then (withInsidePlane), no count array.
void settleLeafByThreshold(uint32_t* words, int L, const int32_t* exit, const LeafCrossingSpan& crossings, int T) {
  // step[row L + x]: the crossings counting from x down; all zero between
  // leaves (the entries set here are cleared at the end, not the whole array).
  thread_local std::vector<int32_t> step;
  if (step.size() < size_t(L) * size_t(L) * size_t(L)) step.assign(size_t(L) * size_t(L) * size_t(L), 0);
  uint32_t rows[32 * 32];    // bit x: N >= T at voxel x of the row
  uint32_t pending[32] = {}; // rows with a crossing before their end, not yet walked
  const uint32_t all = L == 32 ? 0xFFFFFFFFu : (1u << L) - 1u;
  for (int row = 0; row < L * L; ++row) rows[row] = exit[row] >= T ? all : 0u;
  for (const LeafCrossing& c : crossings)
    if (c.before > 0) {
      step[size_t(c.row) * size_t(L) + size_t(c.before - 1)] += c.sign;
      pending[c.row >> 5] |= 1u << (c.row & 31);
    }
  for (const LeafCrossing& c : crossings) {
    if (!((pending[c.row >> 5] >> (c.row & 31)) & 1u)) continue;
    pending[c.row >> 5] &= ~(1u << (c.row & 31));
    int32_t n = exit[c.row];
    uint32_t mask = 0;
    for (int x = L - 1; x >= 0; --x) {
      n += step[size_t(c.row) * size_t(L) + size_t(x)];
      if (n >= T) mask |= 1u << x;
    }
    rows[c.row] = mask;
  }
  for (uint32_t i = 0; i < leafWordCount(L); ++i) words[i] = withInsidePlane(words[i], wordBitsFromRows(rows, L, int(i)));
  for (const LeafCrossing& c : crossings)
    if (c.before > 0) step[size_t(c.row) * size_t(L) + size_t(c.before - 1)] = 0;
}

// Every leaf of the volume by windingDecideLeaf: the signed crossings of each
// leaf's rows summed per row, their suffix sums along each line of leaves
// (between two leaves of a line lie only uniform elements, which hold no
// triangle) give the count at each row's +x exit, and the leaf's own
// crossings the count at each voxel centre. A leaf whose counts do not fit
// 16 bits takes the pieces-and-seeds decision (classifyLeaf).
void classifyLeavesByCrossings(const WindingTree& tree, Volume& volume,
                               const std::vector<std::array<int, 3>>& origins, const CoarseThresholds& coarse,
                               ProgressPoll* progress) {
  const WindingTreeView t = tree.view();
  const int L = volume.grid.leafSize;
  const size_t rows = size_t(L) * size_t(L), leaves = origins.size();
  // The leaf's own row totals, then the counts beyond it; zeroed leaf by leaf
  // below (huge pages: one array of many MB written once).
  std::vector<int32_t, HugePageScratchAllocator<int32_t>> exits(leaves * rows);
  // Each leaf's crossings, kept for its counts below (one walk of the tree a
  // leaf), appended to its thread's pool (one allocation a thread, not a leaf).
  tbb::enumerable_thread_specific<LeafCrossingPool> pools;
  std::vector<LeafCrossingSpan> crossings(leaves);
  tbb::parallel_for(size_t(0), leaves, [&](size_t leaf) {
    if (abortRequested(progress)) return;
    int32_t* total = exits.data() + leaf * rows;
    std::fill_n(total, rows, 0);
    LeafCrossingPool& pool = pools.local();
    const size_t first = pool.size();
    windingForEachLeafCrossing(t, origins[leaf].data(), L, [&](int row, int before, int sign) {
      total[row] += sign;
      pool.push_back({uint16_t(row), uint8_t(before), int8_t(sign)});
    });
    crossings[leaf] = LeafCrossingSpan{&pool, first, pool.size() - first};
  });
  reportWinding(progress, 0.45); // before anything reads the crossings (an aborted loop left some unwritten)
  // Lines of leaves (same y, z), each walked from its +x end.
  std::vector<uint32_t> order(leaves);
  std::iota(order.begin(), order.end(), 0u);
  std::sort(order.begin(), order.end(), [&](uint32_t a, uint32_t b) {
    const std::array<int, 3>&oa = origins[a], &ob = origins[b];
    if (oa[2] != ob[2]) return oa[2] < ob[2];
    if (oa[1] != ob[1]) return oa[1] < ob[1];
    return oa[0] > ob[0];
  });
  std::vector<size_t> lineStarts;
  for (size_t i = 0; i < leaves; ++i)
    if (i == 0 || origins[order[i]][1] != origins[order[i - 1]][1] || origins[order[i]][2] != origins[order[i - 1]][2])
      lineStarts.push_back(i);
  lineStarts.push_back(leaves);
  tbb::parallel_for(size_t(0), lineStarts.size() - 1, [&](size_t line) {
    std::vector<int32_t> running(rows, 0);
    for (size_t i = lineStarts[line]; i < lineStarts[line + 1]; ++i) {
      int32_t* e = exits.data() + size_t(order[i]) * rows;
      for (size_t r = 0; r < rows; ++r) {
        const int32_t own = e[r];
        e[r] = running[r];
        running[r] += own;
      }
    }
  });
  tbb::parallel_for(size_t(0), leaves, [&](size_t leaf) {
    if (abortRequested(progress)) return;
    thread_local std::vector<int32_t> wide;
    thread_local std::vector<int16_t> counts;
    const size_t n = rows * size_t(L);
    wide.resize(n);
    counts.resize(n);
    const int32_t* exit = exits.data() + leaf * rows;
    uint32_t* words = volume.leafWords.data() + leafWordOffset(leaf, L);
    int T = 0;
    if (coarse.find(origins[leaf], T)) {
      settleLeafByThreshold(words, L, exit, crossings[leaf], T);
      return;
    }
    for (size_t r = 0; r < rows; ++r)
      for (int x = 0; x < L; ++x) wide[r * size_t(L) + size_t(x)] = exit[r];
    for (const LeafCrossing& c : crossings[leaf])
      for (int x = 0; x < c.before; ++x) wide[size_t(c.row) * size_t(L) + size_t(x)] += c.sign;
    bool fits = true;
    for (size_t v = 0; v < n; ++v) {
      fits = fits && wide[v] >= INT16_MIN && wide[v] <= INT16_MAX;
      counts[v] = int16_t(wide[v]);
    }
    if (!fits) {
      classifyLeaf(t, words, L, origins[leaf]);
      return;
    }
    windingDecideLeafLinear(t, L, origins[leaf].data(), words, counts.data(), words);
  });
}

// The walk's units in its order: the elements it stops at above level
// `unitLevel` and the subtrees rooted at that level (up to 64 per root cell
// at level 2: many small tasks, so one dense root cell is not one thread's).
void collectWalkUnits(const Volume& v, const WalkedElement& e, int deepest, int unitLevel,
                      std::vector<WalkedElement>& units) {
  if (e.state() != ElementState::Branch || e.level >= deepest || e.level >= unitLevel) {
    units.push_back(e);
    return;
  }
  for (int c = 0; c < 8; ++c) collectWalkUnits(v, childElement(v, e, c), deepest, unitLevel, units);
}

// The leaves' origins (by leaf index) and the uniform elements in the order
// of walkVolume, the walk's units (collectWalkUnits) in parallel: each unit's
// uniform elements counted by a first walk, written at their place by a second.
void walkForWinding(const Volume& v, int deepest, std::vector<std::array<int, 3>>& leafOrigins,
                    std::vector<WindingUniformJob>& jobs) {
  const auto t0 = std::chrono::steady_clock::now();
  const uint64_t R = uint64_t(v.grid.rootGrid), roots = R * R * R;
  std::vector<WalkedElement> units;
  for (uint64_t r = 0; r < roots; ++r) collectWalkUnits(v, rootElement(v, r), deepest, 2, units);
  const auto uniform = [](const WalkedElement& e) {
    return e.state() == ElementState::Empty || e.state() == ElementState::Full;
  };
  std::vector<uint64_t> start(units.size() + 1, 0);
  tbb::parallel_for(size_t(0), units.size(), [&](size_t u) {
    uint64_t n = 0;
    auto visit = [&](const WalkedElement& e) {
      if (e.state() == ElementState::Boundary) leafOrigins[e.payload()] = e.origin;
      n += uniform(e);
    };
    walkSubtree(v, units[u], deepest, visit);
    start[u + 1] = n;
  });
  std::partial_sum(start.begin(), start.end(), start.begin());
  jobs.resize(start.back());
  tbb::parallel_for(size_t(0), units.size(), [&](size_t u) {
    WindingUniformJob* out = jobs.data() + start[u];
    auto visit = [&](const WalkedElement& e) {
      if (uniform(e)) *out++ = {e.index, e.origin, e.edge};
    };
    walkSubtree(v, units[u], deepest, visit);
  });
  traceWinding("walk of the volume", t0);
}

} // namespace

WindingOutcome classifyByWindingNumber(const WindingTree& tree, Volume& volume) {
  return classifyByWindingNumber(tree, volume, WindingLeafPass());
}

WindingOutcome classifyByWindingNumber(const WindingTree& tree, Volume& volume, const WindingLeafPass& leafPass,
                                       const WindingUniformPass& uniformPass, const WindingFreshLeafPass& freshPass,
                                       ProgressPoll* progress) {
  const WindingTreeView t = tree.view();
  const int L = volume.grid.leafSize;
  std::vector<uint8_t> split(volume.elements.size(), 0);
  bool anySplit = false;
  const int deepest = int(volume.levelStart.size()) - 2;
  const size_t leafCount = volume.leafWords.size() / leafWordCount(L);
  std::vector<std::array<int, 3>> leafOrigins(leafCount);
  std::vector<WindingUniformJob> jobs; // the uniform elements, in walk order
  walkForWinding(volume, deepest, leafOrigins, jobs);
  reportWinding(progress, 0.1);
  // The blocks of the leaves and of the uniform elements that fit in one,
  // for the host's passes.
  CoarseThresholds coarse;
  if (!uniformPass || !leafPass) {
    std::vector<std::array<int, 3>> inBlocks = leafOrigins;
    for (const WindingUniformJob& j : jobs)
      if (j.edge <= kCoarseLeaves * L) inBlocks.push_back(j.origin);
    coarse = coarseThresholds(t, inBlocks, L, volume.grid.resolution, progress);
    reportWinding(progress, 0.15);
  }
  const std::vector<UniformVerdict> verdicts = decideUniformJobs(tree, jobs, uniformPass, progress, &coarse);
  reportWinding(progress, 0.3);
  for (size_t i = 0; i < jobs.size(); ++i) {
    volume.elements[jobs[i].index] = makeElement(verdicts[i].inside ? ElementState::Full : ElementState::Empty, 0);
    if (verdicts[i].split) {
      split[jobs[i].index] = 1;
      anySplit = true;
    }
  }
  std::vector<uint32_t> left;
  if (leafPass && leafPass(tree, volume, leafOrigins, left)) {
    tbb::parallel_for(size_t(0), left.size(), [&](size_t i) {
      if (abortRequested(progress)) return;
      const uint32_t leaf = left[i];
      classifyLeaf(t, volume.leafWords.data() + leafWordOffset(leaf, L), L, leafOrigins[leaf]);
    });
  } else {
    if (coarse.keys.empty() && !leafOrigins.empty())
      coarse = coarseThresholds(t, leafOrigins, L, volume.grid.resolution, progress);
    classifyLeavesByCrossings(tree, volume, leafOrigins, coarse, progress);
  }
  reportWinding(progress, 0.85);
  WindingOutcome out;
  if (anySplit) out.refinedElements = refineSplitElements(tree, volume, split, uniformPass, freshPass, progress);
  return out;
}

double applyInsideTest(const PreparedMesh& mesh, Volume& volume) {
  return applyInsideTest(mesh, volume, WindingLeafPass());
}

double applyInsideTest(const PreparedMesh& mesh, Volume& volume, const WindingLeafPass& leafPass,
                       const WindingUniformPass& uniformPass, const WindingFreshLeafPass& freshPass,
                       WindingTreeInBackground* early, ProgressPoll* progress) {
  volume.insideTest = mesh.surfaceOnly ? InsideTest::Parity : mesh.insideTest;
  if (!windingPassFollows(mesh)) return 0;
  const auto t0 = std::chrono::steady_clock::now();
  reportWinding(progress, 0.0);
  WindingTree local;
  const WindingTree& tree = early && early->started() ? early->get() : (local = buildWindingTree(mesh.triangles));
  traceWinding("tree (built or waited for)", t0);
  volume.stats.windingRefinedElements =
      classifyByWindingNumber(tree, volume, leafPass, uniformPass, freshPass, progress).refinedElements;
  return std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count();
}

double applyInsideTestAfterCpuPhases(const PreparedMesh& mesh, Volume& volume, const ProgressPoll::Callback& progress) {
  ProgressPoll poll(progress, kCpuPhasesShareBeforeWinding, 1.0);
  const double ms =
      applyInsideTest(mesh, volume, WindingLeafPass(), WindingUniformPass(), WindingFreshLeafPass(), nullptr, &poll);
  if (windingPassFollows(mesh)) poll.report(1.0, "done");
  return ms;
}

WindingTreeInBackground::WindingTreeInBackground(const PreparedMesh& mesh) {
  if (!windingPassFollows(mesh) || mesh.triangles.empty()) return;
  future_ = std::async(std::launch::async, [&mesh] { return buildWindingTree(mesh.triangles); });
}

const WindingTree& WindingTreeInBackground::get() {
  if (!ready_) {
    tree_ = future_.get();
    ready_ = true;
  }
  return tree_;
}

} // namespace hdt
