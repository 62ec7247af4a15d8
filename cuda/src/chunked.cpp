#include "chunked.hpp"

#include "pipeline.hpp"

#include "hdt/build_steps.hpp"
#include "hdt/error.hpp"

#include <algorithm>
#include <cmath>
#include <deque>
#include <numeric>
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

struct Chunk {
  uint64_t first, end;
};

// One root cell's share of the mesh: its T1 pairs and the area of its
// triangles, each triangle's area split evenly over the cells it meets.
struct CellLoad {
  uint64_t cell;
  uint64_t pairs;
  double area;
};

std::vector<CellLoad> cellLoads(Session& s) {
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
  std::vector<uint32_t> cellsOfTriangle(s.mesh.triangles.size(), 0);
  for (uint32_t t : triOf) ++cellsOfTriangle[t];
  std::vector<CellLoad> loads;
  const double perVoxel2 = double(kLatticePerVoxel) * double(kLatticePerVoxel);
  for (size_t i = 0; i < cellOf.size(); ++i) {
    if (loads.empty() || loads.back().cell != cellOf[i]) loads.push_back(CellLoad{cellOf[i], 0, 0});
    const LatticeTriangle& t = s.mesh.triangles[triOf[i]];
    int64_t n[3];
    triangleNormal(t, n);
    const double area = 0.5 * std::sqrt(double(n[0]) * n[0] + double(n[1]) * n[1] + double(n[2]) * n[2]) / perVoxel2;
    loads.back().pairs += 1;
    loads.back().area += area / cellsOfTriangle[triOf[i]];
  }
  return loads;
}

// Greedy: contiguous cell ranges whose estimates fit next to the fixed part.
std::vector<Chunk> planChunks(const Session& s, const std::vector<CellLoad>& loads, uint64_t cells) {
  const uint64_t fixed = fixedBytes(s.mesh) + (uint64_t(4) << 20);
  const uint64_t avail = s.memory.budget() > fixed ? s.memory.budget() - fixed : 0;
  std::vector<Chunk> chunks;
  uint64_t start = 0, sum = 0;
  bool loaded = false;
  for (const CellLoad& c : loads) {
    const uint64_t est = estimateBytes(s.mesh, c.area, c.pairs, 1);
    if (loaded && sum + est > avail) {
      chunks.push_back(Chunk{start, c.cell});
      start = c.cell;
      sum = 0;
    }
    sum += est;
    loaded = true;
  }
  chunks.push_back(Chunk{start, cells});
  return chunks;
}

// Splits a chunk that did not fit: in the middle of its cells.
std::pair<Chunk, Chunk> split(const Chunk& c) {
  const uint64_t mid = c.first + (c.end - c.first) / 2;
  return {Chunk{c.first, mid}, Chunk{mid, c.end}};
}

// The host half of classification for chunked builds: the device path's
// lines and uniform elements over the joined leaves (same keys, same rules).
struct HostLines {
  std::vector<uint64_t> key;  // sorted
  std::vector<uint32_t> leaf; // leaf of each key
  std::vector<uint8_t> entry; // per leaf: entry parity of row 0
};

HostLines hostLineParity(const GridSpec& g, const std::vector<uint64_t>& leafCoord, int axis,
                         std::vector<uint32_t>& parity) {
  const int b = lineFieldBits(g);
  const size_t n = leafCoord.size(), rw = size_t(rowWordsFor(g.leafSize));
  std::vector<std::pair<uint64_t, uint32_t>> order(n);
  for (size_t i = 0; i < n; ++i) {
    const uint64_t c = leafCoord[i];
    order[i] = {(uint64_t(unpackCoord(c, rayAxisW(axis))) << (2 * b)) |
                    (uint64_t(unpackCoord(c, rayAxisU(axis))) << b) | unpackCoord(c, axis),
                uint32_t(i)};
  }
  std::sort(order.begin(), order.end());
  HostLines h;
  h.key.resize(n);
  h.leaf.resize(n);
  h.entry.assign(n, 0);
  std::vector<uint32_t> running(rw, 0);
  for (size_t i = n; i-- > 0;) {
    h.key[i] = order[i].first;
    h.leaf[i] = order[i].second;
    if (i + 1 == n || (order[i].first >> b) != (order[i + 1].first >> b)) std::fill(running.begin(), running.end(), 0u);
    uint32_t* p = parity.data() + size_t(order[i].second) * rw;
    for (size_t k = 0; k < rw; ++k) {
      const uint32_t inside = p[k];
      p[k] = running[k]; // exit parity
      running[k] ^= inside;
    }
    h.entry[order[i].second] = uint8_t(running[0] & 1u);
  }
  return h;
}

void hostClassifyUniform(Volume& v, int axes, const HostLines* lines) {
  const GridSpec& g = v.grid;
  const int b = lineFieldBits(g);
  const uint64_t R = uint64_t(g.rootGrid), leavesPerAxis = uint64_t(g.resolution / g.leafSize);
  std::vector<uint64_t> coords(v.levelStart[1]), next;
  for (uint64_t i = 0; i < coords.size(); ++i) coords[i] = packCoord(uint32_t(i % R), uint32_t((i / R) % R), uint32_t(i / (R * R)));
  for (size_t level = 0; level + 1 < v.levelStart.size(); ++level) {
    const uint64_t start = v.levelStart[level];
    const uint64_t lpe = uint64_t(g.elementVoxels(int(level))) / uint64_t(g.leafSize);
    if (level + 2 < v.levelStart.size()) next.assign(v.levelStart[level + 2] - v.levelStart[level + 1], 0);
    for (uint64_t i = 0; i < coords.size(); ++i) {
      ElementWord& w = v.elements[start + i];
      if (elementState(w) == ElementState::Branch) {
        const uint64_t first = elementPayload(w) - v.levelStart[level + 1];
        for (int c = 0; c < 8; ++c) next[first + c] = childCoord(coords[i], c);
        continue;
      }
      if (elementState(w) != ElementState::Empty) continue;
      int votes = 0;
      for (int a = 0; a < axes; ++a) {
        const uint64_t u = unpackCoord(coords[i], rayAxisU(a)) * lpe, wv = unpackCoord(coords[i], rayAxisW(a)) * lpe;
        const uint64_t along = (unpackCoord(coords[i], a) + 1) * lpe;
        if (along >= leavesPerAxis) continue;
        const uint64_t key = (wv << (2 * b)) | (u << b) | along;
        auto it = std::lower_bound(lines[a].key.begin(), lines[a].key.end(), key);
        if (it != lines[a].key.end() && (*it >> b) == (key >> b))
          votes += lines[a].entry[lines[a].leaf[size_t(it - lines[a].key.begin())]];
      }
      if (2 * votes > axes) w = makeElement(ElementState::Full, 0);
    }
    coords.swap(next);
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
  // each, and its setup): measured 18-73 bytes a real pair on the shared
  // meshes at 8192^3 (CAD parts share a triangle's slices among many
  // leaves, scans less so); 24 a pair of this estimate, which counts about
  // 3x the real pairs. An estimate too low costs a failed one-piece try
  // (then chunks), one too high needless chunks: 200 bytes here chunked
  // cycloidal-drive at 16384^3 (15 GB real) on an 80 GB GPU.
  const double perLeafPair = 4 /*kept*/ + 16 /*T2 pairs, double-buffered*/ + 9 /*rank, mask, offset*/ + 24;
  const double elements = 3.0 * leaves + double(rootCells);
  const double bytes = leaves * perLeaf + leafPairs * perLeafPair + elements * 12 /*word, coords*/;
  return uint64_t(1.25 * bytes);
}

Volume buildChunked(Session& s, CudaBuildReport& report) {
  const GridSpec& g = s.grid;
  const uint64_t cells = uint64_t(g.rootGrid) * g.rootGrid * g.rootGrid;
  const bool solid = !s.mesh.surfaceOnly;
  const int axes = s.mesh.closed ? 1 : 3;
  const size_t rowWords = size_t(rowWordsFor(g.leafSize));
  const uint32_t wordsPerLeaf = leafWordCount(g.leafSize);

  // Phase A, chunk by chunk, splitting what does not fit.
  std::deque<Chunk> todo;
  for (const Chunk& c : planChunks(s, cellLoads(s), cells)) todo.push_back(c);
  std::vector<Chunk> done;
  std::vector<ChunkTree> trees;
  while (!todo.empty()) {
    const Chunk c = todo.front();
    todo.pop_front();
    try {
      trees.push_back(buildChunkTree(s, c.first, c.end));
      done.push_back(c);
      s.progress(0.1 + 0.5 * double(c.end) / double(cells), "branching");
    } catch (const DeviceMemoryExhausted& e) {
      s.sync();
      s.clock.collect(s.ms);
      if (c.end - c.first == 1) tooLarge(s, c.first, e.neededBytes(), s.memory.budget());
      const auto halves = split(c);
      todo.push_front(halves.second);
      todo.push_front(halves.first);
    }
  }
  report.chunks = int(done.size());

  // Join: level sizes, offsets, renumbered payloads.
  const size_t levels = size_t(g.height) + 1;
  Volume v;
  v.grid = g;
  v.surfaceOnly = s.mesh.surfaceOnly;
  v.closedMesh = s.mesh.closed;
  std::vector<uint64_t> levelCount(levels, 0);
  std::vector<uint64_t> leafStart(done.size() + 1, 0);
  for (size_t c = 0; c < done.size(); ++c) {
    for (size_t k = 0; k < levels; ++k) levelCount[k] += trees[c].levelWords[k].size();
    leafStart[c + 1] = leafStart[c] + trees[c].leafCoord.size();
  }
  v.levelStart.assign(levels + 1, 0);
  for (size_t k = 0; k < levels; ++k) v.levelStart[k + 1] = v.levelStart[k] + levelCount[k];
  for (size_t k = 0; k < levels; ++k) { // the CPU driver's limit, level by level
    const uint64_t touched = k + 1 < levels ? levelCount[k + 1] / 8 : leafStart.back();
    if (v.levelStart[k + 1] + 8 * touched > kMaxElementPayload)
      throw Error(ErrorKind::OutOfResources, "the tree would exceed 2^30 elements at level " + std::to_string(k + 1) +
                                                 "; lower the resolution");
  }
  v.elements.resize(v.levelStart.back());
  std::vector<uint64_t> offset(levels + 1, 0); // chunk's first element within each level
  for (size_t c = 0; c < done.size(); ++c) {
    for (size_t k = 0; k < levels; ++k) {
      const std::vector<ElementWord>& words = trees[c].levelWords[k];
      ElementWord* out = v.elements.data() + v.levelStart[k] + offset[k];
      const uint32_t branchBase = uint32_t(v.levelStart[k + 1] + offset[k + 1]);
      const uint32_t leafBase = uint32_t(leafStart[c]);
      for (size_t i = 0; i < words.size(); ++i) {
        const ElementWord w = words[i];
        switch (elementState(w)) {
        case ElementState::Branch: out[i] = makeElement(ElementState::Branch, elementPayload(w) + branchBase); break;
        case ElementState::Boundary: out[i] = makeElement(ElementState::Boundary, elementPayload(w) + leafBase); break;
        default: out[i] = w;
        }
      }
      offset[k] += words.size();
    }
    trees[c].levelWords.clear();
  }
  // One host copy: phase B copies each chunk's leaf grids straight to their
  // place; LeafWordVector's resize touches no page before that.
  v.leafWords.resize(leafStart.back() * wordsPerLeaf);

  // Solid builds: lines over all leaves (host), then the uniform elements.
  const int parityAxes = solid ? axes : 0;
  std::vector<uint64_t> leafCoord;
  std::vector<uint32_t> parity[3];
  leafCoord.reserve(leafStart.back());
  for (int a = 0; a < parityAxes; ++a) parity[a].reserve(leafStart.back() * rowWords);
  for (ChunkTree& t : trees) {
    leafCoord.insert(leafCoord.end(), t.leafCoord.begin(), t.leafCoord.end());
    for (int a = 0; a < parityAxes; ++a) parity[a].insert(parity[a].end(), t.parity[a].begin(), t.parity[a].end());
    t = ChunkTree();
  }
  if (solid) {
    HostLines lines[3];
    for (int a = 0; a < axes; ++a) lines[a] = hostLineParity(g, leafCoord, a, parity[a]);
    hostClassifyUniform(v, axes, lines);
  }
  s.progress(0.7, "leaf processing");

  // Phase B: leaf grids per chunk; a chunk that does not fit after all is split.
  const uint64_t leavesPerRoot = uint64_t(g.rootCellVoxels() / g.leafSize);
  auto rootOfLeaf = [&](uint64_t leaf) {
    const uint64_t c = leafCoord[leaf];
    return unpackCoord(c, 0) / leavesPerRoot +
           uint64_t(g.rootGrid) * (unpackCoord(c, 1) / leavesPerRoot + uint64_t(g.rootGrid) * (unpackCoord(c, 2) / leavesPerRoot));
  };
  struct Piece {
    Chunk c;
    uint64_t firstLeaf, endLeaf;
  };
  std::deque<Piece> pieces;
  for (size_t c = 0; c < done.size(); ++c) pieces.push_back(Piece{done[c], leafStart[c], leafStart[c + 1]});
  while (!pieces.empty()) {
    const Piece p = pieces.front();
    pieces.pop_front();
    try {
      const uint32_t* exitParity[3] = {nullptr, nullptr, nullptr};
      for (int a = 0; a < parityAxes; ++a) exitParity[a] = parity[a].data() + p.firstLeaf * rowWords;
      buildChunkLeaves(s, p.c.first, p.c.end, uint32_t(p.endLeaf - p.firstLeaf), exitParity,
                       v.leafWords.data() + p.firstLeaf * wordsPerLeaf);
      s.progress(0.7 + 0.3 * double(p.c.end) / double(cells), solid ? "classification" : "leaf processing");
    } catch (const DeviceMemoryExhausted& e) {
      s.sync();
      s.clock.collect(s.ms);
      if (p.c.end - p.c.first == 1) tooLarge(s, p.c.first, e.neededBytes(), s.memory.budget());
      const auto halves = split(p.c);
      uint64_t mid = p.firstLeaf; // leaves are grouped by root cell, in root order
      while (mid < p.endLeaf && rootOfLeaf(mid) < halves.second.first) ++mid;
      pieces.push_front(Piece{halves.second, mid, p.endLeaf});
      pieces.push_front(Piece{halves.first, p.firstLeaf, mid});
      ++report.chunks;
    }
  }
  return v;
}

} // namespace cuda
} // namespace hdt
