#include "chunked.hpp"

#include "pipeline.hpp"

#include "hdt/error.hpp"
#include "hdt/mesh.hpp" // windingPassFollows
#include "hdt/root_ranges.hpp"

#include <chrono>
#include <deque>
#include <string>

namespace hdt {
namespace cuda {
namespace {

uint64_t mib(uint64_t bytes) { return (bytes + (uint64_t(1) << 20) - 1) >> 20; }

[[noreturn]] void tooLarge(const Session& s, uint64_t firstCell, uint64_t needed, uint64_t available) {
  throw Error(ErrorKind::OutOfResources,
              "resolution " + std::to_string(s.grid.resolution) + ": root cell " + std::to_string(firstCell) +
                  " alone needs at least " + std::to_string(mib(needed)) + " MiB of device memory, " +
                  std::to_string(mib(available)) + " MiB available; lower the resolution or raise the budget");
}

// The T1 load of every root cell of `cells`, from one T1 run on the device.
std::vector<CellLoad> deviceCellLoads(Session& s, RootRange cells) {
  std::vector<uint32_t> cellOf, triOf;
  s.clock.start();
  {
    RootMapping root = mapTrianglesToRootCells(s.memory, s.scalars, s.deviceMesh, s.grid, cells.first, cells.end, false);
    cellOf.resize(root.pairs.count);
    triOf.resize(root.pairs.count);
    if (root.pairs.count) {
      HDT_CUDA_CHECK(cudaMemcpyAsync(cellOf.data(), root.pairs.element.data(), cellOf.size() * 4,
                                     cudaMemcpyDeviceToHost, s.stream.get()));
      HDT_CUDA_CHECK(cudaMemcpyAsync(triOf.data(), root.pairs.triangle.data(), triOf.size() * 4,
                                     cudaMemcpyDeviceToHost, s.stream.get()));
    }
    s.clock.mark(kMapping);
    s.sync();
  }
  s.clock.collect(s.ms);
  std::vector<CellLoad> loads = cellLoads(s.mesh, cellOf.data(), triOf.data(), cellOf.size());
  for (CellLoad& l : loads) l.cell += cells.first; // T1 numbers the cells from the range's first
  return loads;
}

// Greedy: contiguous cell ranges of `cells` whose estimates fit next to the
// fixed part (`loads` not empty).
std::vector<RootRange> planChunks(const Session& s, const std::vector<CellLoad>& loads, RootRange cells) {
  const uint64_t fixed = fixedBytes(s.mesh) + (uint64_t(4) << 20);
  const uint64_t avail = s.memory.budget() > fixed ? s.memory.budget() - fixed : 0;
  std::vector<RootRange> chunks = planRootRangesWithin(
      loads, cells.end, [&s](const CellLoad& c) { return estimateBytes(s.mesh, c.area, c.pairs, 1); }, avail);
  chunks.front().first = cells.first; // every chunk starts at a loaded cell but the first
  return chunks;
}

// A chunk's phase-A result as the range's piece of the tree.
RangeTree rangeTreeOf(const RootRange& cells, ChunkTree& t) {
  RangeTree r;
  r.cells = cells;
  r.levels = std::move(t.levelWords);
  r.leafCoord = std::move(t.leafCoord);
  return r;
}

// The phase-A result of cells without triangles: Empty root cells, no
// leaves (the uniform elements classify them), no device work.
ChunkTree emptyChunkTree(const GridSpec& g, RootRange cells) {
  ChunkTree t;
  t.levelWords.resize(size_t(g.height) + 1);
  t.levelWords[0].assign(cells.size(), makeElement(ElementState::Empty, 0));
  return t;
}

using HostClock = std::chrono::steady_clock;
double msSince(HostClock::time_point t0) {
  return std::chrono::duration<double, std::milli>(HostClock::now() - t0).count();
}

} // namespace

uint64_t fixedBytes(const PreparedMesh& mesh) {
  // triangles, T1's per-triangle counts and offsets, T3's per-triangle
  // flags, ranks and index list (TriangleTables; the setups count per pair)
  return uint64_t(mesh.triangles.size()) * (sizeof(LatticeTriangle) + 8 + 9);
}

uint64_t estimateBytes(const PreparedMesh& mesh, double area, uint64_t rootPairs, uint64_t rootCells) {
  // Leaf grids: a surface of area A meets about 3 A / L^2 leaves (closed
  // boxes: faces on leaf planes count twice), at least one per root pair.
  // Leaf pairs: each leaf holds a few triangles, each small triangle meets a
  // few leaves. Elements: about 3 per leaf (8 children per refined parent).
  const double L = mesh.grid.leafSize;
  const double leaves = 3.0 * area / (L * L) + double(rootPairs);
  const double leafPairs = 6.0 * area / (L * L) + 4.0 * double(rootPairs);
  const double rowWords = L * L / 32.0;
  const int axes = mesh.closed ? 1 : 3;
  double perLeaf = L * L * L / 4.0 /*grid*/ + 12 /*coord, pair start*/;
  // The parity classification's buffers: solid builds not followed by the
  // winding-number pass (those build the surface only on the device, as
  // Session::parityClassification says; the pass's own arrays are not part
  // of this estimate: it runs after the build, on the whole volume whatever
  // the chunks, and returns to the host when the budget has no room for it).
  if (!mesh.surfaceOnly && !windingPassFollows(mesh))
    perLeaf += axes * (rowWords * 4 /*parity*/ + 13 /*line table*/) + 24 /*sort buffers*/ +
               (axes - 1) * L * L * 4 /*open meshes: pass-1 masks of axes 1, 2*/;
  // T3's tables (a triangle's slices, row heights and ray lines, 4-8 bytes
  // each, and its setup): 24 bytes a pair of this estimate, which counts
  // about 3x the real pairs (measurements: bench/results/gpu-notes.md). An
  // estimate too low costs a failed one-piece try (then chunks), one too
  // high needless chunks.
  // T2 (branching.cu; no sort): its last level holds the parent pairs
  // (element, triangle: 8 bytes), their child-test bytes (1) and scanned
  // child counters (24, or 32 + a 4-byte rank past 65,535 triangles) beside
  // the hits (8 a leaf pair, whose triangles T3 keeps): with ~2-3 hits a
  // parent pair, about 16 + 9 bytes a leaf pair.
  const double perLeafPair = 4 /*kept*/ + 16 /*T2's hits and parent pairs*/ + 9 /*child tests, counters*/ + 24;
  const double elements = 3.0 * leaves + double(rootCells);
  const double bytes = leaves * perLeaf + leafPairs * perLeafPair + elements * 12 /*word, coords*/;
  return uint64_t(1.25 * bytes);
}

void ChunkedRange::planAndBuildTrees() {
  const GridSpec& g = s_.grid;
  const std::vector<CellLoad> loads = s_.mesh.triangles.empty() ? std::vector<CellLoad>() : deviceCellLoads(s_, cells_);
  if (loads.empty()) { // also an empty range: one chunk, no device work
    done_.push_back(cells_);
    trees_.push_back(emptyChunkTree(g, cells_));
    return;
  }
  // Phase A, chunk by chunk, splitting what does not fit.
  std::deque<RootRange> todo;
  for (const RootRange& c : planChunks(s_, loads, cells_)) todo.push_back(c);
  while (!todo.empty()) {
    const RootRange c = todo.front();
    todo.pop_front();
    try {
      trees_.push_back(buildChunkTree(s_, c.first, c.end));
      done_.push_back(c);
      s_.progress(0.1 + 0.5 * double(c.end - cells_.first) / double(cells_.size()), "branching");
    } catch (const DeviceMemoryExhausted& e) {
      s_.sync();
      s_.clock.collect(s_.ms);
      if (c.size() == 1) tooLarge(s_, c.first, e.neededBytes(), s_.memory.budget());
      const auto halves = splitRootRange(c);
      todo.push_front(halves.second);
      todo.push_front(halves.first);
    }
  }
}

const RangeBoundary& ChunkedRange::buildTree() {
  const GridSpec& g = s_.grid;
  planAndBuildTrees();
  chunks_ = int(done_.size());
  for (size_t c = 0; c < done_.size(); ++c) pieces_.push_back(rangeTreeOf(done_[c], trees_[c]));
  checkJoinedElementLimit(g, pieces_);
  if (!s_.parityClassification()) return boundary_;
  // The host half of classification (root_ranges.hpp), first part: per
  // chunk the lines and their exit parity within the chunk (in place in
  // trees_[c].parity), and the chunks' boundary parities.
  const auto t0 = HostClock::now();
  const int axes = classifiedAxes(s_.mesh.closed), rw = rowWordsFor(g.leafSize);
  lines_.resize(done_.size());
  chunkBoundary_.resize(done_.size());
  for (size_t c = 0; c < done_.size(); ++c)
    for (int a = 0; a < axes; ++a)
      lines_[c].push_back(lineParity(g, pieces_[c].leafCoord, a, trees_[c].parity[a].data(), &chunkBoundary_[c].axis[a]));
  // The range's: the XOR of all its chunks' (the parity beyond a range
  // before them).
  std::vector<RangeBoundary> withHead(1);
  withHead.insert(withHead.end(), chunkBoundary_.begin(), chunkBoundary_.end());
  boundary_ = parityBeyondRanges(withHead, axes, rw)[0];
  hostMs_ += msSince(t0);
  return boundary_;
}

std::vector<RangeTree> ChunkedRange::finish(const RangeBoundary* beyond, LeafWordVector& leafWords) {
  const GridSpec& g = s_.grid;
  const bool solid = s_.parityClassification();
  const int axes = classifiedAxes(s_.mesh.closed);
  const size_t rowWords = size_t(rowWordsFor(g.leafSize));
  const uint32_t wordsPerLeaf = leafWordCount(g.leafSize);
  if (solid) {
    // Second part: each chunk's lines stitched with the parity beyond it
    // (the later chunks' boundaries and what lies beyond the range), and its
    // uniform elements.
    const auto t0 = HostClock::now();
    std::vector<RangeBoundary> boundaries = chunkBoundary_;
    if (beyond) boundaries.push_back(*beyond);
    const std::vector<RangeBoundary> beyondChunk = parityBeyondRanges(boundaries, axes, int(rowWords));
    for (size_t c = 0; c < done_.size(); ++c) {
      const RangeLines* l[3] = {nullptr, nullptr, nullptr};
      for (int a = 0; a < axes; ++a) {
        stitchLineParity(lines_[c][a], beyondChunk[c].axis[a], trees_[c].parity[a].data(), int(rowWords));
        l[a] = &lines_[c][a];
      }
      classifyUniformElements(g, pieces_[c], axes, l, &beyondChunk[c]);
      lines_[c].clear();
    }
    hostMs_ += msSince(t0);
  }
  s_.progress(0.7, "leaf processing");

  // Phase B: leaf grids per chunk, copied straight to their place in the
  // joined order (the only host copy of the leaf grids; LeafWordVector's
  // resize touches no page before that); a chunk that does not fit after all
  // is split.
  std::vector<uint64_t> leafStart(done_.size() + 1, 0);
  for (size_t c = 0; c < done_.size(); ++c) leafStart[c + 1] = leafStart[c] + pieces_[c].leafCoord.size();
  leafWords.resize(leafStart.back() * wordsPerLeaf);
  const uint64_t leavesPerRoot = uint64_t(g.rootCellVoxels() / g.leafSize);
  struct Piece {
    size_t chunk;
    RootRange cells;
    uint64_t firstLeaf, endLeaf; // within the chunk
  };
  auto rootOfLeaf = [&](const Piece& p, uint64_t leaf) {
    const uint64_t c = pieces_[p.chunk].leafCoord[leaf];
    return unpackCoord(c, 0) / leavesPerRoot +
           uint64_t(g.rootGrid) * (unpackCoord(c, 1) / leavesPerRoot + uint64_t(g.rootGrid) * (unpackCoord(c, 2) / leavesPerRoot));
  };
  std::deque<Piece> todo;
  for (size_t c = 0; c < done_.size(); ++c)
    if (!pieces_[c].leafCoord.empty()) todo.push_back(Piece{c, done_[c], 0, pieces_[c].leafCoord.size()});
  while (!todo.empty()) {
    const Piece p = todo.front();
    todo.pop_front();
    try {
      const uint32_t* exitParity[3] = {nullptr, nullptr, nullptr};
      for (int a = 0; solid && a < axes; ++a) exitParity[a] = trees_[p.chunk].parity[a].data() + p.firstLeaf * rowWords;
      buildChunkLeaves(s_, p.cells.first, p.cells.end, uint32_t(p.endLeaf - p.firstLeaf), exitParity,
                       leafWords.data() + (leafStart[p.chunk] + p.firstLeaf) * wordsPerLeaf);
      s_.progress(0.7 + 0.3 * double(p.cells.end - cells_.first) / double(cells_.size()),
                  solid ? "classification" : "leaf processing");
    } catch (const DeviceMemoryExhausted& e) {
      s_.sync();
      s_.clock.collect(s_.ms);
      if (p.cells.size() == 1) tooLarge(s_, p.cells.first, e.neededBytes(), s_.memory.budget());
      const auto halves = splitRootRange(p.cells);
      uint64_t mid = p.firstLeaf; // leaves are grouped by root cell, in root order
      while (mid < p.endLeaf && rootOfLeaf(p, mid) < halves.second.first) ++mid;
      todo.push_front(Piece{p.chunk, halves.second, mid, p.endLeaf});
      todo.push_front(Piece{p.chunk, halves.first, p.firstLeaf, mid});
      ++chunks_;
    }
  }
  trees_.clear();
  return std::move(pieces_);
}

Volume buildChunked(Session& s, CudaBuildReport& report) {
  const GridSpec& g = s.grid;
  const uint64_t cells = uint64_t(g.rootGrid) * g.rootGrid * g.rootGrid;
  ChunkedRange range(s, RootRange{0, cells});
  range.buildTree();
  LeafWordVector leafWords;
  std::vector<RangeTree> pieces = range.finish(nullptr, leafWords);
  report.chunks = range.chunks();
  Volume v = joinRanges(g, std::move(pieces), std::move(leafWords));
  v.surfaceOnly = s.mesh.surfaceOnly;
  v.closedMesh = s.mesh.closed;
  return v;
}

} // namespace cuda
} // namespace hdt
