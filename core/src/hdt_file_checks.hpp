// The .hdt format's rules (docs/hdt-format.md, "Validation") checked on a
// volume: the reader runs them on what it has read, section by section, the
// writer on the volume it is given (it must never write a file the reader
// refuses). A broken rule throws Invalid (hdt_file_format.hpp). Private to hdt_core.
#pragma once

#include "hdt/volume.hpp"
#include "hdt_leaf_encoder.hpp"

#include <array>
#include <cstdint>
#include <map>
#include <string>
#include <vector>

namespace hdt::hdt_file_detail {

// Rules 8-9.
void checkGrid(int64_t N, int64_t R, int64_t L, int64_t h, const std::array<double, 3>& origin,
               double voxelSize);
// Rule 10's inside test (version 2's grid field).
void checkInsideTest(uint32_t test);
// Rule 11: the statistics fields that are not derived from the contents.
void checkStatisticsFields(const Statistics& s);
// Rule 13.
void checkLevelTable(const std::vector<uint64_t>& ls, const GridSpec& g);

struct TreeCounts {
  uint64_t leaves = 0;     // Boundary elements
  uint64_t fullVoxels = 0; // voxels covered by Full elements
};
// Rules 14-17.
TreeCounts checkElements(const std::vector<ElementWord>& elements, const std::vector<uint64_t>& ls,
                         const GridSpec& g, bool surfaceOnly);

// Rule 19, and the voxel counts the statistics must match.
LeafCounts checkLeaves(const LeafWordVector& words, int leafSize, bool surfaceOnly);
// Rule 19 from counts already taken over all the leaf words.
void checkLeafCounts(const LeafCounts& c, const LeafWordVector& words, int leafSize, bool surfaceOnly);
// Rule 12.
void checkStructure(const Statistics& s, const Volume& v, const TreeCounts& tree, const LeafCounts& leaves);

// Part labels: the element labels (returns the leaf indices of the mixed
// leaves, in order), the mixed leaves' storage, section 17's 16-bit labels,
// the names.
std::vector<uint64_t> checkLabelElements(const std::vector<Label>& labels, const std::vector<ElementWord>& elements);
void checkLabelVoxels(const Volume& v, const std::vector<uint64_t>& mixed);
void checkSixteenBitVoxelLabels(const Volume& v, const std::vector<uint64_t>& mixed, const std::vector<Label>& labels);
void checkLabelNames(const std::map<Label, std::string>& names);

// A whole volume, for the writer, in two parts that frame the leaf words'
// contents: before them (grid, statistics fields, level table, elements, the
// number of leaf words), and after them (statistics, labels, arrays).
TreeCounts checkVolumeTree(const Volume& v);
void checkVolumeRest(const Volume& v, const TreeCounts& tree, const LeafCounts& leaves, StatisticsOf statistics);

} // namespace hdt::hdt_file_detail
