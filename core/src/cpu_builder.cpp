// The CPU driver: the paper's phases, scheduled with oneTBB.
//
// Every step whose output order could depend on scheduling ends in a sort on a
// total key (element, triangle) or works on disjoint outputs, so the result is
// the same bytes for any thread count. All geometry is in build_steps.hpp,
// shared with the CUDA driver.
#include "hdt/builder.hpp"

#include "hdt/build_steps.hpp"
#include "hdt/error.hpp"
#include "memory_info.hpp"

#include <tbb/combinable.h>
#include <tbb/global_control.h>
#include <tbb/info.h>
#include <tbb/parallel_for.h>
#include <tbb/parallel_sort.h>
#include <tbb/task_arena.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <thread>

namespace hdt {
namespace {

using Clock = std::chrono::steady_clock;
double msSince(Clock::time_point t0) {
  return std::chrono::duration<double, std::milli>(Clock::now() - t0).count();
}

// (element index within its level << 32) | triangle. Sorting these gives the
// canonical order: by element, then by triangle.
using Pair = uint64_t;
inline Pair makePair(uint64_t element, uint32_t tri) { return (element << 32) | tri; }
inline uint32_t pairElement(Pair p) { return uint32_t(p >> 32); }
inline uint32_t pairTriangle(Pair p) { return uint32_t(p); }

std::vector<Pair> gatherSorted(tbb::combinable<std::vector<Pair>>& local) {
  size_t total = 0;
  local.combine_each([&](const std::vector<Pair>& v) { total += v.size(); });
  std::vector<Pair> all;
  all.reserve(total);
  local.combine_each([&](const std::vector<Pair>& v) { all.insert(all.end(), v.begin(), v.end()); });
  tbb::parallel_sort(all.begin(), all.end());
  return all;
}

// An element that no triangle touches; classification makes it Full or Empty.
struct UniformElement {
  uint64_t index; // global element index
  uint64_t coord; // packed cell coordinates at its level
  int level;
};

// A leaf on its "leaf line" along one ray axis: key = (w, u, along) leaf coords.
struct LineEntry {
  uint64_t key;
  uint32_t leaf;
  bool operator<(const LineEntry& o) const { return key < o.key; }
};
inline uint64_t lineKey(uint64_t u, uint64_t w, uint64_t along) {
  return (((w << 21) | u) << 21) | along;
}

class CpuBuild {
public:
  CpuBuild(const PreparedMesh& mesh, const BuildOptions& options)
      : mesh_(mesh), options_(options), g_(mesh.grid), L_(mesh.grid.leafSize),
        rowWords_((mesh.grid.leafSize * mesh.grid.leafSize + 31) / 32) {}

  Volume run(bool surfaceOnly) {
    const auto t0 = Clock::now();
    report(0.0, "mapping");
    auto t = Clock::now();
    std::vector<Pair> pairs = mapTrianglesToRootCells();
    times_.mapping = msSince(t);

    report(0.1, "branching");
    t = Clock::now();
    const std::vector<Pair> leafPairs = branch(std::move(pairs));
    times_.branching = msSince(t);

    report(0.4, "leaf processing");
    t = Clock::now();
    processLeaves(leafPairs);
    times_.leaf = msSince(t);

    report(0.7, "classification");
    t = Clock::now();
    if (!surfaceOnly) classify(leafPairs);
    times_.classify = msSince(t);
    times_.total = msSince(t0);
    report(1.0, "done");
    return finish(surfaceOnly);
  }

private:
  void report(double fraction, const char* phase) {
    if (options_.progress && !options_.progress(fraction, phase)) {
      throw Error(ErrorKind::Aborted, std::string("build aborted during ") + phase);
    }
  }

  // ---- T1: triangles -> root cells ------------------------------------------
  std::vector<Pair> mapTrianglesToRootCells() {
    const int64_t R = g_.rootGrid;
    const int64_t cellSize = int64_t(g_.rootCellVoxels()) * kLatticePerVoxel;
    tbb::combinable<std::vector<Pair>> local;
    tbb::parallel_for(tbb::blocked_range<size_t>(0, mesh_.triangles.size(), 1024),
                      [&](const tbb::blocked_range<size_t>& r) {
                        std::vector<Pair>& out = local.local();
                        for (size_t ti = r.begin(); ti != r.end(); ++ti) {
                          const LatticeTriangle& tri = mesh_.triangles[ti];
                          int64_t lo[3], hi[3], first[3], last[3];
                          triangleBounds(tri, lo, hi);
                          for (int a = 0; a < 3; ++a) cellRange(lo[a], hi[a], cellSize, R, first[a], last[a]);
                          for (int64_t z = first[2]; z <= last[2]; ++z)
                            for (int64_t y = first[1]; y <= last[1]; ++y)
                              for (int64_t x = first[0]; x <= last[0]; ++x)
                                if (triangleOverlapsElement(tri, packCoord(x, y, z), cellSize))
                                  out.push_back(makePair(uint64_t(x + R * (y + R * z)), uint32_t(ti)));
                        }
                      });
    return gatherSorted(local);
  }

  // ---- T2: level-order branching -------------------------------------------
  // Takes the sorted (root index, triangle) pairs; appends every level to the
  // element array and returns the sorted (leaf index, triangle) pairs.
  std::vector<Pair> branch(std::vector<Pair> pairs) {
    const uint64_t R = uint64_t(g_.rootGrid);
    std::vector<uint64_t> coords(R * R * R);
    for (uint64_t i = 0; i < coords.size(); ++i) coords[i] = packCoord(i % R, (i / R) % R, i / (R * R));
    for (int level = 0;; ++level) {
      // The touched elements of this level, in order; pairRank maps a pair to
      // the position of its element among them.
      std::vector<uint32_t> touched;
      std::vector<uint32_t> pairRank(pairs.size());
      for (size_t i = 0; i < pairs.size(); ++i) {
        if (i == 0 || pairElement(pairs[i]) != pairElement(pairs[i - 1])) touched.push_back(pairElement(pairs[i]));
        pairRank[i] = uint32_t(touched.size() - 1);
      }
      const bool leafLevel = level == g_.height;
      appendLevel(level, coords, touched, leafLevel);
      if (leafLevel) {
        leafCoords_.resize(touched.size());
        for (size_t i = 0; i < touched.size(); ++i) leafCoords_[i] = coords[touched[i]];
        for (size_t i = 0; i < pairs.size(); ++i) pairs[i] = makePair(pairRank[i], pairTriangle(pairs[i]));
        return pairs;
      }
      // Each touched element branches into 8 children, allocated in its order.
      std::vector<uint64_t> childCoords(touched.size() * 8);
      tbb::parallel_for(size_t(0), touched.size(), [&](size_t r) {
        for (int c = 0; c < 8; ++c) childCoords[8 * r + c] = childCoord(coords[touched[r]], c);
      });
      const int64_t childSize = int64_t(g_.elementVoxels(level + 1)) * kLatticePerVoxel;
      tbb::combinable<std::vector<Pair>> local;
      tbb::parallel_for(tbb::blocked_range<size_t>(0, pairs.size(), 256), [&](const tbb::blocked_range<size_t>& r) {
        std::vector<Pair>& out = local.local();
        for (size_t i = r.begin(); i != r.end(); ++i) {
          const uint32_t tri = pairTriangle(pairs[i]);
          for (int c = 0; c < 8; ++c) {
            const uint64_t child = uint64_t(pairRank[i]) * 8 + c;
            if (triangleOverlapsElement(mesh_.triangles[tri], childCoords[child], childSize))
              out.push_back(makePair(child, tri));
          }
        }
      });
      pairs = gatherSorted(local);
      coords.swap(childCoords);
      report(0.1 + 0.3 * double(level + 1) / double(g_.height + 1), "branching");
    }
  }

  void appendLevel(int level, const std::vector<uint64_t>& coords, const std::vector<uint32_t>& touched,
                   bool leafLevel) {
    const uint64_t start = elements_.size();
    const uint64_t next = start + coords.size();
    if (next + 8 * uint64_t(touched.size()) > kMaxElementPayload) {
      throw Error(ErrorKind::OutOfResources, "the tree would exceed 2^30 elements at level " +
                                                 std::to_string(level + 1) + "; lower the resolution");
    }
    levelStart_.push_back(start);
    elements_.resize(next, makeElement(ElementState::Empty, 0));
    size_t r = 0;
    for (uint64_t i = 0; i < coords.size(); ++i) {
      if (r < touched.size() && touched[r] == i) {
        elements_[start + i] = leafLevel ? makeElement(ElementState::Boundary, uint32_t(r))
                                         : makeElement(ElementState::Branch, uint32_t(next + 8 * r));
        ++r;
      } else {
        uniform_.push_back(UniformElement{start + i, coords[i], level});
      }
    }
  }

  // ---- T3: leaf grids --------------------------------------------------------
  void processLeaves(const std::vector<Pair>& leafPairs) {
    const size_t leaves = leafCoords_.size();
    const uint32_t wordsPerLeaf = leafWordCount(L_);
    leafWords_.assign(leaves * wordsPerLeaf, 0u);
    leafPairStart_.assign(leaves + 1, 0);
    for (Pair p : leafPairs) ++leafPairStart_[pairElement(p) + 1];
    for (size_t i = 0; i < leaves; ++i) leafPairStart_[i + 1] += leafPairStart_[i];

    tbb::parallel_for(size_t(0), leaves, [&](size_t leaf) {
      int64_t v0[3];
      leafOrigin(leaf, v0);
      uint32_t rows[32 * 32] = {};
      for (uint64_t p = leafPairStart_[leaf]; p < leafPairStart_[leaf + 1]; ++p) {
        // Rows along the triangle's own row axis (rowAxisFor), in the frame
        // where that axis is "x"; the bits land in the leaf's x rows.
        const LatticeTriangle& original = mesh_.triangles[pairTriangle(leafPairs[p])];
        const int axis = rowAxisFor(original);
        const LatticeTriangle tri = permuteToRowAxis(original, axis);
        int64_t o[3], first[3], last[3];
        permutedOrigin(v0, axis, o);
        leafVoxelRanges(tri, o, L_, g_.resolution, first, last);
        RowClipper clipper;
        makeRowClipper(tri, clipper);
        // The x span each row height allows (e x Z axes), shared by all slices.
        int64_t columnFirst[32], columnLast[32];
        for (int64_t y = first[1]; y <= last[1]; ++y)
          columnSpan(clipper, first, last, y, columnFirst[y - o[1]], columnLast[y - o[1]]);
        for (int64_t z = first[2]; z <= last[2]; ++z) {
          int64_t y0, y1, sliceFirst, sliceLast;
          sliceSpans(clipper, first, last, z, y0, y1, sliceFirst, sliceLast);
          for (int64_t y = y0; y <= y1 && sliceFirst <= sliceLast; ++y) {
            int64_t f = std::max(sliceFirst, columnFirst[y - o[1]]);
            int64_t l = std::min(sliceLast, columnLast[y - o[1]]);
            clipRowByPlane(clipper.plane, y, z, f, l);
            forEachXRowOf(axis, L_, int(y - o[1]), int(z - o[2]), int(f - o[0]), int(l - o[0]),
                          [&](int row, uint32_t bits) { rows[row] |= bits; });
          }
        }
      }
      uint32_t* words = leafWords_.data() + leaf * wordsPerLeaf;
      for (int r = 0; r < L_ * L_; ++r) orRowIntoLeaf(words, L_, r, rows[r], 1);
    });
  }

  void leafOrigin(size_t leaf, int64_t (&v0)[3]) const {
    for (int a = 0; a < 3; ++a) v0[a] = int64_t(unpackCoord(leafCoords_[leaf], a)) * L_;
  }

  // ---- classification ------------------------------------------------------
  // Parity of crossings along +axis, from every voxel centre to the grid's end:
  //   pass 1  per leaf and row, the parity of crossings inside the leaf;
  //   lines   per line of leaves along the axis, a suffix XOR gives the parity
  //           of everything beyond each leaf (the regions between leaves hold
  //           no triangle, so they add nothing);
  //   pass 2  per leaf voxel: crossings ahead of it in its leaf (kept by
  //           pass 1 for x, enumerated again for y and z) + beyond.
  // Closed meshes need one axis (all agree); open ones take the majority of 3.
  struct AxisParity {
    std::vector<uint32_t> exit;     // per leaf, rowWords_: parity beyond the leaf
    std::vector<uint32_t> entry;    // per leaf, rowWords_: parity from the leaf's start
    std::vector<LineEntry> line;    // leaves sorted by (w, u, along)
  };

  template <class RowFn>
  void forEachCrossing(size_t leaf, const std::vector<Pair>& leafPairs, int axis, RowFn&& fn) const {
    const int U = rayAxisU(axis), W = rayAxisW(axis);
    int64_t v0[3];
    leafOrigin(leaf, v0);
    for (uint64_t p = leafPairStart_[leaf]; p < leafPairStart_[leaf + 1]; ++p) {
      const LatticeTriangle& tri = mesh_.triangles[pairTriangle(leafPairs[p])];
      int64_t lo[3], hi[3], u0, u1, w0, w1;
      triangleBounds(tri, lo, hi);
      centreRange(lo[U], hi[U], v0[U], L_, u0, u1);
      centreRange(lo[W], hi[W], v0[W], L_, w0, w1);
      LeafCrossings crossings{};
      bool made = false;
      for (int64_t w = w0; w <= w1; ++w) {
        int64_t uf = u0, ul = u1;
        raySpanAtW(tri, axis, w, uf, ul);
        if (uf <= ul && !made) {
          makeLeafCrossings(tri, axis, v0, L_, crossings);
          made = true;
        }
        const int dw = int(w - v0[W]);
        int f = int(uf - v0[U]), l = int(ul - v0[U]);
        narrowToLeafCrossings(crossings, dw, f, l); // nothing to do for an empty span
        for (int du = f; du <= l; ++du) {
          int before;
          if (crossingInLeaf(crossings, du, dw, L_, before)) fn(du + L_ * dw, before);
        }
      }
    }
  }

  // Pass 1 for one axis. Along x (axis 0) it also keeps, per leaf row, the
  // XOR of the "voxels before the crossing" masks in plane 0 of the leaf
  // words (still zero after T3), so that pass 2 needs no geometry there.
  AxisParity axisParity(int axis, const std::vector<Pair>& leafPairs) {
    const size_t leaves = leafCoords_.size();
    const uint32_t wordsPerLeaf = leafWordCount(L_);
    AxisParity ap;
    std::vector<uint32_t> inside(leaves * rowWords_, 0u);
    tbb::parallel_for(size_t(0), leaves, [&](size_t leaf) {
      uint32_t* bits = inside.data() + leaf * rowWords_;
      if (axis != 0) {
        forEachCrossing(leaf, leafPairs, axis, [&](int row, int) { bits[row >> 5] ^= 1u << (row & 31); });
        return;
      }
      uint32_t masks[32 * 32] = {};
      forEachCrossing(leaf, leafPairs, axis, [&](int row, int before) {
        bits[row >> 5] ^= 1u << (row & 31);
        masks[row] ^= maskBeforeCrossing(before);
      });
      uint32_t* words = leafWords_.data() + leaf * wordsPerLeaf;
      for (int r = 0; r < L_ * L_; ++r)
        if (masks[r]) orRowIntoLeaf(words, L_, r, masks[r], 0);
    });
    const int U = rayAxisU(axis), W = rayAxisW(axis);
    ap.line.resize(leaves);
    for (size_t leaf = 0; leaf < leaves; ++leaf) {
      const uint64_t c = leafCoords_[leaf];
      ap.line[leaf] = LineEntry{lineKey(unpackCoord(c, U), unpackCoord(c, W), unpackCoord(c, axis)), uint32_t(leaf)};
    }
    tbb::parallel_sort(ap.line.begin(), ap.line.end());
    ap.exit.assign(leaves * rowWords_, 0u);
    ap.entry.assign(leaves * rowWords_, 0u);
    std::vector<uint32_t> running(rowWords_, 0u);
    for (size_t i = leaves; i-- > 0;) {
      const uint32_t leaf = ap.line[i].leaf;
      if (i + 1 == leaves || (ap.line[i].key >> 21) != (ap.line[i + 1].key >> 21))
        std::fill(running.begin(), running.end(), 0u);
      for (int k = 0; k < rowWords_; ++k) {
        ap.exit[leaf * rowWords_ + k] = running[k];
        running[k] ^= inside[leaf * rowWords_ + k];
        ap.entry[leaf * rowWords_ + k] = running[k];
      }
    }
    return ap;
  }

  // Parity along `axis` at the lowest-corner voxel centre of a uniform
  // element: the entry parity (row 0) of the first leaf beyond it on its line.
  bool uniformParity(const AxisParity& ap, int axis, const UniformElement& e) const {
    const uint64_t leavesPerElement = uint64_t(g_.elementVoxels(e.level)) / uint64_t(L_);
    const uint64_t u = unpackCoord(e.coord, rayAxisU(axis)) * leavesPerElement;
    const uint64_t w = unpackCoord(e.coord, rayAxisW(axis)) * leavesPerElement;
    const uint64_t along = (unpackCoord(e.coord, axis) + 1) * leavesPerElement;
    const uint64_t key = lineKey(u, w, along);
    auto it = std::lower_bound(ap.line.begin(), ap.line.end(), LineEntry{key, 0});
    if (it == ap.line.end() || (it->key >> 21) != (key >> 21)) return false;
    return ap.entry[size_t(it->leaf) * rowWords_] & 1u;
  }

  // Per row (u, w) of a leaf along y or z (axis 1 or 2): bit i = the ray from
  // voxel i's centre crosses the surface an odd number of times. (Along x
  // the in-leaf part is kept by pass 1 in plane 0: insideWords.)
  void insideRows(size_t leaf, const std::vector<Pair>& leafPairs, const AxisParity& ap, int axis,
                  uint32_t* rows) const {
    for (int r = 0; r < L_ * L_; ++r)
      rows[r] = (ap.exit[leaf * rowWords_ + (r >> 5)] >> (r & 31)) & 1u ? fullRowMask(L_) : 0u;
    forEachCrossing(leaf, leafPairs, axis, [&](int row, int before) { rows[row] ^= maskBeforeCrossing(before); });
  }

  // Pass 2 word by word (16 voxels a word), without unpacking rows: the x
  // axis's in-leaf masks are plane 0 already (pass 1), the exit parity is one
  // bit a row; inside := that, or for open meshes the majority with the y and
  // z answers given as x rows; then minus the surface voxels (plane 1).
  void insideWords(size_t leaf, const AxisParity& ap, const uint32_t* yxRows, const uint32_t* zxRows,
                   uint32_t* words) const {
    const uint32_t* exitBits = ap.exit.data() + leaf * rowWords_;
    for (uint32_t i = 0; i < leafWordCount(L_); ++i) {
      const uint32_t old = words[i];
      uint32_t inside = rowBitsToWordBits(exitBits, L_, int(i)) ^ planeBits16(old, 0);
      if (yxRows) {
        const uint32_t y = wordBitsFromRows(yxRows, L_, int(i)), z = wordBitsFromRows(zxRows, L_, int(i));
        inside = (inside & y) | (inside & z) | (y & z);
      }
      words[i] = withInsidePlane(old, inside);
    }
  }

  void classify(const std::vector<Pair>& leafPairs) {
    const int axes = mesh_.closed ? 1 : 3;
    std::vector<AxisParity> parity;
    for (int a = 0; a < axes; ++a) {
      parity.push_back(axisParity(a, leafPairs));
      report(0.7 + 0.1 * (a + 1) / axes, "classification");
    }
    const uint32_t wordsPerLeaf = leafWordCount(L_);
    tbb::parallel_for(size_t(0), leafCoords_.size(), [&](size_t leaf) {
      uint32_t* words = leafWords_.data() + leaf * wordsPerLeaf;
      if (axes == 1) { // closed: the +x rows are the leaf's own rows
        insideWords(leaf, parity[0], nullptr, nullptr, words);
        return;
      }
      // Open: the y and z answers become x rows by bit-matrix transposes
      // (xRowsOfAxisMatrix), then the majority per word.
      uint32_t axisRows[32 * 32], xRows[2][32 * 32];
      for (int a = 1; a < 3; ++a) {
        insideRows(leaf, leafPairs, parity[a], a, axisRows);
        for (int i = 0; i < L_; ++i) {
          if (L_ == 8) xRowsOfAxisMatrix<8>(a, i, axisRows, xRows[a - 1]);
          else if (L_ == 16) xRowsOfAxisMatrix<16>(a, i, axisRows, xRows[a - 1]);
          else xRowsOfAxisMatrix<32>(a, i, axisRows, xRows[a - 1]);
        }
      }
      insideWords(leaf, parity[0], xRows[0], xRows[1], words);
    });
    tbb::parallel_for(size_t(0), uniform_.size(), [&](size_t i) {
      int votes = 0;
      for (int a = 0; a < axes; ++a) votes += uniformParity(parity[a], a, uniform_[i]);
      if (2 * votes > axes) elements_[uniform_[i].index] = makeElement(ElementState::Full, 0);
    });
  }

  Volume finish(bool surfaceOnly) {
    Volume v;
    v.grid = g_;
    v.surfaceOnly = surfaceOnly;
    v.closedMesh = mesh_.closed;
    v.elements = std::move(elements_);
    levelStart_.push_back(v.elements.size());
    v.levelStart = std::move(levelStart_);
    v.leafWords = std::move(leafWords_);
    computeStructureStatistics(v);
    v.stats.triangles = mesh_.triangles.size();
    v.stats.degenerateTriangles = mesh_.degenerateTriangles;
    v.stats.time = times_;
    v.stats.backend = "cpu";
    v.stats.peakHostBytes = peakResidentBytes();
    return v;
  }

  const PreparedMesh& mesh_;
  const BuildOptions& options_;
  const GridSpec& g_;
  const int L_;
  const int rowWords_; // 32-bit words for one bit per leaf row
  std::vector<ElementWord> elements_;
  std::vector<uint64_t> levelStart_;
  std::vector<UniformElement> uniform_;
  std::vector<uint64_t> leafCoords_;
  std::vector<uint64_t> leafPairStart_;
  std::vector<uint32_t> leafWords_;
  PhaseTimes times_;
};

} // namespace

void validateThreads(int threads) {
  if (threads < 0 || threads > kMaxCpuThreads) {
    throw Error(ErrorKind::InvalidArgument, "threads must be between 0 (all cores) and " +
                                                std::to_string(kMaxCpuThreads) + ", got " + std::to_string(threads));
  }
}

Volume buildCpu(const PreparedMesh& mesh, const BuildOptions& options) {
  const uint64_t need = estimateHostBytes(mesh) + options.extraHostBytes;
  const uint64_t have = availableHostBytes();
  if (have != 0 && need > have) {
    throw Error(ErrorKind::OutOfResources,
                "resolution " + std::to_string(mesh.grid.resolution) + " needs about " +
                    std::to_string(need >> 20) + " MiB of memory but only " + std::to_string(have >> 20) +
                    " MiB are available; lower the resolution");
  }
  validateThreads(options.threads);
  const int threads = options.threads > 0 ? options.threads : tbb::info::default_concurrency();
  // Raising the process-wide worker limit to what was asked for lets oneTBB
  // oversubscribe without printing its "number of workers is limited" warning
  // on stderr (the CLI's --quiet must be quiet).
  tbb::global_control allowed(tbb::global_control::max_allowed_parallelism, size_t(threads));
  tbb::task_arena arena(threads);
  Volume v;
  int used = 0;
  try {
    arena.execute([&] {
      used = tbb::this_task_arena::max_concurrency();
      v = CpuBuild(mesh, options).run(mesh.surfaceOnly);
    });
  } catch (const std::bad_alloc&) {
    throw Error(ErrorKind::OutOfResources, "out of host memory while building at resolution " +
                                               std::to_string(mesh.grid.resolution));
  }
  v.stats.threads = used; // what the arena really has, not what was asked for
  return v;
}

} // namespace hdt
