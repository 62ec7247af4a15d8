// Part labels on voxels: per-part builds combined into one labelled volume
// (hdt/labels.hpp says what the result means).
#include "hdt/labels.hpp"

#include "hdt/error.hpp"
#include "hdt/host_memory.hpp"
#include "hdt/mesh.hpp"
#include "hdt/volume_walk.hpp"

#include <tbb/blocked_range.h>
#include <tbb/enumerable_thread_specific.h>
#include <tbb/parallel_for.h>
#include <tbb/parallel_scan.h>

#include <algorithm>
#include <array>
#include <chrono>
#include <functional>
#include <map>
#include <utility>

namespace hdt {

LabelRanking::LabelRanking(const LabelOptions& options) : rank_(65536) {
  for (uint32_t l = 0; l < 65536; ++l) {
    switch (options.overlap) {
    case OverlapPolicy::Lowest:
    case OverlapPolicy::Priority: rank_[l] = 65536 + l; break;
    case OverlapPolicy::Highest: rank_[l] = 65536 + (65535 - l); break;
    }
  }
  if (options.overlap == OverlapPolicy::Priority) {
    // Listed labels first, in list order; a repeated label keeps its first place.
    for (size_t i = options.priority.size(); i-- > 0;) rank_[options.priority[i]] = uint32_t(i);
  }
}

namespace {

// A part's claim on an element of the combined tree: the part's own element
// there, or "Full" inherited from a Full ancestor.
constexpr uint64_t kInheritedFull = ~uint64_t(0);
struct Claim {
  uint32_t part;
  uint64_t element;
};

// Claims grouped by combined element: element i owns claims[start[i] .. start[i+1]).
struct ClaimLists {
  std::vector<Claim> claims;
  std::vector<uint64_t> start{0};
  void close() { start.push_back(claims.size()); }
  size_t size() const { return start.size() - 1; }
};

bool isFullClaim(const std::vector<Volume>& parts, const Claim& c) {
  return c.element == kInheritedFull || elementState(parts[c.part].elements[c.element]) == ElementState::Full;
}

// The claims of part `part` on child `child` of an element the part holds as `c`.
void pushChildClaim(const std::vector<Volume>& parts, const Claim& c, int child, ClaimLists& next) {
  if (isFullClaim(parts, c)) {
    next.claims.push_back({c.part, kInheritedFull});
    return;
  }
  const ElementWord w = parts[c.part].elements[c.element];
  if (elementState(w) != ElementState::Branch) return; // Empty: no claim
  const uint64_t k = uint64_t(elementPayload(w)) + uint64_t(child);
  if (elementState(parts[c.part].elements[k]) != ElementState::Empty) next.claims.push_back({c.part, k});
}

// One combined leaf's words: the OR of the claims' surface and inside
// planes, inside only where no claim has surface.
uint32_t claimWord(const std::vector<Volume>& parts, const Claim& c, uint32_t w) {
  if (c.element == kInheritedFull) return kInsidePlaneBits; // all Inside
  return parts[c.part].leaf(elementPayload(parts[c.part].elements[c.element]))[w];
}

void combineLeafWords(const std::vector<Volume>& parts, const Claim* claims, size_t count, uint32_t* out) {
  const uint32_t words = leafWordCount(parts[0].grid.leafSize);
  for (uint32_t w = 0; w < words; ++w) {
    uint32_t surface = 0, inside = 0;
    for (size_t i = 0; i < count; ++i) {
      const uint32_t pw = claimWord(parts, claims[i], w);
      surface |= planeOf(pw, kSurfacePlane);
      inside |= planeOf(pw, kInsidePlane);
    }
    inside &= ~surface;
    out[w] = inside | (surface << 1);
  }
}

// The labels of a combined leaf (words as combineLeafWords made them): the
// one label of its non-Outside voxels, or 0 when it holds several; then
// `voxels` (L^3, written only for several claims) holds every voxel's label:
// the best, by the policy, of the claims in the voxel's combined state.
Label combineLeafLabels(const std::vector<Volume>& parts, const std::vector<Label>& partLabels,
                        const LabelRanking& ranking, const Claim* claims, size_t count, const uint32_t* combined,
                        Label* voxels) {
  if (count == 1) return partLabels[claims[0].part];
  const int L = parts[0].grid.leafSize;
  const uint32_t words = leafWordCount(L);
  std::fill(voxels, voxels + size_t(L) * L * L, kOutsideLabel);
  for (size_t i = 0; i < count; ++i) {
    const Label label = partLabels[claims[i].part];
    for (uint32_t w = 0; w < words; ++w) {
      const uint32_t pw = claimWord(parts, claims[i], w), c = combined[w];
      uint32_t mine = (planeOf(pw, kSurfacePlane) & planeOf(c, kSurfacePlane)) |
                      (planeOf(pw, kInsidePlane) & planeOf(c, kInsidePlane));
      while (mine) {
        const int bit = __builtin_ctz(mine);
        mine &= mine - 1;
        Label& v = voxels[size_t(w) * kVoxelsPerWord + size_t(bit / 2)];
        v = v == kOutsideLabel ? label : ranking.best(v, label);
      }
    }
  }
  Label only = kOutsideLabel;
  for (size_t j = 0; j < size_t(L) * L * L; ++j) {
    if (voxels[j] == kOutsideLabel) continue;
    if (only == kOutsideLabel) only = voxels[j];
    if (voxels[j] != only) return kOutsideLabel; // mixed
  }
  return only;
}

void checkParts(const std::vector<Volume>& parts, const std::vector<Label>& partLabels) {
  if (parts.empty() || parts.size() != partLabels.size())
    throw Error(ErrorKind::InvalidArgument, "labelled build: no parts, or not one label per part");
  std::vector<Label> sorted = partLabels;
  std::sort(sorted.begin(), sorted.end());
  if (sorted.front() == kOutsideLabel || std::adjacent_find(sorted.begin(), sorted.end()) != sorted.end())
    throw Error(ErrorKind::InvalidArgument, "labelled build: part labels must be distinct and >= 1");
  const GridSpec& g = parts[0].grid;
  for (const Volume& p : parts) {
    const GridSpec& q = p.grid;
    if (q.resolution != g.resolution || q.rootGrid != g.rootGrid || q.leafSize != g.leafSize ||
        q.height != g.height || q.origin != g.origin || q.voxelSize != g.voxelSize ||
        p.surfaceOnly != parts[0].surfaceOnly)
      throw Error(ErrorKind::InvalidArgument, "labelled build: the parts are not on one grid");
  }
}

} // namespace

Volume combineLabelledParts(const std::vector<Volume>& parts, const std::vector<Label>& partLabels,
                            const LabelOptions& options) {
  checkParts(parts, partLabels);
  const auto t0 = std::chrono::steady_clock::now();
  const LabelRanking ranking(options);
  Volume out;
  out.grid = parts[0].grid;
  out.surfaceOnly = parts[0].surfaceOnly;
  out.closedMesh = true;
  out.insideTest = parts[0].insideTest;
  for (const Volume& p : parts) {
    out.closedMesh = out.closedMesh && p.closedMesh;
    // Auto may have picked different tests for closed and open parts.
    if (p.insideTest != out.insideTest) out.insideTest = InsideTest::WindingNumber;
  }
  const GridSpec& g = out.grid;
  std::vector<Label>& elementLabels = out.labels.elementLabels;

  // The tree, level by level (types.hpp order): an element branches when a
  // part branches there, is Full when a part is Full there.
  ClaimLists level, leafClaims;
  const uint64_t roots = uint64_t(g.rootGrid) * g.rootGrid * g.rootGrid;
  for (uint64_t r = 0; r < roots; ++r) {
    for (uint32_t p = 0; p < parts.size(); ++p)
      if (elementState(parts[p].elements[r]) != ElementState::Empty) level.claims.push_back({p, r});
    level.close();
  }
  std::vector<uint64_t> leafElement;
  for (int k = 0; k <= g.height; ++k) {
    out.levelStart.push_back(out.elements.size());
    const uint64_t firstChild = out.elements.size() + level.size();
    uint32_t branches = 0;
    ClaimLists next;
    for (size_t i = 0; i < level.size(); ++i) {
      const Claim* c = level.claims.data() + level.start[i];
      const size_t n = size_t(level.start[i + 1] - level.start[i]);
      bool refined = false;
      Label full = kOutsideLabel;
      for (size_t j = 0; j < n; ++j) {
        if (isFullClaim(parts, c[j])) {
          const Label l = partLabels[c[j].part];
          full = full == kOutsideLabel ? l : ranking.best(full, l);
        } else {
          refined = true; // Branch, or Boundary at level h
        }
      }
      if (refined && k < g.height) {
        out.elements.push_back(makeElement(ElementState::Branch, uint32_t(firstChild + 8 * uint64_t(branches++))));
        elementLabels.push_back(kOutsideLabel);
        for (int child = 0; child < 8; ++child) {
          for (size_t j = 0; j < n; ++j) pushChildClaim(parts, c[j], child, next);
          next.close();
        }
      } else if (refined) {
        out.elements.push_back(makeElement(ElementState::Boundary, uint32_t(leafElement.size())));
        elementLabels.push_back(kOutsideLabel); // set once the leaf is combined
        leafElement.push_back(out.elements.size() - 1);
        for (size_t j = 0; j < n; ++j)
          leafClaims.claims.push_back(isFullClaim(parts, c[j]) ? Claim{c[j].part, kInheritedFull} : c[j]);
        leafClaims.close();
      } else {
        out.elements.push_back(makeElement(full ? ElementState::Full : ElementState::Empty, 0));
        elementLabels.push_back(full);
      }
      if (out.elements.size() > kMaxElementPayload)
        throw Error(ErrorKind::OutOfResources, "labelled build: more than 2^30 - 1 tree elements");
    }
    level = std::move(next);
  }
  out.levelStart.push_back(out.elements.size());

  // The leaves, in parallel, each writing its own words, label and (mixed)
  // palette; the voxel labels of mixed leaves are computed again straight
  // into their compact place once the blocks are counted.
  const uint32_t words = leafWordCount(g.leafSize);
  const uint32_t voxels = uint32_t(g.leafSize) * g.leafSize * g.leafSize;
  const size_t leafCount = leafElement.size();
  out.leafWords.resize(leafCount * words);
  std::vector<Label> leafLabels(leafCount);
  std::vector<LeafPalette> leafPalettes(leafCount);
  auto claimsOf = [&](size_t i) { return leafClaims.claims.data() + leafClaims.start[i]; };
  auto countOf = [&](size_t i) { return size_t(leafClaims.start[i + 1] - leafClaims.start[i]); };
  tbb::enumerable_thread_specific<std::vector<Label>> scratch([&] { return std::vector<Label>(voxels); });
  tbb::parallel_for(size_t(0), leafCount, [&](size_t i) {
    uint32_t* w = out.leafWords.data() + i * words;
    combineLeafWords(parts, claimsOf(i), countOf(i), w);
    Label* labels = scratch.local().data();
    leafLabels[i] = combineLeafLabels(parts, partLabels, ranking, claimsOf(i), countOf(i), w, labels);
    uint32_t distinct = 0;
    if (leafLabels[i] == kOutsideLabel) leafPalettes[i] = paletteOfLeaf(labels, voxels, distinct);
  });
  LabelField& f = out.labels;
  for (size_t i = 0; i < leafCount; ++i) {
    elementLabels[leafElement[i]] = leafLabels[i];
    if (leafLabels[i] == kOutsideLabel) f.palettes.push_back(leafPalettes[i]);
  }
  indexMixedLeaves(out);
  std::vector<size_t> mixedLeaves;
  for (size_t i = 0; i < leafCount; ++i)
    if (leafLabels[i] == kOutsideLabel) mixedLeaves.push_back(i);
  size_t wide = 0;
  for (const LeafPalette& p : f.palettes) wide += p.isWide();
  f.paletteIndices.resize((f.palettes.size() - wide) * words);
  f.wideLabels.resize(wide * voxels);
  tbb::parallel_for(size_t(0), mixedLeaves.size(), [&](size_t k) {
    const size_t i = mixedLeaves[k], block = f.mixedBlock[k];
    const bool isWide = f.palettes[k].isWide();
    Label* labels = isWide ? f.wideLabels.data() + block * voxels : scratch.local().data();
    combineLeafLabels(parts, partLabels, ranking, claimsOf(i), countOf(i), out.leafWords.data() + i * words, labels);
    if (!isWide) packPaletteIndices(labels, voxels, f.palettes[k], f.paletteIndices.data() + block * words);
  });

  computeStructureStatistics(out);
  Statistics& s = out.stats;
  s.backend = parts[0].stats.backend;
  s.threads = parts[0].stats.threads;
  for (const Volume& p : parts) {
    s.triangles += p.stats.triangles;
    s.degenerateTriangles += p.stats.degenerateTriangles;
    s.time.mapping += p.stats.time.mapping;
    s.time.branching += p.stats.time.branching;
    s.time.leaf += p.stats.time.leaf;
    s.time.classify += p.stats.time.classify;
    s.time.total += p.stats.time.total;
    s.peakHostBytes = std::max(s.peakHostBytes, p.stats.peakHostBytes);
    s.peakDeviceBytes = std::max(s.peakDeviceBytes, p.stats.peakDeviceBytes);
  }
  s.time.total += std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count();
  // The combination holds every part and the result at once: the process's peak so far.
  s.peakHostBytes = std::max(s.peakHostBytes, peakResidentBytes());
  return out;
}

namespace {

// Numbers the items in [0, items) that `counts` selects, in order, and hands
// each its number through `visit` (tbb::parallel_scan: a deterministic prefix
// sum whatever the thread count). Returns how many were numbered.
template <class Counts, class Visit>
uint64_t numberInOrder(size_t items, const Counts& counts, const Visit& visit) {
  return tbb::parallel_scan(
      tbb::blocked_range<size_t>(0, items, size_t(1) << 14), uint64_t(0),
      [&](const tbb::blocked_range<size_t>& r, uint64_t before, bool isFinal) {
        for (size_t i = r.begin(); i < r.end(); ++i) {
          if (!counts(i)) continue;
          if (isFinal) visit(i, before);
          ++before;
        }
        return before;
      },
      std::plus<uint64_t>());
}

} // namespace

// Mixed leaves numbered in element order; their blocks number wide and
// palette leaves apart, each in mixed order.
void indexMixedLeaves(Volume& v) {
  LabelField& f = v.labels;
  f.mixedIndex.clear();
  f.mixedBlock.clear();
  if (f.empty()) return;
  const uint64_t first = v.levelStart[size_t(v.grid.height)];
  const size_t leafLevel = v.elements.size() - first;
  const auto isMixed = [&](size_t i) {
    return elementState(v.elements[first + i]) == ElementState::Boundary &&
           f.elementLabels[first + i] == kOutsideLabel;
  };
  f.mixedIndex.assign(v.leafCount(), kNotMixed);
  const uint64_t mixed = numberInOrder(leafLevel, isMixed, [&](size_t i, uint64_t k) {
    // Past the palettes' count the numbers are not stored: the check below throws.
    if (k < f.palettes.size()) f.mixedIndex[elementPayload(v.elements[first + i])] = uint32_t(k);
  });
  if (mixed != f.palettes.size()) {
    f.mixedIndex.clear();
    throw Error(ErrorKind::InvalidArgument, "labels: " + std::to_string(f.palettes.size()) + " palettes for " +
                                                std::to_string(mixed) + " mixed leaves");
  }
  f.mixedBlock.resize(mixed);
  const auto isWide = [&](size_t k) { return f.palettes[k].isWide(); };
  const auto numberBlock = [&](size_t k, uint64_t block) { f.mixedBlock[k] = uint32_t(block); };
  numberInOrder(mixed, isWide, numberBlock);
  numberInOrder(mixed, [&](size_t k) { return !isWide(k); }, numberBlock);
}

LeafLabels leafLabels(const Volume& v, uint64_t element) {
  const LabelField& f = v.labels;
  const uint32_t leaf = elementPayload(v.elements[element]);
  const uint32_t* words = v.leaf(leaf);
  const Label single = f.elementLabels[element];
  if (single != kOutsideLabel) return LeafLabels(words, single, nullptr, nullptr, nullptr);
  const uint32_t k = f.mixedIndex[leaf];
  const size_t block = f.mixedBlock[k];
  if (f.palettes[k].isWide())
    return LeafLabels(words, kOutsideLabel, nullptr, nullptr, f.wideLabels.data() + block * v.grid.leafVoxels());
  return LeafLabels(words, kOutsideLabel, f.palettes[k].labels,
                    f.paletteIndices.data() + block * leafWordCount(v.grid.leafSize), nullptr);
}

LeafPalette paletteOfLeaf(const Label* voxels, uint32_t voxelCount, uint32_t& distinct) {
  Label seen[kPaletteSize + 1] = {};
  distinct = 0;
  for (uint32_t j = 0; j < voxelCount && distinct <= uint32_t(kPaletteSize); ++j) {
    const Label l = voxels[j];
    if (l == kOutsideLabel || std::find(seen, seen + distinct, l) != seen + distinct) continue;
    seen[distinct++] = l;
  }
  LeafPalette p{};
  if (distinct > uint32_t(kPaletteSize)) return p; // wide
  std::sort(seen, seen + distinct);
  std::copy(seen, seen + distinct, p.labels);
  return p;
}

void packPaletteIndices(const Label* voxels, uint32_t voxelCount, const LeafPalette& palette, uint32_t* indexWords) {
  for (uint32_t w = 0; w < voxelCount / kVoxelsPerWord; ++w) {
    uint32_t word = 0;
    for (uint32_t b = 0; b < uint32_t(kVoxelsPerWord); ++b)
      word |= paletteSlotOf(palette.labels, voxels[w * kVoxelsPerWord + b]) << (kPaletteIndexBits * b);
    indexWords[w] = word;
  }
}

void packVoxelLabels(Volume& v, const Label* mixedLeafVoxels) {
  LabelField& f = v.labels;
  const uint32_t voxels = uint32_t(v.grid.leafVoxels()), words = leafWordCount(v.grid.leafSize);
  size_t mixed = 0;
  for (uint64_t i = v.levelStart[size_t(v.grid.height)]; i < v.elements.size(); ++i)
    mixed += elementState(v.elements[i]) == ElementState::Boundary && f.elementLabels[i] == kOutsideLabel;
  f.palettes.resize(mixed);
  size_t wide = 0;
  tbb::parallel_for(size_t(0), mixed, [&](size_t k) {
    uint32_t distinct = 0;
    f.palettes[k] = paletteOfLeaf(mixedLeafVoxels + k * voxels, voxels, distinct);
  });
  for (const LeafPalette& p : f.palettes) wide += p.isWide();
  indexMixedLeaves(v);
  f.paletteIndices.resize((mixed - wide) * words);
  f.wideLabels.resize(wide * voxels);
  tbb::parallel_for(size_t(0), mixed, [&](size_t k) {
    const Label* labels = mixedLeafVoxels + k * voxels;
    const size_t block = f.mixedBlock[k];
    if (f.palettes[k].isWide())
      std::copy(labels, labels + voxels, f.wideLabels.data() + block * voxels);
    else
      packPaletteIndices(labels, voxels, f.palettes[k], f.paletteIndices.data() + block * words);
  });
}

std::vector<Label> unpackVoxelLabels(const Volume& v) {
  const LabelField& f = v.labels;
  const uint32_t voxels = uint32_t(v.grid.leafVoxels());
  std::vector<Label> out(f.palettes.size() * voxels);
  for (uint64_t i = v.levelStart[size_t(v.grid.height)]; i < v.elements.size(); ++i) {
    const ElementWord w = v.elements[i];
    if (elementState(w) != ElementState::Boundary || f.elementLabels[i] != kOutsideLabel) continue;
    const LeafLabels labels = leafLabels(v, i);
    Label* block = out.data() + size_t(f.mixedIndex[elementPayload(w)]) * voxels;
    for (uint32_t j = 0; j < voxels; ++j) block[j] = labels[j];
  }
  return out;
}

Label labelAt(const Volume& v, int x, int y, int z) {
  const GridSpec& g = v.grid;
  if (v.labels.empty() || x < 0 || y < 0 || z < 0 || x >= g.resolution || y >= g.resolution ||
      z >= g.resolution)
    return kOutsideLabel;
  const WalkedElement e = locateElement(v, x, y, z, g.height);
  if (e.state() != ElementState::Boundary) return v.labels.elementLabels[e.index];
  const int L = g.leafSize, lx = x - e.origin[0], ly = y - e.origin[1], lz = z - e.origin[2];
  return leafLabels(v, e.index)[uint32_t(lx + L * (ly + L * lz))];
}

void addToHistogram(LabelHistogram& h, Label label, uint64_t count) {
  if (label == kOutsideLabel || count == 0) return;
  auto it = std::lower_bound(h.begin(), h.end(), label,
                             [](const std::pair<Label, uint64_t>& e, Label l) { return e.first < l; });
  if (it != h.end() && it->first == label)
    it->second += count;
  else
    h.insert(it, {label, count});
}

Label majorityLabel(const LabelHistogram& h) {
  Label best = kOutsideLabel;
  uint64_t most = 0;
  for (const auto& entry : h)
    if (entry.second > most) { // strictly: ties keep the lower label
      best = entry.first;
      most = entry.second;
    }
  return best;
}

namespace {

// The labels of the voxels of the box [o, o + edge)^3 that lie in Boundary element e.
void addLeafVoxels(const Volume& v, const WalkedElement& e, const std::array<int, 3>& o, int edge,
                   LabelHistogram& h) {
  const int L = v.grid.leafSize;
  const LeafLabels labels = leafLabels(v, e.index);
  std::array<int, 3> lo, hi;
  for (int a = 0; a < 3; ++a) {
    lo[size_t(a)] = std::max(o[size_t(a)], e.origin[a]) - e.origin[a];
    hi[size_t(a)] = std::min(o[size_t(a)] + edge, e.origin[a] + L) - e.origin[a];
  }
  // Counted per label first: the histogram's sorted insert is the slow part.
  Label last = kOutsideLabel;
  uint64_t run = 0;
  for (int z = lo[2]; z < hi[2]; ++z)
    for (int y = lo[1]; y < hi[1]; ++y)
      for (int x = lo[0]; x < hi[0]; ++x) {
        const Label l = labels[uint32_t(x + L * (y + L * z))];
        if (l == last) {
          ++run;
          continue;
        }
        addToHistogram(h, last, run);
        last = l;
        run = 1;
      }
  addToHistogram(h, last, run);
}

} // namespace

LabelHistogram cellLabelHistogram(const Volume& v, int x, int y, int z, int edge) {
  LabelHistogram h;
  if (v.labels.empty()) return h;
  const int rootEdge = v.grid.rootCellVoxels();
  int level = 0;
  while ((rootEdge >> level) > edge && level < v.grid.height) ++level;
  const std::array<int, 3> o = {x, y, z};
  auto visit = [&](const WalkedElement& e) {
    if (e.state() == ElementState::Boundary) {
      addLeafVoxels(v, e, o, edge, h);
    } else if (e.state() == ElementState::Full) {
      // A uniform element larger than the cell counts only the cell's voxels.
      const uint64_t side = uint64_t(std::min(edge, e.edge));
      addToHistogram(h, v.labels.elementLabels[e.index], side * side * side);
    }
  };
  walkSubtree(v, locateElement(v, x, y, z, level), v.grid.height, visit);
  return h;
}

namespace {

// Surface and inside voxels of Boundary element `element`, per label.
void countLeafVoxels(const Volume& v, uint64_t element, std::vector<uint64_t>& surface, std::vector<uint64_t>& inside) {
  const uint32_t words = leafWordCount(v.grid.leafSize);
  const uint32_t* leaf = v.leaf(elementPayload(v.elements[element]));
  const LeafLabels labels = leafLabels(v, element);
  if (!labels.mixed()) {
    for (uint32_t j = 0; j < words; ++j) {
      surface[labels.single()] += planeCount(leaf[j], kSurfacePlane);
      inside[labels.single()] += planeCount(leaf[j], kInsidePlane);
    }
    return;
  }
  if (const Label* palette = labels.palette()) {
    for (uint32_t j = 0; j < words; ++j)
      for (uint32_t slot = 0; slot < uint32_t(kPaletteSize) && palette[slot] != kOutsideLabel; ++slot) {
        const uint32_t mine = paletteSlotVoxels(labels.paletteIndices()[j], slot);
        surface[palette[slot]] += popcount32(planeOf(leaf[j], kSurfacePlane) & mine);
        inside[palette[slot]] += popcount32(planeOf(leaf[j], kInsidePlane) & mine);
      }
    return;
  }
  for (uint32_t j = 0; j < words * kVoxelsPerWord; ++j) {
    const VoxelState s = VoxelState((leaf[j / kVoxelsPerWord] >> (2 * (j % kVoxelsPerWord))) & 3u);
    if (s == VoxelState::Surface) ++surface[labels[j]];
    if (s == VoxelState::Inside) ++inside[labels[j]];
  }
}

} // namespace

std::vector<LabelStatistics> labelStatistics(const Volume& v) {
  std::vector<LabelStatistics> table;
  if (v.labels.empty()) return table;
  const LabelField& f = v.labels;
  const GridSpec& g = v.grid;
  // Counts per thread over chunks of elements, then added up (integers: the
  // same sums whatever the split).
  struct Counts {
    std::vector<uint64_t> surface = std::vector<uint64_t>(65536, 0), inside = std::vector<uint64_t>(65536, 0);
  };
  tbb::enumerable_thread_specific<Counts> perThread;
  for (int k = 0; k <= g.height; ++k) {
    const uint64_t edge = uint64_t(g.elementVoxels(k));
    tbb::parallel_for(tbb::blocked_range<uint64_t>(v.levelStart[size_t(k)], v.levelStart[size_t(k) + 1], 1 << 14),
                      [&](const tbb::blocked_range<uint64_t>& r) {
                        Counts& c = perThread.local();
                        for (uint64_t i = r.begin(); i != r.end(); ++i) {
                          const ElementWord w = v.elements[i];
                          if (elementState(w) == ElementState::Full) c.inside[f.elementLabels[i]] += edge * edge * edge;
                          if (elementState(w) != ElementState::Boundary) continue;
                          countLeafVoxels(v, i, c.surface, c.inside);
                        }
                      });
  }
  std::vector<uint64_t> surface(65536, 0), inside(65536, 0);
  for (const Counts& c : perThread) {
    for (size_t l = 0; l < surface.size(); ++l) {
      surface[l] += c.surface[l];
      inside[l] += c.inside[l];
    }
  }
  const double s = g.voxelSize;
  for (uint32_t l = 1; l < 65536; ++l) {
    const auto name = f.names.find(Label(l));
    if (surface[l] == 0 && inside[l] == 0 && name == f.names.end()) continue;
    LabelStatistics row;
    row.label = Label(l);
    if (name != f.names.end()) row.name = name->second;
    row.surfaceVoxels = surface[l];
    row.insideVoxels = inside[l];
    row.volume = double(surface[l] + inside[l]) * s * s * s;
    row.surfaceArea = 2.0 / 3.0 * double(surface[l]) * s * s;
    table.push_back(std::move(row));
  }
  return table;
}

uint64_t labelFieldBytes(const Volume& v) {
  const LabelField& f = v.labels;
  return f.elementLabels.size() * sizeof(Label) + f.palettes.size() * sizeof(LeafPalette) +
         f.paletteIndices.size() * sizeof(uint32_t) + f.wideLabels.size() * sizeof(Label) +
         (f.mixedIndex.size() + f.mixedBlock.size()) * sizeof(uint32_t);
}

} // namespace hdt
