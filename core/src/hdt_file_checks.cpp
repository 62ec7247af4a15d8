// The .hdt format's rules checked on a volume (hdt_file_checks.hpp), and
// validateVolume (hdt/volume.hpp), which runs all of them.
#include "hdt_file_checks.hpp"

#include "hdt_file_format.hpp"

#include "hdt/error.hpp"
#include "hdt/labels.hpp"
#include "hdt/lattice.hpp"
#include "hdt/transfer.hpp"

#include <tbb/blocked_range.h>
#include <tbb/parallel_reduce.h>

#include <algorithm>
#include <cmath>

namespace hdt {
namespace hdt_file_detail {

void checkGrid(int64_t N, int64_t R, int64_t L, int64_t h, const std::array<double, 3>& origin,
               double voxelSize) {
  if (L != 8 && L != 16 && L != 32) invalid("grid: leaf size " + std::to_string(L) + " is not 8, 16 or 32");
  if (R < 1 || R > kMaxResolution) invalid("grid: root grid " + std::to_string(R) + " is out of range");
  if (h < 0 || h > kMaxHeight) invalid("grid: height " + std::to_string(h) + " is out of range");
  const int64_t expected = R * (int64_t(1) << h) * L;
  if (N != expected) {
    invalid("grid: resolution " + std::to_string(N) + " is not R * 2^h * L = " + std::to_string(expected));
  }
  if (N > kMaxResolution) {
    invalid("grid: resolution " + std::to_string(N) + " exceeds " + std::to_string(kMaxResolution));
  }
  for (double o : origin)
    if (!std::isfinite(o)) invalid("grid: origin is not finite");
  if (!std::isfinite(voxelSize) || !(voxelSize > 0)) invalid("grid: voxel size is not finite and positive");
}

// Version 2's grid field: the inside test that classified the volume.
void checkInsideTest(uint32_t test) {
  if (test != uint32_t(InsideTest::Parity) && test != uint32_t(InsideTest::WindingNumber)) {
    invalid("grid: inside test " + str(test) + " is neither 1 (parity) nor 2 (winding number)");
  }
}

// The fields that are not derived from the contents (those: checkStructure).
void checkStatisticsFields(const Statistics& s) {
  if (s.backend.size() > kMaxBackendLength) invalid("statistics: backend name longer than 64 bytes");
  for (char c : s.backend)
    if (c < 0x20 || c > 0x7E) invalid("statistics: backend name is not printable ASCII");
  if (s.threads < 0) invalid("statistics: negative thread count");
  const double values[] = {s.paperBitsPerActiveVoxel, s.time.mapping, s.time.branching, s.time.leaf,
                           s.time.classify,           s.time.total};
  for (double v : values)
    if (!std::isfinite(v) || v < 0) invalid("statistics: a time or ratio is negative or not finite");
}

// levelStart: h + 2 entries; see docs/hdt-format.md rule 13.
void checkLevelTable(const std::vector<uint64_t>& ls, const GridSpec& g) {
  if (ls.size() != size_t(g.height) + 2)
    invalid("level table: " + str(ls.size()) + " entries, expected h + 2");
  const uint64_t R = uint64_t(g.rootGrid);
  const uint64_t roots = R * R * R;
  if (roots > kMaxElementPayload) invalid("level table: R^3 = " + str(roots) + " exceeds the element limit");
  if (ls[0] != 0 || ls[1] != roots)
    invalid("level table: level 0 must be the R^3 = " + str(roots) + " root elements");
  for (size_t k = 1; k + 1 < ls.size(); ++k) {
    if (ls[k + 1] < ls[k] || ls[k + 1] > kMaxElementPayload) {
      invalid("level table: start of level " + str(k + 1) + " (" + str(ls[k + 1]) +
              ") is decreasing or beyond the element limit");
    }
    const uint64_t size = ls[k + 1] - ls[k], parents = ls[k] - ls[k - 1];
    if (size % 8 != 0 || size > 8 * parents) {
      invalid("level table: level " + str(k) + " has " + str(size) + " elements, not 8 per branch of the " +
              str(parents) + " elements above");
    }
  }
}

// Rules 14-17: the canonical level-order layout, element by element.
TreeCounts checkElements(const std::vector<ElementWord>& elements, const std::vector<uint64_t>& ls,
                         const GridSpec& g, bool surfaceOnly) {
  TreeCounts counts;
  const int h = g.height;
  for (int k = 0; k <= h; ++k) {
    const bool leafLevel = k == h;
    const uint64_t edge = uint64_t(g.elementVoxels(k));
    uint64_t nextChild = ls[k + 1]; // where the next Branch's children must start
    for (uint64_t i = ls[k]; i < ls[k + 1]; ++i) {
      const ElementWord w = elements[i];
      const uint32_t payload = elementPayload(w);
      // Built only for a message: this loop may run a billion times.
      const auto where = [&] { return "element " + str(i) + " (level " + std::to_string(k) + ")"; };
      switch (elementState(w)) {
      case ElementState::Full:
        if (surfaceOnly) invalid(where() + ": Full element in a surface-only volume");
        counts.fullVoxels += edge * edge * edge;
        [[fallthrough]];
      case ElementState::Empty:
        if (payload != 0) invalid(where() + ": uniform element with nonzero payload " + str(payload));
        break;
      case ElementState::Branch:
        if (leafLevel) invalid(where() + ": Branch at the leaf level");
        if (payload != nextChild) {
          invalid(where() + ": Branch points to " + str(payload) + ", its children are at " + str(nextChild));
        }
        nextChild += 8;
        break;
      case ElementState::Boundary:
        if (!leafLevel) invalid(where() + ": Boundary element above the leaf level " + std::to_string(h));
        if (payload != counts.leaves) {
          invalid(where() + ": Boundary points to leaf " + str(payload) + ", expected " + str(counts.leaves));
        }
        ++counts.leaves;
        break;
      }
    }
    if (!leafLevel && nextChild != ls[k + 2]) {
      invalid("level " + std::to_string(k) + " has " + str((nextChild - ls[k + 1]) / 8) +
              " Branch elements but level " + std::to_string(k + 1) + " has " + str(ls[k + 2] - ls[k + 1]) +
              " elements");
    }
  }
  return counts;
}

// Rule 19, and the voxel counts the statistics must match.
LeafCounts checkLeaves(const LeafWordVector& words, int leafSize, bool surfaceOnly) {
  const LeafCounts c = tbb::parallel_reduce(
      tbb::blocked_range<size_t>(0, words.size(), 1 << 16), LeafCounts{},
      [&](const tbb::blocked_range<size_t>& r, LeafCounts c) {
        return c += countLeafWords(words.data() + r.begin(), r.size());
      },
      [](LeafCounts a, const LeafCounts& b) { return a += b; });
  checkLeafCounts(c, words, leafSize, surfaceOnly);
  return c;
}

// Rule 19 from the counts of all the leaf words (checkLeaves, or the writer's
// zstd blocks): the first invalid field is looked for only when there is one.
void checkLeafCounts(const LeafCounts& c, const LeafWordVector& words, int leafSize, bool surfaceOnly) {
  if (c.invalidWords != 0) {
    const auto bad = std::find_if(words.begin(), words.end(),
                                  [](uint32_t w) { return invalidFields(w) != 0; });
    const uint64_t word = uint64_t(bad - words.begin()), perLeaf = leafWordCount(leafSize);
    invalid("leaf data: leaf " + str(word / perLeaf) + " has a voxel in the invalid state 3 (word " +
            str(word % perLeaf) + ")");
  }
  // Inside and Surface are exclusive states, so the popcounts above count voxels.
  if (surfaceOnly && c.inside != 0)
    invalid("leaf data: " + str(c.inside) + " Inside voxels in a surface-only volume");
}

// Rule 12: the statistics that are functions of the contents must agree with them.
void checkStructure(const Statistics& s, const Volume& v, const TreeCounts& tree, const LeafCounts& leaves) {
  const uint64_t L = uint64_t(v.grid.leafSize);
  const struct {
    const char* name;
    uint64_t stored, actual;
  } fields[] = {
      {"tree elements", s.treeElements, v.elements.size()},
      {"leaf grids", s.leafGrids, tree.leaves},
      {"leaf voxels", s.leafVoxels, tree.leaves * L * L * L},
      {"active voxels", s.activeVoxels, leaves.surface},
      {"inside voxels", s.insideVoxels, leaves.inside + tree.fullVoxels},
      {"topology bytes", s.topologyBytes, uint64_t(v.elements.size()) * 4},
      {"leaf bytes", s.leafBytes, uint64_t(v.leafWords.size()) * 4},
  };
  for (const auto& f : fields) {
    if (f.stored != f.actual) {
      invalid(std::string("statistics: ") + f.name + " is " + str(f.stored) + " but the volume has " +
              str(f.actual));
    }
  }
}

// ---- part labels (docs/hdt-format.md, "Part labels") ------------------------------

// Element labels: 0 on Empty and Branch, >= 1 on Full, any on Boundary (0:
// a mixed leaf). Returns the leaf indices of the mixed leaves, in order.
std::vector<uint64_t> checkLabelElements(const std::vector<Label>& labels, const std::vector<ElementWord>& elements) {
  if (labels.size() != elements.size())
    invalid("label elements: " + str(labels.size()) + " labels for " + str(elements.size()) + " elements");
  std::vector<uint64_t> mixed;
  for (size_t i = 0; i < elements.size(); ++i) {
    const ElementState s = elementState(elements[i]);
    if ((s == ElementState::Empty || s == ElementState::Branch) && labels[i] != kOutsideLabel)
      invalid("label elements: element " + str(i) + " is Empty or Branch but has label " + str(labels[i]));
    if (s == ElementState::Full && labels[i] == kOutsideLabel)
      invalid("label elements: Full element " + str(i) + " has label 0");
    if (s == ElementState::Boundary && labels[i] == kOutsideLabel) mixed.push_back(elementPayload(elements[i]));
  }
  return mixed;
}

namespace {

// Labels of a leaf, one a voxel: 0 exactly on Outside voxels, at least
// `minDistinct` (<= kPaletteSize + 1) different labels.
bool voxelLabelsFitLeaf(const uint32_t* words, const Label* labels, int leafSize, uint32_t minDistinct) {
  const uint32_t voxels = uint32_t(leafSize) * leafSize * leafSize;
  for (uint32_t j = 0; j < voxels; ++j) {
    const bool outside = ((words[j / kVoxelsPerWord] >> (2 * (j % kVoxelsPerWord))) & 3u) == 0;
    if (outside != (labels[j] == kOutsideLabel)) return false;
  }
  uint32_t distinct = 0;
  paletteOfLeaf(labels, voxels, distinct);
  return distinct >= minDistinct;
}

// A palette leaf: the palette ascending from 1, two labels at least, unused
// entries 0; index 0 on Outside voxels; every other voxel's index names a
// used entry, and every used entry has a voxel.
bool paletteLeafIsValid(const uint32_t* words, const LeafPalette& palette, const uint32_t* indices, int leafSize) {
  uint32_t used = 0;
  while (used < uint32_t(kPaletteSize) && palette.labels[used] != kOutsideLabel) ++used;
  if (used < 2) return false;
  for (uint32_t s = 1; s < uint32_t(kPaletteSize); ++s) {
    if (s < used && palette.labels[s] <= palette.labels[s - 1]) return false;
    if (s >= used && palette.labels[s] != kOutsideLabel) return false;
  }
  uint32_t seen = 0; // bit s: slot s has a voxel
  for (uint32_t j = 0; j < leafWordCount(leafSize); ++j) {
    const uint32_t occupied = planeOf(words[j], kInsidePlane) | planeOf(words[j], kSurfacePlane);
    if (indices[j] & ~(occupied | (occupied << 1))) return false; // an Outside voxel with index != 0
    for (uint32_t s = 0; s < uint32_t(kPaletteSize); ++s) {
      const uint32_t mine = paletteSlotVoxels(indices[j], s) & occupied;
      if (mine && s >= used) return false;
      seen |= mine ? 1u << s : 0u;
    }
  }
  return seen == (1u << used) - 1;
}

bool mixedLeafIsValid(const Volume& v, uint32_t leaf, size_t k) {
  const LabelField& f = v.labels;
  const size_t block = f.mixedBlock[k];
  if (f.palettes[k].isWide())
    return voxelLabelsFitLeaf(v.leaf(leaf), f.wideLabels.data() + block * v.grid.leafVoxels(), v.grid.leafSize,
                              kPaletteSize + 1);
  return paletteLeafIsValid(v.leaf(leaf), f.palettes[k], f.paletteIndices.data() + block * leafWordCount(v.grid.leafSize),
                            v.grid.leafSize);
}

} // namespace

// The mixed leaves' storage (label_field.hpp): one palette each, then the
// blocks their palettes imply, each canonical for its leaf.
void checkLabelVoxels(const Volume& v, const std::vector<uint64_t>& mixed) {
  const LabelField& f = v.labels;
  if (f.palettes.size() != mixed.size())
    invalid("label voxels: " + str(f.palettes.size()) + " palettes for " + str(mixed.size()) + " mixed leaves");
  uint64_t wide = 0;
  for (const LeafPalette& p : f.palettes) wide += p.isWide();
  if (f.paletteIndices.size() != (mixed.size() - wide) * leafWordCount(v.grid.leafSize) ||
      f.wideLabels.size() != wide * v.grid.leafVoxels())
    invalid("label voxels: " + str(f.paletteIndices.size()) + " palette index words and " + str(f.wideLabels.size()) +
            " wide labels for " + str(mixed.size() - wide) + " palette leaves and " + str(wide) + " wide leaves");
  if (f.mixedBlock.size() != mixed.size()) invalid("label voxels: the mixed leaves are not indexed");
  const size_t firstBad = tbb::parallel_reduce(
      tbb::blocked_range<size_t>(0, mixed.size(), 64), mixed.size(),
      [&](const tbb::blocked_range<size_t>& r, size_t bad) {
        for (size_t k = r.begin(); k != r.end() && k < bad; ++k)
          if (!mixedLeafIsValid(v, uint32_t(mixed[k]), k)) return k;
        return bad;
      },
      [](size_t a, size_t b) { return std::min(a, b); });
  if (firstBad != mixed.size()) {
    invalid("label voxels: mixed leaf " + str(mixed[firstBad]) +
            (f.palettes[firstBad].isWide()
                 ? " (wide) has a label 0 on a voxel that is not Outside (or a label on an Outside voxel), or 4 labels or fewer"
                 : " has a palette that is not ascending from 1 with 2 to 4 labels, or indices that do not match its voxels"));
  }
}

// Section 17 (read only): L^3 labels per mixed leaf, each 0 exactly on
// Outside voxels with two labels or more.
void checkSixteenBitVoxelLabels(const Volume& v, const std::vector<uint64_t>& mixed, const std::vector<Label>& labels) {
  const size_t voxels = v.grid.leafVoxels();
  const size_t firstBad = tbb::parallel_reduce(
      tbb::blocked_range<size_t>(0, mixed.size(), 64), mixed.size(),
      [&](const tbb::blocked_range<size_t>& r, size_t bad) {
        for (size_t b = r.begin(); b != r.end() && b < bad; ++b)
          if (!voxelLabelsFitLeaf(v.leaf(mixed[b]), labels.data() + b * voxels, v.grid.leafSize, 2)) return b;
        return bad;
      },
      [](size_t a, size_t b) { return std::min(a, b); });
  if (firstBad != mixed.size()) {
    invalid("label voxels: mixed leaf " + str(mixed[firstBad]) +
            " has a label 0 on a voxel that is not Outside (or a label on an Outside voxel), or only one label");
  }
}

void checkLabelNames(const std::map<Label, std::string>& names) {
  for (const auto& [label, name] : names) {
    if (label == kOutsideLabel) invalid("label names: a name for label 0");
    if (name.size() > kMaxLabelNameLength)
      invalid("label names: the name of label " + str(label) + " is longer than 255 bytes");
    for (char c : name)
      if (uint8_t(c) < 0x20 || c == 0x7F) invalid("label names: the name of label " + str(label) + " has a control character");
  }
}

namespace {

void checkLabels(const Volume& v) {
  if (v.labels.empty()) {
    if (!v.labels.palettes.empty() || !v.labels.names.empty())
      invalid("voxel labels or label names in a volume without element labels");
    return;
  }
  checkLabelVoxels(v, checkLabelElements(v.labels.elementLabels, v.elements));
  checkLabelNames(v.labels.names);
}

} // namespace

// The checks before the leaf words' contents: grid, statistics fields, level
// table, elements, the number of leaf words.
TreeCounts checkVolumeTree(const Volume& v) {
  const GridSpec& g = v.grid;
  checkGrid(g.resolution, g.rootGrid, g.leafSize, g.height, g.origin, g.voxelSize);
  checkInsideTest(uint32_t(v.insideTest));
  checkStatisticsFields(v.stats);
  checkLevelTable(v.levelStart, g);
  if (v.elements.size() != v.levelStart.back()) {
    invalid(str(v.elements.size()) + " elements but the level table ends at " + str(v.levelStart.back()));
  }
  const TreeCounts tree = checkElements(v.elements, v.levelStart, g, v.surfaceOnly);
  if (v.leafWords.size() != tree.leaves * leafWordCount(g.leafSize)) {
    invalid(str(v.leafWords.size()) + " leaf words for " + str(tree.leaves) + " Boundary elements");
  }
  return tree;
}

// The checks after the leaf words' contents (`leaves`, already checked).
void checkVolumeRest(const Volume& v, const TreeCounts& tree, const LeafCounts& leaves, StatisticsOf statistics) {
  if (statistics == StatisticsOf::Contents) checkStructure(v.stats, v, tree, leaves);
  checkLabels(v);
  try {
    validateVoxelArrays(v);
  } catch (const Error& e) {
    invalid(e.what());
  }
}

namespace {

// Everything at once.
void checkVolume(const Volume& v, StatisticsOf statistics = StatisticsOf::Contents) {
  const TreeCounts tree = checkVolumeTree(v);
  checkVolumeRest(v, tree, checkLeaves(v.leafWords, v.grid.leafSize, v.surfaceOnly), statistics);
}

} // namespace
} // namespace hdt_file_detail

void validateVolume(const Volume& v, StatisticsOf statistics) {
  try {
    hdt_file_detail::checkVolume(v, statistics);
  } catch (const hdt_file_detail::Invalid& e) {
    throw Error(ErrorKind::BadInput, std::string("inconsistent HDT volume: ") + e.what());
  }
}

} // namespace hdt
