// The compact storage of mixed leaves' labels (hdt/label_field.hpp): leaves
// of 1, 2, 4, 5 and many labels against the labels they were given, voxel by
// voxel, through the accessors, the statistics and an .hdt round trip.
#include "hdt/hdt_file.hpp"
#include "hdt/labels.hpp"
#include "hdt/volume.hpp"
#include "support/format_volumes.hpp"

#include <gtest/gtest.h>

#include <algorithm>
#include <set>

namespace hdt {
namespace test {
namespace {

constexpr int kL = 8;

bool occupied(uint32_t voxel) { return voxel % 3 != 0; } // every third voxel Outside

// One leaf grid (R = 1, L = 8, h = 0): Outside where !occupied, else Surface
// on odd voxels and Inside on even ones.
Volume oneLeafVolume() {
  Volume v = emptyVolume(1, kL, 0);
  v.elements[0] = makeElement(ElementState::Boundary, 0);
  v.leafWords.assign(leafWordCount(kL), 0);
  for (uint32_t j = 0; j < uint32_t(kL * kL * kL); ++j)
    if (occupied(j)) v.leafWords[j / 16] |= (j % 2 ? 2u : 1u) << (2 * (j % 16));
  computeStructureStatistics(v);
  return v;
}

// Labels out of order, so that the palette must sort them.
const Label kLabels[] = {300, 7, 65535, 12, 9000, 1, 44, 2, 100, 5000};

// Voxel j's label among the first `count` of kLabels: each appears.
std::vector<Label> chosenLabels(int count) {
  std::vector<Label> voxels(size_t(kL * kL * kL), kOutsideLabel);
  for (uint32_t j = 0; j < voxels.size(); ++j)
    if (occupied(j)) voxels[j] = kLabels[(j / 3) % uint32_t(count)];
  return voxels;
}

Volume labelledLeaf(int count) {
  Volume v = oneLeafVolume();
  const std::vector<Label> voxels = chosenLabels(count);
  v.labels.elementLabels = {count == 1 ? kLabels[0] : kOutsideLabel};
  packVoxelLabels(v, voxels.data());
  return v;
}

void expectLabels(const Volume& v, const std::vector<Label>& voxels, const std::string& context) {
  for (int z = 0; z < kL; ++z)
    for (int y = 0; y < kL; ++y)
      for (int x = 0; x < kL; ++x)
        ASSERT_EQ(labelAt(v, x, y, z), voxels[size_t(x + kL * (y + kL * z))]) << context << " voxel " << x << " " << y << " " << z;
  std::map<Label, uint64_t> surface, inside; // brute force
  for (uint32_t j = 0; j < voxels.size(); ++j)
    if (occupied(j)) ++(j % 2 ? surface : inside)[voxels[j]];
  const std::vector<LabelStatistics> table = labelStatistics(v);
  ASSERT_EQ(table.size(), std::max(surface.size(), inside.size())) << context;
  for (const LabelStatistics& row : table) {
    EXPECT_EQ(row.surfaceVoxels, surface[row.label]) << context << " label " << row.label;
    EXPECT_EQ(row.insideVoxels, inside[row.label]) << context << " label " << row.label;
  }
}

TEST(LabelPalette, LeavesOfOneTwoFourFiveAndManyLabels) {
  for (int count : {1, 2, 3, 4, 5, 10}) {
    const std::string context = std::to_string(count) + " labels";
    const Volume v = labelledLeaf(count);
    const std::vector<Label> voxels = chosenLabels(count);
    EXPECT_NO_THROW(validateVolume(v)) << context;
    const LabelField& f = v.labels;
    if (count == 1) {
      EXPECT_TRUE(f.palettes.empty() && f.paletteIndices.empty() && f.wideLabels.empty()) << context;
    } else if (count <= kPaletteSize) {
      ASSERT_EQ(f.palettes.size(), 1u) << context;
      std::vector<Label> sorted(kLabels, kLabels + count);
      std::sort(sorted.begin(), sorted.end());
      sorted.resize(kPaletteSize, kOutsideLabel);
      EXPECT_TRUE(std::equal(sorted.begin(), sorted.end(), f.palettes[0].labels)) << context;
      EXPECT_EQ(f.paletteIndices.size(), size_t(leafWordCount(kL))) << context << ": 2 bits a voxel";
      EXPECT_TRUE(f.wideLabels.empty()) << context;
      EXPECT_TRUE(unpackVoxelLabels(v) == voxels) << context;
    } else {
      ASSERT_EQ(f.palettes.size(), 1u) << context;
      EXPECT_TRUE(f.palettes[0].isWide()) << context;
      EXPECT_TRUE(f.paletteIndices.empty()) << context;
      EXPECT_TRUE(std::vector<Label>(f.wideLabels.begin(), f.wideLabels.end()) == voxels) << context;
    }
    expectLabels(v, voxels, context);
    for (bool compress : {false, true}) {
      HdtWriteOptions o;
      o.compressLeaves = compress;
      const std::vector<uint8_t> bytes = serializeHdt(v, o);
      const Volume back = deserializeHdt(bytes.data(), bytes.size());
      expectSameVolume(v, back, context + (compress ? ", zstd" : ", raw"));
      expectLabels(back, voxels, context + " read back");
    }
  }
}

// The packing of the spec (docs/hdt-format.md, section 21), worked by hand:
// labels 300 and 7 -> palette {7, 300}; voxel j (Outside when j % 3 == 0)
// has 300 (slot 1) where j / 3 is even, so word 0 has slot 1 at voxels
// 1, 2, 7, 8, 13 and 14 (bits 2j) and slot 0 elsewhere.
TEST(LabelPalette, IndexPackingFollowsTheSpec) {
  const Volume v = labelledLeaf(2);
  ASSERT_EQ(v.labels.palettes.size(), 1u);
  EXPECT_EQ(v.labels.palettes[0].labels[0], 7);
  EXPECT_EQ(v.labels.palettes[0].labels[1], 300);
  EXPECT_EQ(v.labels.paletteIndices[0],
            (1u << 2) | (1u << 4) | (1u << 14) | (1u << 16) | (1u << 26) | (1u << 28));
  EXPECT_EQ(paletteIndexOf(v.labels.paletteIndices.data(), 13), 1u);
  EXPECT_EQ(paletteIndexOf(v.labels.paletteIndices.data(), 10), 0u);
  EXPECT_EQ(paletteSlotVoxels(0xE4u, 2), 1u << 4); // indices 0, 1, 2, 3 in voxels 0 to 3
}

TEST(LabelPalette, CompactFieldIsAnEighthOfSixteenBits) {
  const Volume v = labelledLeaf(2);
  const uint64_t voxels = uint64_t(kL) * kL * kL;
  EXPECT_EQ(v.labels.paletteIndices.size() * 4 + v.labels.palettes.size() * 8, voxels * 2 / 8 + 8);
}

} // namespace
} // namespace test
} // namespace hdt
