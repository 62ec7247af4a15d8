// The winding-number tree over a mesh's triangles and the boundary chain
// of its open edges (winding_tree.hpp; docs/design.md "Winding number"): a
// function of the triangles alone, built once per build, on a host thread
// beside the CUDA driver's device work (WindingTreeInBackground).
#include "hdt/winding_tree.hpp"

#include "hdt/huge_pages.hpp"
#include "hdt/mesh.hpp"
#include "morton_key.hpp"

#include <algorithm>
#include <cmath>
#include <future>
#include <memory>
#include <new>

#include <tbb/enumerable_thread_specific.h>
#include <tbb/parallel_for.h>
#include <tbb/parallel_invoke.h>
#include <tbb/parallel_reduce.h>
#include <tbb/parallel_sort.h>

namespace hdt {
namespace {

constexpr uint32_t kLeafTriangles = 4;

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
