// Buffers, slices and piece volumes of a build spread over processes
// (range_exchange.hpp).
#include "hdt/range_exchange.hpp"

#include "hdt/error.hpp"
#include "hdt/huge_pages.hpp"
#include "hdt/mesh.hpp"

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include <algorithm>
#include <cstring>
#include <string>

namespace hdt {

namespace {

// ---- buffers ---------------------------------------------------------------------------
class Writer {
public:
  template <class T> void value(T v) { bytes(&v, sizeof(T)); }
  template <class V> void array(const V& v) {
    value<uint64_t>(v.size());
    bytes(v.data(), v.size() * sizeof(v[0]));
  }
  void bytes(const void* p, size_t n) {
    const size_t at = out.size();
    out.resize(at + n);
    if (n) std::memcpy(out.data() + at, p, n);
  }
  std::vector<uint8_t> out;
};

class Reader {
public:
  Reader(const uint8_t* data, size_t size) : p_(data), left_(size) {}
  template <class T> T value() {
    T v;
    bytes(&v, sizeof(T));
    return v;
  }
  template <class V> void array(V& v) {
    const uint64_t n = value<uint64_t>();
    if (n > left_ / sizeof(v[0])) fail();
    v.resize(n);
    bytes(v.data(), n * sizeof(v[0]));
  }
  void bytes(void* to, size_t n) {
    if (n > left_) fail();
    if (n) std::memcpy(to, p_, n);
    p_ += n;
    left_ -= n;
  }
  void end() const {
    if (left_) fail();
  }

private:
  [[noreturn]] static void fail() { throw Error(ErrorKind::BadInput, "a range buffer from another process is damaged"); }
  const uint8_t* p_;
  size_t left_;
};

constexpr uint32_t kTreeTag = 0x48445452u;     // "HDTR"
constexpr uint32_t kBoundaryTag = 0x48445442u; // "HDTB"
constexpr uint32_t kLevelsTag = 0x4844544Cu;   // "HDTL"

// ---- slices ------------------------------------------------------------------------------
// A source tree seen level by level, starting at root cell `first`.
struct LevelSpans {
  std::vector<const ElementWord*> words;
  std::vector<size_t> count;
  std::vector<uint64_t> childBase; // what a Branch payload counts from (the next level's start)
  const uint32_t* leafWords = nullptr;
  uint64_t leaves = 0;
  RootRange cells;
};

RangeTree slice(const GridSpec& g, const LevelSpans& src, RootRange cells) {
  if (cells.first < src.cells.first || cells.end > src.cells.end || cells.first > cells.end)
    throw Error(ErrorKind::InvalidArgument, "a slice of root cells lies outside its source");
  const uint32_t wordsPerLeaf = leafWordCount(g.leafSize);
  RangeTree t;
  t.cells = cells;
  t.levels.resize(src.words.size());
  uint64_t begin = cells.first - src.cells.first, end = cells.end - src.cells.first;
  uint64_t leafFirst = 0, leafCount = 0, leafLast = 0;
  bool leafSeen = false;
  for (size_t k = 0; k < src.words.size(); ++k) {
    if (end > src.count[k]) throw Error(ErrorKind::BadInput, "a volume's levels do not match its root grid");
    const ElementWord* w = src.words[k];
    uint64_t childFirst = 0, branches = 0;
    bool childSeen = false;
    for (uint64_t i = begin; i < end; ++i) {
      const ElementState s = elementState(w[i]);
      if (s == ElementState::Branch) {
        if (!childSeen) childFirst = elementPayload(w[i]) - src.childBase[k];
        childSeen = true;
        ++branches;
      } else if (s == ElementState::Boundary) {
        if (!leafSeen) leafFirst = elementPayload(w[i]);
        leafSeen = true;
        leafLast = elementPayload(w[i]);
        ++leafCount;
      }
    }
    std::vector<ElementWord>& out = t.levels[k];
    out.assign(w + begin, w + end);
    for (ElementWord& e : out) {
      const ElementState s = elementState(e);
      if (s == ElementState::Branch) e = makeElement(s, uint32_t(elementPayload(e) - src.childBase[k] - childFirst));
      if (s == ElementState::Boundary) e = makeElement(s, uint32_t(elementPayload(e) - leafFirst));
    }
    begin = childFirst;
    end = childFirst + 8 * branches;
  }
  // Leaves are numbered in root-cell order within the level of the leaf grids.
  if (leafCount && leafLast + 1 != leafFirst + leafCount)
    throw Error(ErrorKind::BadInput, "a volume's leaves are not in the order of their elements");
  if (leafFirst + leafCount > src.leaves) throw Error(ErrorKind::BadInput, "a volume's leaf indices exceed its leaves");
  t.leafWords.resize(leafCount * wordsPerLeaf);
  if (leafCount)
    std::memcpy(t.leafWords.data(), src.leafWords + leafFirst * wordsPerLeaf, leafCount * wordsPerLeaf * sizeof(uint32_t));
  return t;
}

RangeTree placeholder(const GridSpec& g, RootRange cells) {
  RangeTree t;
  t.cells = cells;
  t.levels.resize(size_t(g.height) + 1);
  t.levels[0].assign(cells.size(), makeElement(ElementState::Empty, 0));
  return t;
}

} // namespace

std::vector<uint8_t> packBoundary(const RangeBoundary& b, int rowWords) {
  Writer w;
  w.value(kBoundaryTag);
  w.value<int32_t>(rowWords);
  for (const LineParities& a : b.axis) {
    w.array(a.line);
    w.array(a.words);
  }
  return std::move(w.out);
}

RangeBoundary unpackBoundary(const uint8_t* data, size_t size, int rowWords) {
  Reader r(data, size);
  RangeBoundary b;
  if (r.value<uint32_t>() != kBoundaryTag || r.value<int32_t>() != rowWords)
    throw Error(ErrorKind::BadInput, "a boundary buffer from another process is damaged");
  for (LineParities& a : b.axis) {
    r.array(a.line);
    r.array(a.words);
    if (a.words.size() != a.line.size() * size_t(rowWords))
      throw Error(ErrorKind::BadInput, "a boundary buffer from another process is damaged");
  }
  r.end();
  return b;
}

namespace {
// A tree buffer's header and levels (packRangeTree, packRangeLevels: the tag tells them apart).
void writeLevels(Writer& w, uint32_t tag, const RangeTree& t) {
  w.value(tag);
  w.value(t.cells.first);
  w.value(t.cells.end);
  w.value<uint64_t>(t.levels.size());
  for (const std::vector<ElementWord>& level : t.levels) w.array(level);
}

RangeTree readLevels(Reader& r, uint32_t tag, const GridSpec& g) {
  RangeTree t;
  if (r.value<uint32_t>() != tag) throw Error(ErrorKind::BadInput, "a tree buffer from another process is damaged");
  t.cells.first = r.value<uint64_t>();
  t.cells.end = r.value<uint64_t>();
  if (r.value<uint64_t>() != uint64_t(g.height) + 1 || t.cells.first > t.cells.end)
    throw Error(ErrorKind::BadInput, "a tree buffer from another process does not match the grid");
  t.levels.resize(size_t(g.height) + 1);
  for (std::vector<ElementWord>& level : t.levels) r.array(level);
  return t;
}

} // namespace

std::vector<uint8_t> packRangeTree(const RangeTree& t) {
  Writer w;
  writeLevels(w, kTreeTag, t);
  w.value<uint64_t>(t.leafWords.size());
  w.bytes(t.leafWords.data(), t.leafWords.size() * sizeof(uint32_t));
  return std::move(w.out);
}

RangeTree unpackRangeTree(const uint8_t* data, size_t size, const GridSpec& g) {
  Reader r(data, size);
  RangeTree t = readLevels(r, kTreeTag, g);
  const uint64_t words = r.value<uint64_t>();
  if (words > size || words % leafWordCount(g.leafSize))
    throw Error(ErrorKind::BadInput, "a tree buffer from another process is damaged");
  t.leafWords.resize(words);
  r.bytes(t.leafWords.data(), words * sizeof(uint32_t));
  r.end();
  return t;
}

namespace {
// A range's leaves as its Boundary elements count them.
uint64_t boundaryElements(const RangeTree& t) {
  uint64_t n = 0;
  for (const std::vector<ElementWord>& level : t.levels)
    for (const ElementWord w : level) n += elementState(w) == ElementState::Boundary ? 1 : 0;
  return n;
}
} // namespace

std::vector<uint8_t> packRangeLevels(const RangeTree& t) {
  Writer w;
  writeLevels(w, kLevelsTag, t);
  return std::move(w.out);
}

RangeTree unpackRangeLevels(const uint8_t* data, size_t size, const GridSpec& g) {
  Reader r(data, size);
  RangeTree t = readLevels(r, kLevelsTag, g);
  r.end();
  return t;
}

PlacedGather::PlacedGather(const GridSpec& g, const std::vector<uint64_t>& counts)
    : grid_(g), start_(counts.size() + 1, 0), ranges_(counts.size()), added_(counts.size(), false) {
  const uint64_t perLeaf = hdt::leafWordCount(g.leafSize);
  for (size_t r = 0; r < counts.size(); ++r) {
    if (counts[r] % perLeaf || counts[r] > UINT64_MAX / 4 - start_[r])
      throw Error(ErrorKind::BadInput, "range " + std::to_string(r) + " announced a leaf-word count that is not whole leaves");
    start_[r + 1] = start_[r] + counts[r];
  }
  const uint64_t total = start_.back();
  if (total > uint64_t(SIZE_MAX) / sizeof(uint32_t))
    throw Error(ErrorKind::OutOfResources, "the gathered leaf words exceed this machine's address space");
  words_.resize(size_t(total)); // unwritten: every word is received or copied
  adviseHugePages(words_.data(), words_.size() * sizeof(uint32_t));
  prefaultParallel(words_.data(), words_.size() * sizeof(uint32_t));
}

uint32_t* PlacedGather::wordsOf(size_t r) { return words_.data() + start_.at(r); }

void PlacedGather::addLevels(size_t r, RangeTree&& levels) {
  if (!levels.leafWords.empty() || !levels.leafCoord.empty())
    throw Error(ErrorKind::InvalidArgument, "PlacedGather::addLevels: the leaf words go to wordsOf()");
  ranges_.at(r) = std::move(levels);
  added_[r] = true;
}

void PlacedGather::addOwn(size_t r, RangeTree&& own) {
  if (own.leafWords.size() != wordCountOf(r))
    throw Error(ErrorKind::InvalidArgument, "PlacedGather::addOwn: the range's leaf words differ from its announced count");
  uint32_t* to = wordsOf(r);
  tbb::parallel_for(tbb::blocked_range<size_t>(0, own.leafWords.size(), size_t(1) << 22),
                    [&](const tbb::blocked_range<size_t>& b) {
                      std::copy(own.leafWords.begin() + b.begin(), own.leafWords.begin() + b.end(), to + b.begin());
                    });
  own.leafWords = LeafWordVector();
  own.leafCoord.clear();
  addLevels(r, std::move(own));
}

Volume PlacedGather::join() {
  const uint64_t perLeaf = hdt::leafWordCount(grid_.leafSize);
  for (size_t r = 0; r < added_.size(); ++r) {
    if (!added_[r]) throw Error(ErrorKind::InvalidArgument, "PlacedGather::join: range " + std::to_string(r) + " is missing");
    if (boundaryElements(ranges_[r]) * perLeaf != wordCountOf(r))
      throw Error(ErrorKind::BadInput, "range " + std::to_string(r) + "'s leaf words do not match its leaves");
  }
  return joinRanges(grid_, std::move(ranges_), std::move(words_));
}

RangeTree sliceVolume(const Volume& v, RootRange cells) {
  const uint64_t R = uint64_t(v.grid.rootGrid);
  LevelSpans src;
  for (size_t k = 0; k + 1 < v.levelStart.size(); ++k) {
    src.words.push_back(v.elements.data() + v.levelStart[k]);
    src.count.push_back(v.levelStart[k + 1] - v.levelStart[k]);
    src.childBase.push_back(v.levelStart[k + 1]);
  }
  src.leafWords = v.leafWords.data();
  src.leaves = v.leafCount();
  src.cells = RootRange{0, R * R * R};
  return slice(v.grid, src, cells);
}

RangeTree sliceRangeTree(const GridSpec& g, const RangeTree& t, RootRange cells) {
  LevelSpans src;
  for (const std::vector<ElementWord>& level : t.levels) {
    src.words.push_back(level.data());
    src.count.push_back(level.size());
    src.childBase.push_back(0);
  }
  src.leafWords = t.leafWords.data();
  src.leaves = t.leafWords.size() / leafWordCount(g.leafSize);
  src.cells = t.cells;
  return slice(g, src, cells);
}

Volume pieceVolume(const GridSpec& g, std::vector<RangeTree>&& ranges) {
  const uint64_t R = uint64_t(g.rootGrid);
  std::vector<RangeTree> all;
  uint64_t at = 0;
  for (RangeTree& t : ranges) {
    if (t.cells.first < at) throw Error(ErrorKind::InvalidArgument, "pieceVolume: ranges overlap or are out of order");
    if (t.cells.first > at) all.push_back(placeholder(g, RootRange{at, t.cells.first}));
    at = t.cells.end;
    t.leafCoord.clear(); // the join counts leaves by their words
    all.push_back(std::move(t));
  }
  if (at < R * R * R) all.push_back(placeholder(g, RootRange{at, R * R * R}));
  return joinRanges(g, std::move(all));
}

Statistics rangeStructure(const GridSpec& g, const RangeTree& t) {
  Statistics s;
  const uint64_t L = uint64_t(g.leafSize);
  for (size_t k = 0; k < t.levels.size(); ++k) {
    s.treeElements += t.levels[k].size();
    const uint64_t edge = uint64_t(g.elementVoxels(int(k)));
    for (ElementWord w : t.levels[k])
      if (elementState(w) == ElementState::Full) s.insideVoxels += edge * edge * edge;
  }
  s.leafGrids = t.leafWords.size() / leafWordCount(g.leafSize);
  s.leafVoxels = s.leafGrids * L * L * L;
  for (uint32_t w : t.leafWords) {
    s.activeVoxels += planeCount(w, kSurfacePlane);
    s.insideVoxels += planeCount(w, kInsidePlane);
  }
  s.topologyBytes = s.treeElements * sizeof(ElementWord);
  s.leafBytes = t.leafWords.size() * sizeof(uint32_t);
  return s;
}

void addStructure(Statistics& sum, const Statistics& part) {
  uint64_t a[kStructureFields], b[kStructureFields];
  structureToArray(sum, a);
  structureToArray(part, b);
  for (int i = 0; i < kStructureFields; ++i) a[i] += b[i];
  structureFromArray(a, sum);
}

void finishStructure(Statistics& s) {
  s.paperBitsPerActiveVoxel = s.activeVoxels ? double(s.treeElements) * 20.0 * 8.0 / double(s.activeVoxels) : 0.0;
}

void structureToArray(const Statistics& s, uint64_t out[kStructureFields]) {
  out[0] = s.treeElements;
  out[1] = s.leafGrids;
  out[2] = s.leafVoxels;
  out[3] = s.activeVoxels;
  out[4] = s.insideVoxels;
  out[5] = s.leafBytes;
}

void structureFromArray(const uint64_t in[kStructureFields], Statistics& s) {
  s.treeElements = in[0];
  s.leafGrids = in[1];
  s.leafVoxels = in[2];
  s.activeVoxels = in[3];
  s.insideVoxels = in[4];
  s.leafBytes = in[5];
  s.topologyBytes = s.treeElements * sizeof(ElementWord);
}

} // namespace hdt
