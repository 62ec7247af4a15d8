// The CPU driver: the paper's phases, scheduled with oneTBB.
//
// Every step whose output order could depend on scheduling ends in a sort on a
// total key (element, triangle) or works on disjoint outputs, so the result is
// the same bytes for any thread count. All geometry is in build_steps.hpp and
// the classification bookkeeping in classify_steps.hpp, shared with the CUDA
// driver; ranges, their boundary parities and the join are root_ranges.hpp's.
// The whole grid is built as one range.
#include "hdt/builder.hpp"

#include "hdt/build_steps.hpp"
#include "hdt/error.hpp"
#include "hdt/host_memory.hpp"
#include "hdt/progress.hpp"
#include "hdt/root_ranges.hpp"
#include "hdt/winding_tree.hpp"

#include <tbb/combinable.h>
#include <tbb/global_control.h>
#include <tbb/info.h>
#include <tbb/parallel_for.h>
#include <tbb/parallel_sort.h>
#include <tbb/task_arena.h>

#include <algorithm>
#include <atomic>
#include <chrono>
#include <cmath>
#include <memory>
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

} // namespace

// One range of root cells [first, end) (the whole grid for buildCpu). Element
// payloads are range-local (root_ranges.hpp); joinRanges renumbers them.
struct CpuRangeBuild::Impl {
  Impl(const PreparedMesh& mesh, const BuildOptions& options, RootRange cells)
      : mesh_(mesh), options_(options), g_(mesh.grid), L_(mesh.grid.leafSize), rowWords_(rowWordsFor(L_)),
        axes_(classifiedAxes(mesh.closed)), cells_(cells),
        progress_(options.progress, 0.0, windingPassFollows(mesh) ? kCpuPhasesShareBeforeWinding : 1.0) {}

  const RangeBoundary& buildTree() {
    progress_.report(0.0, "mapping");
    auto t = Clock::now();
    std::vector<Pair> pairs = mapTrianglesToRootCells();
    times_.mapping = msSince(t);

    progress_.report(0.1, "branching");
    t = Clock::now();
    leafPairs_ = branch(std::move(pairs));
    times_.branching = msSince(t);

    progress_.report(0.4, "leaf processing");
    t = Clock::now();
    processLeaves();
    times_.leaf = msSince(t);

    progress_.report(0.7, "classification");
    t = Clock::now();
    // Under the winding number the parities would be discarded (finish()
    // skips classify, applyInsideTest rewrites every inside plane).
    if (!mesh_.surfaceOnly && !windingPassFollows(mesh_)) {
      for (int a = 0; a < axes_; ++a) {
        axisParity(a, &boundary_.axis[a]);
        progress_.report(0.7 + 0.1 * (a + 1) / axes_, "classification");
      }
    }
    times_.classify = msSince(t);
    return boundary_;
  }

  RangeTree finish(const RangeBoundary* beyond) {
    const auto t = Clock::now();
    // The winding number classifies the joined volume instead (applyInsideTest).
    if (!mesh_.surfaceOnly && !windingPassFollows(mesh_)) classify(beyond);
    times_.classify += msSince(t);
    times_.total = times_.mapping + times_.branching + times_.leaf + times_.classify;
    progress_.report(1.0, windingPassFollows(mesh_) ? "classification" : "done");
    RangeTree out;
    out.cells = cells_;
    out.levels = std::move(levels_);
    out.leafCoord = std::move(leafCoords_);
    out.leafWords = std::move(leafWords_);
    return out;
  }

  PhaseTimes times_;

private:
  // ---- T1: triangles -> root cells ------------------------------------------
  std::vector<Pair> mapTrianglesToRootCells() {
    const int64_t cellSize = int64_t(g_.rootCellVoxels()) * kLatticePerVoxel;
    tbb::combinable<std::vector<Pair>> local;
    tbb::parallel_for(tbb::blocked_range<size_t>(0, mesh_.triangles.size(), 1024),
                      [&](const tbb::blocked_range<size_t>& r) {
                        if (progress_.abortRequested()) return;
                        std::vector<Pair>& out = local.local();
                        for (size_t ti = r.begin(); ti != r.end(); ++ti)
                          forEachRootCell(mesh_.triangles[ti], cellSize, g_.rootGrid, cells_.first, cells_.end,
                                          [&](uint32_t cell) { out.push_back(makePair(cell, uint32_t(ti))); });
                      });
    return gatherSorted(local);
  }

  // ---- T2: level-order branching -------------------------------------------
  // Takes the sorted (range-local root index, triangle) pairs; appends every
  // level and returns the sorted (leaf index, triangle) pairs.
  std::vector<Pair> branch(std::vector<Pair> pairs) {
    const uint64_t R = uint64_t(g_.rootGrid);
    std::vector<uint64_t> coords(cells_.size());
    for (uint64_t i = 0; i < coords.size(); ++i) {
      const uint64_t c = cells_.first + i;
      coords[i] = packCoord(uint32_t(c % R), uint32_t((c / R) % R), uint32_t(c / (R * R)));
    }
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
      appendLevel(level, coords.size(), touched, leafLevel);
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
        if (progress_.abortRequested()) return;
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
      progress_.report(0.1 + 0.3 * double(level + 1) / double(g_.height + 1), "branching");
    }
  }

  // Branch payloads: the first child's index within the next level.
  void appendLevel(int level, uint64_t count, const std::vector<uint32_t>& touched, bool leafLevel) {
    elementsSoFar_ += count; // the range's share of the limit, before allocating (joinRanges checks the whole)
    checkElementLimit(elementsSoFar_, touched.size(), level);
    std::vector<ElementWord> words(count, makeElement(ElementState::Empty, 0));
    for (size_t r = 0; r < touched.size(); ++r)
      words[touched[r]] = leafLevel ? makeElement(ElementState::Boundary, uint32_t(r))
                                    : makeElement(ElementState::Branch, uint32_t(8 * r));
    levels_.push_back(std::move(words));
  }

  // ---- T3: leaf grids --------------------------------------------------------
  void processLeaves() {
    const size_t leaves = leafCoords_.size();
    // Unwritten here (LeafWordVector's resize does not zero): each leaf zeroes
    // its own words in the parallel loop below, so the one serial stretch of a
    // build that could not be aborted is gone. An aborted build leaves words
    // unwritten, but it throws at the next progress_.report() and never reads them.
    leafWords_.resize(leaves * leafWordCount(L_));
    leafPairStart_.assign(leaves + 1, 0);
    for (Pair p : leafPairs_) ++leafPairStart_[pairElement(p) + 1];
    for (size_t i = 0; i < leaves; ++i) leafPairStart_[i + 1] += leafPairStart_[i];

    tbb::parallel_for(size_t(0), leaves, [&](size_t leaf) {
      if (progress_.abortRequested()) return;
      int64_t v0[3];
      leafOrigin(leaf, v0);
      uint32_t rows[32 * 32] = {};
      for (uint64_t p = leafPairStart_[leaf]; p < leafPairStart_[leaf + 1]; ++p) {
        // Rows along the triangle's own row axis (rowAxisFor), in the frame
        // where that axis is "x"; the bits land in the leaf's x rows.
        const LatticeTriangle& original = mesh_.triangles[pairTriangle(leafPairs_[p])];
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
      uint32_t* words = leafWordsAt(leafWords_.data(), leaf, L_);
      std::fill(words, words + leafWordCount(L_), 0u); // pass 1 and pass 2 OR into these
      for (int r = 0; r < L_ * L_; ++r) orRowIntoLeaf(words, L_, r, rows[r], kSurfacePlane);
    });
  }

  void leafOrigin(size_t leaf, int64_t (&v0)[3]) const {
    for (int a = 0; a < 3; ++a) v0[a] = int64_t(unpackCoord(leafCoords_[leaf], a)) * L_;
  }

  // ---- classification (docs/design.md, "Classification") --------------------
  // pass 1 per leaf and axis (crossings inside the leaf), the lines' suffix
  // parity (lineParity), pass 2 per leaf voxel, the uniform elements.
  template <class RowFn>
  void forEachCrossing(size_t leaf, int axis, RowFn&& fn) const {
    int64_t v0[3];
    leafOrigin(leaf, v0);
    for (uint64_t p = leafPairStart_[leaf]; p < leafPairStart_[leaf + 1]; ++p)
      forEachPairCrossing(mesh_.triangles[pairTriangle(leafPairs_[p])], axis, v0, L_, fn);
  }

  // Pass 1 for one axis, then its lines: exit parity per leaf row. Along x
  // (axis 0) it also keeps, per leaf row, the XOR of the "voxels before the
  // crossing" masks in plane 0 of the leaf words (still zero after T3), so
  // that pass 2 needs no geometry there.
  void axisParity(int axis, LineParities* boundary) {
    const size_t leaves = leafCoords_.size();
    std::vector<uint32_t>& parity = exit_[axis];
    parity.assign(leaves * rowWords_, 0u);
    tbb::parallel_for(size_t(0), leaves, [&](size_t leaf) {
      if (progress_.abortRequested()) return;
      uint32_t* bits = parity.data() + leaf * rowWords_;
      if (axis != 0) {
        forEachCrossing(leaf, axis, [&](int row, int) { bits[row >> 5] ^= 1u << (row & 31); });
        return;
      }
      uint32_t masks[32 * 32] = {};
      forEachCrossing(leaf, axis, [&](int row, int before) {
        bits[row >> 5] ^= 1u << (row & 31);
        masks[row] ^= maskBeforeCrossing(before);
      });
      uint32_t* words = leafWordsAt(leafWords_.data(), leaf, L_);
      for (int r = 0; r < L_ * L_; ++r)
        if (masks[r]) orRowIntoLeaf(words, L_, r, masks[r], kInsidePlane);
    });
    lines_[axis] = lineParity(g_, leafCoords_, axis, parity.data(), boundary);
  }

  // Per row (u, w) of a leaf along y or z (axis 1 or 2): bit i = the ray from
  // voxel i's centre crosses the surface an odd number of times. (Along x
  // the in-leaf part is kept by pass 1 in plane 0: insideWords.)
  void insideRows(size_t leaf, int axis, uint32_t* rows) const {
    const uint32_t* exitBits = exit_[axis].data() + leaf * rowWords_;
    for (int r = 0; r < L_ * L_; ++r) rows[r] = exitRowMask(exitBits, r, L_);
    forEachCrossing(leaf, axis, [&](int row, int before) { rows[row] ^= maskBeforeCrossing(before); });
  }

  // Pass 2 word by word (16 voxels a word), without unpacking rows
  // (classifiedWord): the x axis's in-leaf masks are plane 0 already (pass
  // 1), the exit parity is one bit a row; open meshes bring the y and z
  // answers as x rows.
  void insideWords(size_t leaf, const uint32_t* yxRows, const uint32_t* zxRows, uint32_t* words) const {
    const uint32_t* exitBits = exit_[0].data() + leaf * rowWords_;
    for (uint32_t i = 0; i < leafWordCount(L_); ++i) {
      const uint32_t x = rowBitsToWordBits(exitBits, L_, int(i));
      words[i] = yxRows ? classifiedWord(words[i], x, wordBitsFromRows(yxRows, L_, int(i)),
                                         wordBitsFromRows(zxRows, L_, int(i)))
                        : classifiedWord(words[i], x);
    }
  }

  void classify(const RangeBoundary* beyond) {
    if (beyond)
      for (int a = 0; a < axes_; ++a) stitchLineParity(lines_[a], beyond->axis[a], exit_[a].data(), rowWords_);
    tbb::parallel_for(size_t(0), leafCoords_.size(), [&](size_t leaf) {
      if (progress_.abortRequested()) return;
      uint32_t* words = leafWordsAt(leafWords_.data(), leaf, L_);
      if (axes_ == 1) { // closed: the +x rows are the leaf's own rows
        insideWords(leaf, nullptr, nullptr, words);
        return;
      }
      // Open: the y and z answers become x rows by bit-matrix transposes
      // (xRowsOfAxisMatrix), then the majority per word.
      uint32_t axisRows[32 * 32], xRows[2][32 * 32];
      for (int a = 1; a < 3; ++a) {
        insideRows(leaf, a, axisRows);
        for (int i = 0; i < L_; ++i) {
          if (L_ == 8) xRowsOfAxisMatrix<8>(a, i, axisRows, xRows[a - 1]);
          else if (L_ == 16) xRowsOfAxisMatrix<16>(a, i, axisRows, xRows[a - 1]);
          else xRowsOfAxisMatrix<32>(a, i, axisRows, xRows[a - 1]);
        }
      }
      insideWords(leaf, xRows[0], xRows[1], words);
    });
    RangeTree view;
    view.cells = cells_;
    view.levels = std::move(levels_);
    const RangeLines* lines[3] = {&lines_[0], &lines_[1], &lines_[2]};
    classifyUniformElements(g_, view, axes_, lines, beyond);
    levels_ = std::move(view.levels);
  }

  const PreparedMesh& mesh_;
  const BuildOptions& options_;
  const GridSpec& g_;
  const int L_;
  const int rowWords_; // 32-bit words for one bit per leaf row
  const int axes_;
  const RootRange cells_;
  uint64_t elementsSoFar_ = 0;
  std::vector<std::vector<ElementWord>> levels_;
  std::vector<uint64_t> leafCoords_;
  std::vector<uint64_t> leafPairStart_;
  std::vector<Pair> leafPairs_;
  LeafWordVector leafWords_;
  std::vector<uint32_t> exit_[3]; // per axis, leaves * rowWords: pass 1's parity, then the exit parity
  RangeLines lines_[3];
  RangeBoundary boundary_;
  // Reports between phases, abort polling inside them.
  ProgressPoll progress_;
};

CpuRangeBuild::CpuRangeBuild(const PreparedMesh& mesh, const BuildOptions& options, RootRange cells)
    : impl_(new Impl(mesh, options, cells)) {}
CpuRangeBuild::~CpuRangeBuild() = default;
const RangeBoundary& CpuRangeBuild::buildTree() { return impl_->buildTree(); }
RangeTree CpuRangeBuild::finish(const RangeBoundary* beyond) { return impl_->finish(beyond); }
const PhaseTimes& CpuRangeBuild::times() const { return impl_->times_; }

namespace {

Volume finishVolume(const PreparedMesh& mesh, const BuildOptions& options, Volume v, PhaseTimes times) {
  v.surfaceOnly = mesh.surfaceOnly;
  v.closedMesh = mesh.closed;
  const double windingMs = applyInsideTestAfterCpuPhases(mesh, v, options.progress);
  times.classify += windingMs;
  times.total += windingMs;
  computeStructureStatistics(v);
  v.stats.triangles = mesh.triangles.size();
  v.stats.degenerateTriangles = mesh.degenerateTriangles;
  v.stats.time = times;
  v.stats.backend = "cpu";
  v.stats.peakHostBytes = peakResidentBytes();
  return v;
}

// The whole grid as one range: no boundary parities to exchange.
Volume buildWholeGrid(const PreparedMesh& mesh, const BuildOptions& options) {
  const auto t0 = Clock::now();
  const uint64_t R = uint64_t(mesh.grid.rootGrid);
  CpuRangeBuild build(mesh, options, RootRange{0, R * R * R});
  build.buildTree();
  std::vector<RangeTree> pieces;
  pieces.push_back(build.finish(nullptr));
  Volume v = joinRanges(mesh.grid, std::move(pieces));
  PhaseTimes times = build.times();
  times.total = msSince(t0);
  return finishVolume(mesh, options, std::move(v), times);
}

void validateThreads(int threads) {
  if (threads < 0 || threads > kMaxCpuThreads) {
    throw Error(ErrorKind::InvalidArgument, "threads must be between 0 (all cores) and " +
                                                std::to_string(kMaxCpuThreads) + ", got " + std::to_string(threads));
  }
}

// Runs a build in an arena of the options' threads; bad_alloc as an Error.
// The statistics record the threads the arena really has.
template <class Fn>
Volume inArena(const PreparedMesh& mesh, const BuildOptions& options, Fn&& fn) {
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
      v = fn();
    });
  } catch (const std::bad_alloc&) {
    throw Error(ErrorKind::OutOfResources, "out of host memory while building at resolution " +
                                               std::to_string(mesh.grid.resolution));
  }
  v.stats.threads = used;
  return v;
}

} // namespace


Volume buildCpu(const PreparedMesh& mesh, const BuildOptions& options) {
  const uint64_t need = estimateHostBytes(mesh) + options.extraHostBytes;
  const uint64_t have = availableHostBytes();
  if (have != 0 && need > have) {
    throw Error(ErrorKind::OutOfResources,
                "resolution " + std::to_string(mesh.grid.resolution) + " needs about " +
                    std::to_string(need >> 20) + " MiB of memory but only " + std::to_string(have >> 20) +
                    " MiB are available; lower the resolution");
  }
  return inArena(mesh, options, [&] { return buildWholeGrid(mesh, options); });
}

Volume buildCpuRanges(const PreparedMesh& mesh, const BuildOptions& options, const std::vector<RootRange>& ranges) {
  return inArena(mesh, options, [&] {
    const auto t0 = Clock::now();
    std::vector<std::unique_ptr<CpuRangeBuild>> builds;
    std::vector<RangeBoundary> boundaries;
    for (const RootRange& r : ranges) {
      builds.emplace_back(new CpuRangeBuild(mesh, options, r));
      boundaries.push_back(builds.back()->buildTree());
    }
    const std::vector<RangeBoundary> beyond =
        parityBeyondRanges(boundaries, classifiedAxes(mesh.closed), rowWordsFor(mesh.grid.leafSize));
    std::vector<RangeTree> pieces;
    PhaseTimes times;
    for (size_t i = 0; i < builds.size(); ++i) {
      pieces.push_back(builds[i]->finish(&beyond[i]));
      const PhaseTimes& t = builds[i]->times();
      times.mapping += t.mapping;
      times.branching += t.branching;
      times.leaf += t.leaf;
      times.classify += t.classify;
      builds[i].reset();
    }
    Volume v = joinRanges(mesh.grid, std::move(pieces));
    times.total = msSince(t0);
    return finishVolume(mesh, options, std::move(v), times);
  });
}

} // namespace hdt
