// Root-range builds: planning, the lines of leaves and their parities, the
// uniform elements of a range, and the join (root_ranges.hpp).
#include "hdt/root_ranges.hpp"

#include "hdt/error.hpp"
#include "hdt/geometry.hpp"

#include <tbb/parallel_for.h>
#include <tbb/parallel_sort.h>

#include <algorithm>
#include <string>

namespace hdt {

// ---- plan ---------------------------------------------------------------------------

std::vector<CellLoad> cellLoads(const PreparedMesh& mesh, const uint32_t* cellOf, const uint32_t* triOf, size_t n) {
  std::vector<uint32_t> cellsOfTriangle(mesh.triangles.size(), 0);
  for (size_t i = 0; i < n; ++i) ++cellsOfTriangle[triOf[i]];
  std::vector<CellLoad> loads;
  for (size_t i = 0; i < n; ++i) {
    if (loads.empty() || loads.back().cell != cellOf[i]) loads.push_back(CellLoad{cellOf[i], 0, 0});
    loads.back().pairs += 1;
    loads.back().area += triangleArea(mesh.triangles[triOf[i]]) / cellsOfTriangle[triOf[i]];
  }
  return loads;
}

std::vector<CellLoad> cellLoads(const PreparedMesh& mesh) {
  const GridSpec& g = mesh.grid;
  const uint64_t cells = uint64_t(g.rootGrid) * g.rootGrid * g.rootGrid;
  const int64_t cellSize = int64_t(g.rootCellVoxels()) * kLatticePerVoxel;
  std::vector<std::pair<uint32_t, uint32_t>> pairs; // (cell, triangle)
  for (size_t t = 0; t < mesh.triangles.size(); ++t)
    forEachRootCell(mesh.triangles[t], cellSize, g.rootGrid, 0, cells,
                    [&](uint32_t cell) { pairs.emplace_back(cell, uint32_t(t)); });
  std::sort(pairs.begin(), pairs.end());
  std::vector<uint32_t> cellOf(pairs.size()), triOf(pairs.size());
  for (size_t i = 0; i < pairs.size(); ++i) {
    cellOf[i] = pairs[i].first;
    triOf[i] = pairs[i].second;
  }
  return cellLoads(mesh, cellOf.data(), triOf.data(), pairs.size());
}

std::vector<RootRange> planRootRanges(const std::vector<CellLoad>& loads, uint64_t cells, int count, uint64_t align) {
  if (count < 1) throw Error(ErrorKind::InvalidArgument, "a build needs at least one root range");
  if (align < 1) align = 1;
  uint64_t total = 0;
  for (const CellLoad& c : loads) total += c.pairs;
  // Boundary k (1 .. count - 1): the first aligned cell before which at
  // least k / count of the pairs lie.
  std::vector<RootRange> ranges;
  uint64_t start = 0, seen = 0;
  size_t next = 0;
  for (int k = 1; k < count; ++k) {
    const uint64_t target = (total * uint64_t(k) + uint64_t(count) - 1) / uint64_t(count);
    uint64_t end = start;
    while (end < cells && seen < target) {
      const uint64_t unitEnd = std::min(cells, (end / align + 1) * align);
      for (; next < loads.size() && loads[next].cell < unitEnd; ++next) seen += loads[next].pairs;
      end = unitEnd;
    }
    ranges.push_back(RootRange{start, end});
    start = end;
  }
  ranges.push_back(RootRange{start, cells});
  return ranges;
}

std::vector<RootRange> planRootRangesWithin(const std::vector<CellLoad>& loads, uint64_t cells,
                                            const std::function<uint64_t(const CellLoad&)>& cost, uint64_t capacity) {
  std::vector<RootRange> ranges;
  uint64_t start = 0, sum = 0;
  bool loaded = false;
  for (const CellLoad& c : loads) {
    const uint64_t est = cost(c);
    if (loaded && sum + est > capacity) {
      ranges.push_back(RootRange{start, c.cell});
      start = c.cell;
      sum = 0;
    }
    sum += est;
    loaded = true;
  }
  ranges.push_back(RootRange{start, cells});
  return ranges;
}

std::pair<RootRange, RootRange> splitRootRange(const RootRange& r) {
  const uint64_t mid = r.first + r.size() / 2;
  return {RootRange{r.first, mid}, RootRange{mid, r.end}};
}

// ---- join ------------------------------------------------------------------------------

void checkElementLimit(uint64_t levelEnd, uint64_t touched, int level) {
  if (levelEnd + 8 * touched > kMaxElementPayload) {
    throw Error(ErrorKind::OutOfResources, "the tree would exceed 2^30 elements at level " + std::to_string(level + 1) +
                                               "; lower the resolution");
  }
}

namespace {

// A range carries its leaf coordinates, its leaf words, or neither (its
// leaves were placed elsewhere, as a distributed join receives them): then
// its leaves are its Boundary elements, one each.
uint64_t leavesOf(const RangeTree& t, uint32_t wordsPerLeaf) {
  if (!t.leafCoord.empty()) return t.leafCoord.size();
  if (!t.leafWords.empty()) return t.leafWords.size() / wordsPerLeaf;
  uint64_t leaves = 0;
  for (const std::vector<ElementWord>& level : t.levels)
    for (const ElementWord w : level) leaves += elementState(w) == ElementState::Boundary ? 1 : 0;
  return leaves;
}

// Elements of each level over all ranges.
std::vector<uint64_t> levelCounts(const GridSpec& g, const std::vector<RangeTree>& ranges) {
  const size_t levels = size_t(g.height) + 1;
  std::vector<uint64_t> count(levels, 0);
  for (const RangeTree& t : ranges) {
    if (t.levels.size() != levels) throw Error(ErrorKind::InvalidArgument, "joinRanges: a range has the wrong number of levels");
    for (size_t k = 0; k < levels; ++k) count[k] += t.levels[k].size();
  }
  return count;
}

} // namespace

void checkJoinedElementLimit(const GridSpec& g, const std::vector<RangeTree>& ranges) {
  const std::vector<uint64_t> count = levelCounts(g, ranges);
  uint64_t leaves = 0, end = 0;
  for (const RangeTree& t : ranges) leaves += leavesOf(t, leafWordCount(g.leafSize));
  for (size_t k = 0; k < count.size(); ++k) {
    end += count[k];
    checkElementLimit(end, k + 1 < count.size() ? count[k + 1] / 8 : leaves, int(k));
  }
}

Volume joinRanges(const GridSpec& g, std::vector<RangeTree>&& ranges, LeafWordVector&& leafWords) {
  checkJoinedElementLimit(g, ranges);
  const std::vector<uint64_t> levelCount = levelCounts(g, ranges);
  const size_t levels = levelCount.size();
  const uint32_t wordsPerLeaf = leafWordCount(g.leafSize);
  Volume v;
  v.grid = g;
  std::vector<uint64_t> leafStart(ranges.size() + 1, 0);
  for (size_t r = 0; r < ranges.size(); ++r) leafStart[r + 1] = leafStart[r] + leavesOf(ranges[r], wordsPerLeaf);
  v.levelStart.assign(levels + 1, 0);
  for (size_t k = 0; k < levels; ++k) v.levelStart[k + 1] = v.levelStart[k] + levelCount[k];
  v.elements.resize(v.levelStart.back());
  const bool placed = !leafWords.empty() || leafStart.back() == 0;
  if (placed) {
    if (leafWords.size() != leafStart.back() * wordsPerLeaf)
      throw Error(ErrorKind::InvalidArgument, "joinRanges: leaf words do not match the ranges' leaves");
    v.leafWords = std::move(leafWords);
  } else if (ranges.size() == 1) {
    v.leafWords = std::move(ranges[0].leafWords);
  } else {
    v.leafWords.resize(leafStart.back() * wordsPerLeaf);
  }
  std::vector<uint64_t> offset(levels + 1, 0); // the range's first element within each level
  for (size_t r = 0; r < ranges.size(); ++r) {
    RangeTree& t = ranges[r];
    for (size_t k = 0; k < levels; ++k) {
      const std::vector<ElementWord>& words = t.levels[k];
      ElementWord* out = v.elements.data() + v.levelStart[k] + offset[k];
      const uint32_t branchBase = uint32_t(v.levelStart[k + 1] + offset[k + 1]);
      const uint32_t leafBase = uint32_t(leafStart[r]);
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
    if (!placed && ranges.size() > 1)
      std::copy(t.leafWords.begin(), t.leafWords.end(), v.leafWords.begin() + leafStart[r] * wordsPerLeaf);
    t = RangeTree();
  }
  return v;
}

RangeTree joinRangeTrees(std::vector<RangeTree>&& ranges, LeafWordVector&& leafWords) {
  if (ranges.empty()) throw Error(ErrorKind::InvalidArgument, "joinRangeTrees: no ranges");
  const bool placed = !leafWords.empty();
  if (ranges.size() == 1) {
    RangeTree out = std::move(ranges[0]);
    if (placed) out.leafWords = std::move(leafWords);
    return out;
  }
  const size_t levels = ranges.front().levels.size();
  RangeTree out;
  out.cells = RootRange{ranges.front().cells.first, ranges.back().cells.end};
  out.levels.resize(levels);
  if (placed) out.leafWords = std::move(leafWords);
  uint64_t leafBase = 0, cellsSoFar = 0;
  std::vector<uint64_t> base(levels + 1, 0); // earlier ranges' elements per level
  for (size_t r = 0; r < ranges.size(); ++r) {
    RangeTree& t = ranges[r];
    if (t.levels.size() != levels) throw Error(ErrorKind::InvalidArgument, "joinRangeTrees: levels differ");
    if (t.cells.first != out.cells.first + cellsSoFar)
      throw Error(ErrorKind::InvalidArgument, "joinRangeTrees: the ranges are not contiguous");
    cellsSoFar += t.cells.size();
    for (size_t k = 0; k < levels; ++k) {
      std::vector<ElementWord>& words = out.levels[k];
      for (const ElementWord w : t.levels[k]) {
        switch (elementState(w)) {
        case ElementState::Branch: words.push_back(makeElement(ElementState::Branch, uint32_t(elementPayload(w) + base[k + 1]))); break;
        case ElementState::Boundary: words.push_back(makeElement(ElementState::Boundary, uint32_t(elementPayload(w) + leafBase))); break;
        default: words.push_back(w);
        }
      }
    }
    for (size_t k = 0; k < levels; ++k) base[k] += t.levels[k].size();
    const uint64_t leaves = t.leafCoord.size();
    leafBase += leaves;
    out.leafCoord.insert(out.leafCoord.end(), t.leafCoord.begin(), t.leafCoord.end());
    if (!placed) out.leafWords.insert(out.leafWords.end(), t.leafWords.begin(), t.leafWords.end());
    t = RangeTree();
  }
  return out;
}

// ---- lines of leaves ------------------------------------------------------------------

RangeLines lineParity(const GridSpec& g, const std::vector<uint64_t>& leafCoord, int axis, uint32_t* parity,
                      LineParities* boundary) {
  const size_t n = leafCoord.size();
  const int rw = rowWordsFor(g.leafSize);
  RangeLines t;
  t.keys = LineKeys{lineFieldBits(uint64_t(g.resolution / g.leafSize))};
  std::vector<std::pair<uint64_t, uint32_t>> order(n);
  tbb::parallel_for(size_t(0), n, [&](size_t i) { order[i] = {t.keys.ofLeaf(leafCoord[i], axis), uint32_t(i)}; });
  tbb::parallel_sort(order.begin(), order.end()); // keys are distinct
  t.key.resize(n);
  t.leaf.resize(n);
  t.entry.assign(n, 0);
  std::vector<uint32_t> running(size_t(rw), 0u);
  for (size_t i = n; i-- > 0;) {
    t.key[i] = order[i].first;
    t.leaf[i] = order[i].second;
    if (i + 1 == n || !t.keys.sameLine(order[i].first, order[i + 1].first))
      std::fill(running.begin(), running.end(), 0u);
    suffixParityStep(parity + size_t(order[i].second) * rw, running.data(), rw);
    t.entry[order[i].second] = uint8_t(running[0] & 1u);
    const bool lineStart = i == 0 || !t.keys.sameLine(order[i - 1].first, order[i].first);
    if (boundary && lineStart) { // lines are visited last to first: reversed below
      boundary->line.push_back(t.keys.line(order[i].first));
      boundary->words.insert(boundary->words.end(), running.begin(), running.end());
    }
  }
  if (boundary) {
    std::reverse(boundary->line.begin(), boundary->line.end());
    const size_t lines = boundary->line.size();
    for (size_t a = 0, b = lines; a + 1 < b; ++a, --b)
      std::swap_ranges(boundary->words.begin() + a * rw, boundary->words.begin() + (a + 1) * rw,
                       boundary->words.begin() + (b - 1) * rw);
  }
  return t;
}

namespace {

// XOR of two sorted line-parity sets.
LineParities xorLines(const LineParities& a, const LineParities& b, int rw) {
  LineParities out;
  size_t i = 0, j = 0;
  auto take = [&](const LineParities& s, size_t k) {
    out.line.push_back(s.line[k]);
    out.words.insert(out.words.end(), s.words.begin() + k * rw, s.words.begin() + (k + 1) * rw);
  };
  while (i < a.line.size() || j < b.line.size()) {
    if (j == b.line.size() || (i < a.line.size() && a.line[i] < b.line[j])) {
      take(a, i++);
    } else if (i == a.line.size() || b.line[j] < a.line[i]) {
      take(b, j++);
    } else {
      take(a, i);
      for (int k = 0; k < rw; ++k) out.words[out.words.size() - rw + k] ^= b.words[j * rw + k];
      ++i;
      ++j;
    }
  }
  return out;
}

// The parity words of `line` in a sorted set, or null.
const uint32_t* findLine(const LineParities& s, uint64_t line, int rw) {
  auto it = std::lower_bound(s.line.begin(), s.line.end(), line);
  if (it == s.line.end() || *it != line) return nullptr;
  return s.words.data() + size_t(it - s.line.begin()) * rw;
}

} // namespace

std::vector<RangeBoundary> parityBeyondRanges(const std::vector<RangeBoundary>& boundaries, int axes, int rowWords) {
  std::vector<RangeBoundary> beyond(boundaries.size());
  RangeBoundary later;
  for (size_t r = boundaries.size(); r-- > 0;) {
    beyond[r] = later;
    for (int a = 0; a < axes; ++a) later.axis[a] = xorLines(later.axis[a], boundaries[r].axis[a], rowWords);
  }
  return beyond;
}

void stitchLineParity(RangeLines& t, const LineParities& beyond, uint32_t* exitParity, int rw) {
  if (beyond.line.empty()) return;
  tbb::parallel_for(size_t(0), t.key.size(), [&](size_t i) {
    const uint32_t* b = findLine(beyond, t.keys.line(t.key[i]), rw);
    if (!b) return;
    uint32_t* p = exitParity + size_t(t.leaf[i]) * rw;
    for (int k = 0; k < rw; ++k) p[k] ^= b[k];
    t.entry[t.leaf[i]] ^= uint8_t(b[0] & 1u);
  });
}

namespace {

// Entry parity (row 0) of the first leaf beyond the uniform element at
// `coord` on its line along `axis`.
bool uniformParity(const GridSpec& g, const RangeLines& t, const LineParities* beyond, int axis, uint64_t coord,
                   int level) {
  const uint64_t leavesPerElement = uint64_t(g.elementVoxels(level)) / uint64_t(g.leafSize);
  uint64_t key;
  if (!uniformLineKey(t.keys, coord, leavesPerElement, uint64_t(g.resolution / g.leafSize), axis, key)) return false;
  auto it = std::lower_bound(t.key.begin(), t.key.end(), key);
  if (it != t.key.end() && t.keys.sameLine(*it, key)) return t.entry[t.leaf[size_t(it - t.key.begin())]] & 1u;
  const uint32_t* b = beyond ? findLine(*beyond, t.keys.line(key), rowWordsFor(g.leafSize)) : nullptr;
  return b && (b[0] & 1u);
}

} // namespace

void classifyUniformElements(const GridSpec& g, RangeTree& tree, int axes, const RangeLines* const lines[3],
                             const RangeBoundary* beyond) {
  const uint64_t R = uint64_t(g.rootGrid);
  std::vector<uint64_t> coords(tree.cells.size()), next;
  for (uint64_t i = 0; i < coords.size(); ++i) {
    const uint64_t c = tree.cells.first + i;
    coords[i] = packCoord(uint32_t(c % R), uint32_t((c / R) % R), uint32_t(c / (R * R)));
  }
  for (size_t level = 0; level < tree.levels.size(); ++level) {
    std::vector<ElementWord>& words = tree.levels[level];
    if (level + 1 < tree.levels.size()) next.assign(tree.levels[level + 1].size(), 0);
    tbb::parallel_for(size_t(0), words.size(), [&](size_t i) {
      const ElementWord w = words[i];
      if (elementState(w) == ElementState::Branch) {
        for (int c = 0; c < 8; ++c) next[elementPayload(w) + c] = childCoord(coords[i], c);
        return;
      }
      if (elementState(w) != ElementState::Empty) return;
      int votes = 0;
      for (int a = 0; a < axes; ++a)
        votes += uniformParity(g, *lines[a], beyond ? &beyond->axis[a] : nullptr, a, coords[i], int(level));
      if (majorityInside(votes, axes)) words[i] = makeElement(ElementState::Full, 0);
    });
    coords.swap(next);
  }
}

} // namespace hdt
