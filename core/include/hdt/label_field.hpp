// Part labels of a built volume (issue 17): one label per element, and a
// per-voxel label only in leaf grids that hold more than one.
//
// Label 0 means "outside"; parts are 1..65535. A voxel's label is 0 exactly
// when its state is Outside. The layout follows the tree's:
//   * Empty and Branch elements: 0;
//   * Full elements: the label of their inside voxels (>= 1);
//   * Boundary elements: the one label of every non-Outside voxel of the
//     leaf (>= 1), or 0 when the leaf is "mixed" (two or more labels); the
//     k-th mixed leaf (in leaf order) has L^3 voxel labels at
//     voxelLabels[k * L^3], voxel v = x + L (y + L z) as in the leaf words.
// An unlabelled volume has an empty LabelField.
#pragma once

#include "hdt/default_init_allocator.hpp"

#include <cstdint>
#include <map>
#include <string>
#include <vector>

namespace hdt {

using Label = uint16_t;
constexpr Label kOutsideLabel = 0;
constexpr uint32_t kNotMixed = 0xFFFFFFFFu; // LabelField::mixedBlock of a leaf with one label

struct LabelField {
  std::vector<Label> elementLabels; // one per element (empty: unlabelled volume)
  // L^3 per mixed leaf, in leaf order; resize() leaves them unwritten (the
  // CUDA driver copies gigabytes into them: a zero fill first would cost more).
  std::vector<Label, DefaultInitAllocator<Label>> voxelLabels;
  std::map<Label, std::string> names; // optional names of labels (>= 1)
  // Derived (indexMixedLeaves): per leaf, the index of its block in
  // voxelLabels, or kNotMixed.
  std::vector<uint32_t> mixedBlock;

  bool empty() const { return elementLabels.empty(); }
};

} // namespace hdt
