#include "chunked.hpp"

#include "pipeline.hpp"

#include "hdt/error.hpp"
#include "hdt/root_ranges.hpp"

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

// The T1 load of every root cell, from one T1 run on the device.
std::vector<CellLoad> deviceCellLoads(Session& s) {
  const GridSpec& g = s.grid;
  const uint64_t cells = uint64_t(g.rootGrid) * g.rootGrid * g.rootGrid;
  std::vector<uint32_t> cellOf, triOf;
  s.clock.start();
  {
    RootMapping root = mapTrianglesToRootCells(s.memory, s.scalars, s.deviceMesh, g, 0, cells, false);
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
  return cellLoads(s.mesh, cellOf.data(), triOf.data(), cellOf.size());
}

// Greedy: contiguous cell ranges whose estimates fit next to the fixed part.
std::vector<RootRange> planChunks(const Session& s, const std::vector<CellLoad>& loads, uint64_t cells) {
  const uint64_t fixed = fixedBytes(s.mesh) + (uint64_t(4) << 20);
  const uint64_t avail = s.memory.budget() > fixed ? s.memory.budget() - fixed : 0;
  return planRootRangesWithin(
      loads, cells, [&s](const CellLoad& c) { return estimateBytes(s.mesh, c.area, c.pairs, 1); }, avail);
}

// A chunk's phase-A result as the range's piece of the tree.
RangeTree rangeTreeOf(const RootRange& cells, ChunkTree& t) {
  RangeTree r;
  r.cells = cells;
  r.levels = std::move(t.levelWords);
  r.leafCoord = std::move(t.leafCoord);
  return r;
}

// The host half of classification (root_ranges.hpp): per chunk the lines
// and their exit parity (in place in t.parity), stitched with the parity
// beyond the chunk, and the chunk's uniform elements.
void classifyOnHost(const GridSpec& g, int axes, std::vector<ChunkTree>& trees, std::vector<RangeTree>& ranges) {
  const int rw = rowWordsFor(g.leafSize);
  std::vector<std::vector<RangeLines>> lines(trees.size());
  std::vector<RangeBoundary> boundary(trees.size());
  for (size_t c = 0; c < trees.size(); ++c)
    for (int a = 0; a < axes; ++a)
      lines[c].push_back(lineParity(g, ranges[c].leafCoord, a, trees[c].parity[a].data(), &boundary[c].axis[a]));
  const std::vector<RangeBoundary> beyond = parityBeyondRanges(boundary, axes, rw);
  for (size_t c = 0; c < trees.size(); ++c) {
    const RangeLines* l[3] = {nullptr, nullptr, nullptr};
    for (int a = 0; a < axes; ++a) {
      stitchLineParity(lines[c][a], beyond[c].axis[a], trees[c].parity[a].data(), rw);
      l[a] = &lines[c][a];
    }
    classifyUniformElements(g, ranges[c], axes, l, &beyond[c]);
    lines[c].clear();
  }
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
  if (!mesh.surfaceOnly)
    perLeaf += axes * (rowWords * 4 /*parity*/ + 13 /*line table*/) + 24 /*sort buffers*/ +
               (axes - 1) * L * L * 4 /*open meshes: pass-1 masks of axes 1, 2*/;
  // T3's tables (a triangle's slices, row heights and ray lines, 4-8 bytes
  // each, and its setup): 24 bytes a pair of this estimate, which counts
  // about 3x the real pairs (measurements: bench/results/gpu-notes.md). An
  // estimate too low costs a failed one-piece try (then chunks), one too
  // high needless chunks.
  const double perLeafPair = 4 /*kept*/ + 16 /*T2 pairs, double-buffered*/ + 9 /*rank, mask, offset*/ + 24;
  const double elements = 3.0 * leaves + double(rootCells);
  const double bytes = leaves * perLeaf + leafPairs * perLeafPair + elements * 12 /*word, coords*/;
  return uint64_t(1.25 * bytes);
}

Volume buildChunked(Session& s, CudaBuildReport& report) {
  const GridSpec& g = s.grid;
  const uint64_t cells = uint64_t(g.rootGrid) * g.rootGrid * g.rootGrid;
  const bool solid = !s.mesh.surfaceOnly;
  const int axes = classifiedAxes(s.mesh.closed);
  const size_t rowWords = size_t(rowWordsFor(g.leafSize));
  const uint32_t wordsPerLeaf = leafWordCount(g.leafSize);

  // Phase A, chunk by chunk, splitting what does not fit.
  std::deque<RootRange> todo;
  for (const RootRange& c : planChunks(s, deviceCellLoads(s), cells)) todo.push_back(c);
  std::vector<RootRange> done;
  std::vector<ChunkTree> trees;
  while (!todo.empty()) {
    const RootRange c = todo.front();
    todo.pop_front();
    try {
      trees.push_back(buildChunkTree(s, c.first, c.end));
      done.push_back(c);
      s.progress(0.1 + 0.5 * double(c.end) / double(cells), "branching");
    } catch (const DeviceMemoryExhausted& e) {
      s.sync();
      s.clock.collect(s.ms);
      if (c.size() == 1) tooLarge(s, c.first, e.neededBytes(), s.memory.budget());
      const auto halves = splitRootRange(c);
      todo.push_front(halves.second);
      todo.push_front(halves.first);
    }
  }
  report.chunks = int(done.size());
  std::vector<RangeTree> ranges;
  for (size_t c = 0; c < done.size(); ++c) ranges.push_back(rangeTreeOf(done[c], trees[c]));
  checkJoinedElementLimit(g, ranges);
  if (solid) classifyOnHost(g, axes, trees, ranges);
  s.progress(0.7, "leaf processing");

  // Phase B: leaf grids per chunk, copied straight to their place in the
  // joined order (the only host copy of the leaf grids; LeafWordVector's
  // resize touches no page before that); a chunk that does not fit after all
  // is split.
  std::vector<uint64_t> leafStart(done.size() + 1, 0);
  for (size_t c = 0; c < done.size(); ++c) leafStart[c + 1] = leafStart[c] + ranges[c].leafCoord.size();
  LeafWordVector leafWords;
  leafWords.resize(leafStart.back() * wordsPerLeaf);
  const uint64_t leavesPerRoot = uint64_t(g.rootCellVoxels() / g.leafSize);
  struct Piece {
    size_t chunk;
    RootRange cells;
    uint64_t firstLeaf, endLeaf; // within the chunk
  };
  auto rootOfLeaf = [&](const Piece& p, uint64_t leaf) {
    const uint64_t c = ranges[p.chunk].leafCoord[leaf];
    return unpackCoord(c, 0) / leavesPerRoot +
           uint64_t(g.rootGrid) * (unpackCoord(c, 1) / leavesPerRoot + uint64_t(g.rootGrid) * (unpackCoord(c, 2) / leavesPerRoot));
  };
  std::deque<Piece> pieces;
  for (size_t c = 0; c < done.size(); ++c) pieces.push_back(Piece{c, done[c], 0, ranges[c].leafCoord.size()});
  while (!pieces.empty()) {
    const Piece p = pieces.front();
    pieces.pop_front();
    try {
      const uint32_t* exitParity[3] = {nullptr, nullptr, nullptr};
      for (int a = 0; solid && a < axes; ++a) exitParity[a] = trees[p.chunk].parity[a].data() + p.firstLeaf * rowWords;
      buildChunkLeaves(s, p.cells.first, p.cells.end, uint32_t(p.endLeaf - p.firstLeaf), exitParity,
                       leafWords.data() + (leafStart[p.chunk] + p.firstLeaf) * wordsPerLeaf);
      s.progress(0.7 + 0.3 * double(p.cells.end) / double(cells), solid ? "classification" : "leaf processing");
    } catch (const DeviceMemoryExhausted& e) {
      s.sync();
      s.clock.collect(s.ms);
      if (p.cells.size() == 1) tooLarge(s, p.cells.first, e.neededBytes(), s.memory.budget());
      const auto halves = splitRootRange(p.cells);
      uint64_t mid = p.firstLeaf; // leaves are grouped by root cell, in root order
      while (mid < p.endLeaf && rootOfLeaf(p, mid) < halves.second.first) ++mid;
      pieces.push_front(Piece{p.chunk, halves.second, mid, p.endLeaf});
      pieces.push_front(Piece{p.chunk, halves.first, p.firstLeaf, mid});
      ++report.chunks;
    }
  }
  trees.clear();
  Volume v = joinRanges(g, std::move(ranges), std::move(leafWords));
  v.surfaceOnly = s.mesh.surfaceOnly;
  v.closedMesh = s.mesh.closed;
  return v;
}

} // namespace cuda
} // namespace hdt
