// Coarsened states over a box (hdt/region.hpp, the "HDT To Image" filter's
// core) against a brute-force reference: every block's voxels counted one by
// one from the dense export, then the documented rule (surface if any voxel is
// surface, else inside if more than half are inside, else outside).
#include "hdt/dense.hpp"
#include "hdt/error.hpp"
#include "hdt/region.hpp"
#include "support/format_volumes.hpp"

#include <gtest/gtest.h>

#include <string>

namespace hdt {
namespace test {
namespace {

std::vector<uint8_t> bruteForce(const Volume& v, const VoxelBox& box, int level) {
  const std::vector<uint8_t> dense = denseStates(v);
  const int64_t N = v.grid.resolution, f = int64_t(1) << level;
  int64_t n[3];
  for (int a = 0; a < 3; ++a) n[a] = (box.size(a) + f - 1) / f;
  std::vector<uint8_t> out;
  for (int64_t k = 0; k < n[2]; ++k)
    for (int64_t j = 0; j < n[1]; ++j)
      for (int64_t i = 0; i < n[0]; ++i) {
        uint64_t voxels = 0, surface = 0, inside = 0;
        for (int64_t z = box.lo[2] + k * f; z < std::min(box.lo[2] + (k + 1) * f, box.hi[2]); ++z)
          for (int64_t y = box.lo[1] + j * f; y < std::min(box.lo[1] + (j + 1) * f, box.hi[1]); ++y)
            for (int64_t x = box.lo[0] + i * f; x < std::min(box.lo[0] + (i + 1) * f, box.hi[0]); ++x) {
              const uint8_t s = dense[size_t(x + N * (y + N * z))];
              ++voxels;
              surface += s == 2;
              inside += s == 1;
            }
        out.push_back(surface ? 2 : (2 * inside > voxels ? 1 : 0));
      }
  return out;
}

TEST(Region, WholeGridLevelZeroIsTheDenseExport) {
  RandomVolumeSpec spec;
  spec.rootGrid = 3;
  spec.leafSize = 8;
  spec.height = 1;
  spec.branchChance = 0.5;
  const Volume v = randomVolume(7, spec);
  VoxelBox all;
  for (int a = 0; a < 3; ++a) all.hi[a] = v.grid.resolution;
  EXPECT_EQ(coarseStates(v, all, 0), denseStates(v));
}

TEST(Region, CoarseBlocksAndBoxesMatchBruteForce) {
  struct Case {
    int R, L, h;
    bool surfaceOnly;
  };
  for (const Case c : {Case{1, 8, 2, false}, Case{3, 8, 1, false}, Case{2, 16, 1, true}, Case{1, 32, 0, false}}) {
    RandomVolumeSpec spec;
    spec.rootGrid = c.R;
    spec.leafSize = c.L;
    spec.height = c.h;
    spec.surfaceOnly = c.surfaceOnly;
    spec.branchChance = 0.5;
    const Volume v = randomVolume(3, spec);
    const int N = v.grid.resolution;
    int maxLevel = 0;
    while ((1 << maxLevel) < N) ++maxLevel;
    for (int level = 0; level <= maxLevel; ++level) {
      VoxelBox wanted;
      wanted.lo[0] = 3; wanted.lo[1] = N / 4; wanted.lo[2] = 0;
      wanted.hi[0] = N - 5; wanted.hi[1] = N; wanted.hi[2] = N / 2 + 1;
      for (const VoxelBox& raw : {wanted, VoxelBox{{0, 0, 0}, {N, N, N}}}) {
        const VoxelBox box = alignToBlocks(v, raw, level);
        SCOPED_TRACE("R " + std::to_string(c.R) + " L " + std::to_string(c.L) + " level " + std::to_string(level));
        for (int a = 0; a < 3; ++a) {
          EXPECT_LE(box.lo[a], std::max<int64_t>(raw.lo[a], 0));
          EXPECT_GE(box.hi[a], std::min<int64_t>(raw.hi[a], N));
          EXPECT_EQ(box.lo[a] % (int64_t(1) << level), 0);
        }
        EXPECT_EQ(coarseStates(v, box, level), bruteForce(v, box, level));
      }
    }
  }
}

TEST(Region, RefusesBadLevelsAndBoxes) {
  const Volume v = emptyVolume(2, 8, 1); // N = 32
  VoxelBox box{{0, 0, 0}, {32, 32, 32}};
  EXPECT_THROW(coarseStates(v, box, -1), Error);
  EXPECT_THROW(coarseStates(v, box, 6), Error);
  box.lo[0] = 1;
  EXPECT_THROW(coarseStates(v, box, 1), Error); // not aligned
  box.lo[0] = 0;
  box.hi[2] = 33;
  EXPECT_THROW(coarseStates(v, box, 0), Error); // outside the grid
}

} // namespace
} // namespace test
} // namespace hdt
