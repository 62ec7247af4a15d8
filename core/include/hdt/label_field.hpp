// Part labels of a built volume (issue 17): one label per element, and
// per-voxel labels only in leaf grids that hold more than one.
//
// Label 0 means "outside"; parts are 1..65535. A voxel's label is 0 exactly
// when its state is Outside. The layout follows the tree's:
//   * Empty and Branch elements: 0;
//   * Full elements: the label of their inside voxels (>= 1);
//   * Boundary elements: the one label of every non-Outside voxel of the
//     leaf (>= 1), or 0 when the leaf is "mixed" (two or more labels).
// A mixed leaf (k-th in leaf order) has palettes[k]:
//   * a palette leaf (2 to 4 labels): palettes[k] holds its labels ascending,
//     unused entries 0, and the leaf has L^3 / 16 words of 2-bit palette
//     indices in paletteIndices, packed as the leaf words (voxel
//     v = x + L (y + L z) in word v / 16 at bits 2 (v % 16)). Outside voxels
//     need no entry (the leaf words say which they are) and hold index 0;
//   * a wide leaf (5 labels or more): palettes[k] is all 0 and the leaf has
//     L^3 labels in wideLabels, voxel v at v.
// Palette leaves and wide leaves each keep leaf order in their own array.
// This form is canonical (one per volume), so bytes can be compared; it is
// 2 bits a voxel for the common mixed leaf, the size of its leaf words.
// An unlabelled volume has an empty LabelField.
#pragma once

#include "hdt/default_init_allocator.hpp"
#include "hdt/platform.hpp"
#include "hdt/types.hpp"

#include <cstdint>
#include <map>
#include <string>
#include <vector>

namespace hdt {

using Label = uint16_t;
constexpr Label kOutsideLabel = 0;
constexpr uint32_t kNotMixed = 0xFFFFFFFFu; // LabelField::mixedIndex of a leaf with one label
constexpr int kPaletteSize = 4;             // labels a palette leaf holds at most
constexpr int kPaletteIndexBits = 2;

struct LeafPalette {
  Label labels[kPaletteSize];
  bool isWide() const { return labels[0] == kOutsideLabel; }
};
static_assert(sizeof(LeafPalette) == 8, "a palette is four u16, as in the file");
inline bool operator==(const LeafPalette& a, const LeafPalette& b) {
  for (int i = 0; i < kPaletteSize; ++i)
    if (a.labels[i] != b.labels[i]) return false;
  return true;
}
inline bool operator!=(const LeafPalette& a, const LeafPalette& b) { return !(a == b); }

// The 2-bit palette index of voxel `voxel` of a palette leaf.
HDT_HD uint32_t paletteIndexOf(const uint32_t* indexWords, uint32_t voxel) {
  return (indexWords[voxel / kVoxelsPerWord] >> (kPaletteIndexBits * (voxel % kVoxelsPerWord))) & 3u;
}

// The index-word bits of `label` in `palette` (its slot, 0 to 3), or
// kPaletteSize when the palette lacks it. Outside voxels use slot 0.
HDT_HD uint32_t paletteSlotOf(const Label* palette, Label label) {
  if (label == kOutsideLabel) return 0;
  for (uint32_t s = 0; s < uint32_t(kPaletteSize); ++s)
    if (palette[s] == label) return s;
  return uint32_t(kPaletteSize);
}

// Of one word of palette indices, the voxels whose index is `slot`, as the
// low bit of each voxel's pair (the layout of planeOf).
HDT_HD uint32_t paletteSlotVoxels(uint32_t indexWord, uint32_t slot) {
  const uint32_t differ = indexWord ^ (slot * kInsidePlaneBits);
  return ~(differ | (differ >> 1)) & kInsidePlaneBits;
}

struct LabelField {
  std::vector<Label> elementLabels; // one per element (empty: unlabelled volume)
  std::vector<LeafPalette> palettes; // one per mixed leaf, in leaf order
  // resize() leaves these unwritten (the CUDA driver copies gigabytes into
  // them: a zero fill first would cost more).
  std::vector<uint32_t, DefaultInitAllocator<uint32_t>> paletteIndices; // L^3 / 16 per palette leaf
  std::vector<Label, DefaultInitAllocator<Label>> wideLabels;           // L^3 per wide leaf
  std::map<Label, std::string> names;                                   // optional names of labels (>= 1)
  // Derived (indexMixedLeaves): per leaf, its place k among the mixed
  // leaves or kNotMixed; per mixed leaf, its block in paletteIndices or in
  // wideLabels (as palettes[k] says). Filled in parallel (resize() leaves them unwritten).
  std::vector<uint32_t, DefaultInitAllocator<uint32_t>> mixedIndex;
  std::vector<uint32_t, DefaultInitAllocator<uint32_t>> mixedBlock;

  bool empty() const { return elementLabels.empty(); }
};

// The labels of one leaf grid's voxels, whatever their storage. Made by
// leafLabels (hdt/labels.hpp).
class LeafLabels {
public:
  LeafLabels(const uint32_t* words, Label single, const Label* palette, const uint32_t* indices, const Label* wide)
      : words_(words), single_(single), palette_(palette), indices_(indices), wide_(wide) {}
  bool mixed() const { return single_ == kOutsideLabel; }
  Label single() const { return single_; } // 0 when mixed
  const Label* palette() const { return palette_; } // a palette leaf's, else nullptr
  const uint32_t* paletteIndices() const { return indices_; }
  Label operator[](uint32_t voxel) const {
    if (wide_) return wide_[voxel];
    const bool outside = ((words_[voxel / kVoxelsPerWord] >> (2 * (voxel % kVoxelsPerWord))) & 3u) == 0;
    if (outside) return kOutsideLabel;
    return palette_ ? palette_[paletteIndexOf(indices_, voxel)] : single_;
  }

private:
  const uint32_t* words_;
  Label single_;
  const Label* palette_;
  const uint32_t* indices_;
  const Label* wide_;
};

} // namespace hdt
