// Root-range builds (root_ranges.hpp): the CPU driver over K ranges of root
// cells, joined, must give the one-piece build's bytes, whatever the split:
// uneven ranges, ranges without triangles, empty ranges, more ranges than
// rows of root cells. Closed and open shapes (1- and 3-axis classification),
// solid and surface-only.
#include "hdt/builder.hpp"
#include "hdt/error.hpp"
#include "hdt/mesh.hpp"
#include "hdt/root_ranges.hpp"
#include "hdt/volume.hpp"
#include "support/range_splits.hpp"
#include "support/shapes.hpp"

#include <gtest/gtest.h>

#include <memory>
#include <string>

namespace hdt {
namespace test {
namespace {

class RangeBuild : public ::testing::TestWithParam<ShapeCase> {};

TEST_P(RangeBuild, JoinedRangesEqualTheOnePieceBuild) {
  const ShapeCase& c = GetParam();
  const PreparedMesh mesh = prepareShapeCase(c);
  BuildOptions options;
  options.backend = Backend::Cpu;
  const Volume whole = buildCpu(mesh, options);
  ASSERT_GT(whole.stats.activeVoxels, 0u);
  if (!c.surfaceOnly) {
    ASSERT_GT(whole.stats.insideVoxels, 0u) << "the shape must have an inside for the parities to matter";
  }

  const uint64_t R = uint64_t(c.r), cells = R * R * R;
  for (const std::vector<RootRange>& ranges : rangeSplitsOf(mesh)) {
    ASSERT_EQ(ranges.front().first, 0u);
    ASSERT_EQ(ranges.back().end, cells);
    for (size_t i = 1; i < ranges.size(); ++i) ASSERT_EQ(ranges[i].first, ranges[i - 1].end);
    const Volume joined = buildCpuRanges(mesh, options, ranges);
    EXPECT_EQ(firstDifference(whole, joined), "") << c.shape << " as " << describeRanges(ranges);
  }
}

INSTANTIATE_TEST_SUITE_P(Cpu, RangeBuild,
                         ::testing::Values(ShapeCase{"sphere", 128, 4, 8, false},
                                           ShapeCase{"hollow_sphere", 128, 2, 16, false},
                                           ShapeCase{"open_hemisphere", 128, 4, 8, false}, // 3-axis vote
                                           ShapeCase{"two_bodies", 128, 4, 8, false},
                                           ShapeCase{"torus", 128, 4, 8, true}),
                         [](const ::testing::TestParamInfo<ShapeCase>& info) { return shapeCaseName(info.param); });

// The plan: contiguous, covering, aligned, balanced within one cell's load.
TEST(RootRangePlan, BalancedAlignedAndCovering) {
  std::vector<CellLoad> loads;
  for (uint64_t c = 0; c < 64; c += 3) loads.push_back(CellLoad{c, 10 + c, 0.0});
  uint64_t total = 0;
  for (const CellLoad& l : loads) total += l.pairs;
  for (uint64_t align : {1u, 4u}) {
    const std::vector<RootRange> ranges = planRootRanges(loads, 64, 4, align);
    ASSERT_EQ(ranges.size(), 4u);
    EXPECT_EQ(ranges.front().first, 0u);
    EXPECT_EQ(ranges.back().end, 64u);
    for (size_t i = 0; i < ranges.size(); ++i) {
      if (i) EXPECT_EQ(ranges[i].first, ranges[i - 1].end);
      EXPECT_EQ(ranges[i].first % align, 0u);
      uint64_t pairs = 0;
      for (const CellLoad& l : loads)
        if (l.cell >= ranges[i].first && l.cell < ranges[i].end) pairs += l.pairs;
      EXPECT_LE(pairs, total / 4 + 4 * 73) << "range " << i; // a quarter, plus at most one unit of cells
    }
  }
  const auto halves = splitRootRange(RootRange{3, 10});
  EXPECT_EQ(halves.first, (RootRange{3, 6}));
  EXPECT_EQ(halves.second, (RootRange{6, 10}));
}

// makeRangeBuild picks a driver per range: Cpu always the CPU, Auto the CPU
// where no CUDA device is usable (saying so), Cuda refused there. What runs
// where a device is usable is tested in tests/cuda (test_cuda_ranges.cpp).
TEST(RangeBuildBackend, AutoWithoutADeviceBuildsOnTheCpuAndSaysSo) {
  if (cudaAvailable()) GTEST_SKIP() << "a CUDA device is usable here";
  const PreparedMesh mesh = prepareShapeCase(ShapeCase{"sphere", 128, 4, 8, false});
  const uint64_t R = 4, cells = R * R * R;
  const std::vector<RootRange> ranges = planRootRanges(cellLoads(mesh), cells, 3, R);
  BuildOptions autoOptions;
  autoOptions.backend = Backend::Auto;
  std::vector<std::string> log;
  autoOptions.log = [&](const std::string& m) { log.push_back(m); };
  std::vector<std::unique_ptr<RootRangeBuild>> builds;
  std::vector<RangeBoundary> boundaries;
  for (const RootRange& r : ranges) {
    builds.push_back(makeRangeBuild(mesh, autoOptions, r));
    EXPECT_STREQ(builds.back()->backend(), "cpu");
    EXPECT_EQ(builds.back()->device(), -1);
    boundaries.push_back(builds.back()->buildTree());
  }
  ASSERT_EQ(log.size(), ranges.size());
  EXPECT_NE(log[0].find("using the CPU driver"), std::string::npos) << log[0];
  const std::vector<RangeBoundary> beyond = parityBeyondRanges(boundaries, 1, rowWordsFor(8));
  std::vector<RangeTree> pieces;
  for (size_t i = 0; i < builds.size(); ++i) pieces.push_back(builds[i]->finish(&beyond[i]));
  Volume joined = joinRanges(mesh.grid, std::move(pieces));
  computeStructureStatistics(joined);
  BuildOptions cpu;
  cpu.backend = Backend::Cpu;
  EXPECT_EQ(firstDifference(buildCpu(mesh, cpu), joined), "");

  BuildOptions cuda;
  cuda.backend = Backend::Cuda;
  EXPECT_THROW(makeRangeBuild(mesh, cuda, ranges[0]), Error);
}

// joinRangeTrees: contiguous pieces as one piece, payloads local to it; the
// join of the whole grid's pieces then equals the join of the pieces.
TEST(RootRangeJoin, PiecesJoinIntoOnePieceOfTheirCells) {
  const PreparedMesh mesh = prepareShapeCase(ShapeCase{"two_bodies", 128, 4, 8, false});
  BuildOptions cpu;
  cpu.backend = Backend::Cpu;
  const Volume whole = buildCpu(mesh, cpu);
  const uint64_t cells = 64;
  const std::vector<RootRange> ranges = cutAt({5, 20, 20, 33, 50}, cells);
  std::vector<std::unique_ptr<CpuRangeBuild>> builds;
  std::vector<RangeBoundary> boundaries;
  for (const RootRange& r : ranges) {
    builds.emplace_back(new CpuRangeBuild(mesh, cpu, r));
    boundaries.push_back(builds.back()->buildTree());
  }
  const std::vector<RangeBoundary> beyond = parityBeyondRanges(boundaries, 1, rowWordsFor(8));
  std::vector<RangeTree> pieces;
  for (size_t i = 0; i < builds.size(); ++i) pieces.push_back(builds[i]->finish(&beyond[i]));
  // [5, 50) from four pieces (one empty), between the first and the last.
  std::vector<RangeTree> middle;
  for (size_t i = 1; i + 1 < pieces.size(); ++i) middle.push_back(std::move(pieces[i]));
  std::vector<RangeTree> three;
  three.push_back(std::move(pieces.front()));
  three.push_back(joinRangeTrees(std::move(middle)));
  three.push_back(std::move(pieces.back()));
  EXPECT_EQ(three[1].cells, (RootRange{5, 50}));
  Volume joined = joinRanges(mesh.grid, std::move(three));
  computeStructureStatistics(joined);
  EXPECT_EQ(firstDifference(whole, joined), "");
}

} // namespace
} // namespace test
} // namespace hdt
