// The CUDA driver on root ranges (makeCudaRangeBuild), as the ranks of a
// distributed build run it: every range built in its two stages, the
// boundary parities exchanged between them (parityBeyondRanges), the pieces
// joined. Whatever the split (1-5 balanced ranges, aligned to rows or not,
// ranges without triangles, empty ranges, more ranges than rows, a cut
// inside a row) the joined volume must be the one-piece build's bytes, and
// each range's boundary parities and piece the CPU driver's for that range
// (CpuRangeBuild), so ranges of one build may run on different drivers.
#include "cuda_compare.hpp"

#include "hdt/builder.hpp"
#include "hdt/error.hpp"
#include "hdt/mesh.hpp"
#include "hdt/range_exchange.hpp"
#include "hdt/root_ranges.hpp"
#include "hdt/winding_tree.hpp"
#include "support/range_splits.hpp"
#include "support/shapes.hpp"
#include "support/winding_reference.hpp"

#include <gtest/gtest.h>

#include <algorithm>
#include <memory>
#include <string>
#include <vector>

namespace hdt {
namespace test {
namespace {

bool sameLines(const LineParities& a, const LineParities& b) { return a.line == b.line && a.words == b.words; }

bool samePiece(const RangeTree& a, const RangeTree& b) {
  return a.cells == b.cells && a.levels == b.levels && a.leafCoord == b.leafCoord && a.leafWords == b.leafWords;
}

// What the ranks of a distributed build do, all in this process: the two
// stages of every range with the boundary exchange between them.
struct RangesRun {
  std::vector<RangeBoundary> boundaries;
  std::vector<RangeTree> pieces;
  std::vector<std::string> backends;
};

RangesRun runRanges(const PreparedMesh& mesh, const std::vector<BuildOptions>& options,
                    const std::vector<RootRange>& ranges) {
  RangesRun run;
  std::vector<std::unique_ptr<RootRangeBuild>> builds;
  for (size_t r = 0; r < ranges.size(); ++r) {
    builds.push_back(makeRangeBuild(mesh, options[r % options.size()], ranges[r]));
    run.boundaries.push_back(builds.back()->buildTree());
  }
  const std::vector<RangeBoundary> beyond =
      parityBeyondRanges(run.boundaries, classifiedAxes(mesh.closed), rowWordsFor(mesh.grid.leafSize));
  for (size_t r = 0; r < ranges.size(); ++r) {
    run.pieces.push_back(builds[r]->finish(&beyond[r]));
    run.backends.push_back(builds[r]->backend());
  }
  return run;
}

Volume joined(const PreparedMesh& mesh, std::vector<RangeTree> pieces) {
  Volume v = joinRanges(mesh.grid, std::move(pieces));
  computeStructureStatistics(v);
  return v;
}

class CudaRangeBuildTest : public ::testing::TestWithParam<ShapeCase> {};

TEST_P(CudaRangeBuildTest, JoinedRangesEqualTheOnePieceBuildAndEachRangeTheCpus) {
  HDT_REQUIRE_CUDA();
  const PreparedMesh mesh = prepareShapeCase(GetParam());
  const Volume whole = build(mesh, cudaOptions());
  ASSERT_TRUE(sameVolume(whole, build(mesh, cpuOptions())));
  for (const std::vector<RootRange>& ranges : rangeSplitsOf(mesh)) {
    const RangesRun gpu = runRanges(mesh, {cudaOptions()}, ranges);
    const RangesRun cpu = runRanges(mesh, {cpuOptions()}, ranges);
    for (size_t r = 0; r < ranges.size(); ++r) {
      EXPECT_EQ(gpu.backends[r], "cuda");
      for (int a = 0; a < 3; ++a)
        EXPECT_TRUE(sameLines(gpu.boundaries[r].axis[a], cpu.boundaries[r].axis[a]))
            << "boundary parities of range " << r << " axis " << a << " of " << describeRanges(ranges);
      EXPECT_TRUE(samePiece(gpu.pieces[r], cpu.pieces[r])) << "range " << r << " of " << describeRanges(ranges);
    }
    EXPECT_EQ(firstDifference(whole, joined(mesh, gpu.pieces)), "") << describeRanges(ranges);
  }
}

// Ranges alternately on the GPU and the CPU (ranks of one build where some
// have no device) give the same bytes.
TEST_P(CudaRangeBuildTest, RangesOnBothDriversGiveTheSameBytes) {
  HDT_REQUIRE_CUDA();
  const PreparedMesh mesh = prepareShapeCase(GetParam());
  const Volume whole = build(mesh, cpuOptions());
  const uint64_t R = uint64_t(mesh.grid.rootGrid);
  for (int k : {2, 3, 5}) {
    const std::vector<RootRange> ranges = planRootRanges(cellLoads(mesh), R * R * R, k, R);
    const RangesRun run = runRanges(mesh, {cudaOptions(), cpuOptions()}, ranges);
    EXPECT_EQ(run.backends[0], "cuda");
    EXPECT_EQ(run.backends[1], "cpu");
    EXPECT_EQ(firstDifference(whole, joined(mesh, run.pieces)), "") << describeRanges(ranges);
  }
}

INSTANTIATE_TEST_SUITE_P(Cuda, CudaRangeBuildTest,
                         ::testing::Values(ShapeCase{"sphere", 128, 4, 8, false},
                                           ShapeCase{"hollow_sphere", 128, 2, 16, false},
                                           ShapeCase{"open_hemisphere", 128, 4, 8, false},
                                           ShapeCase{"two_bodies", 128, 4, 8, false},
                                           ShapeCase{"torus", 128, 4, 8, true},
                                           ShapeCase{"two_bodies", 512, 8, 16, false}),
                         [](const ::testing::TestParamInfo<ShapeCase>& info) { return shapeCaseName(info.param); });

// A range larger than the device memory budget is built in chunks inside
// the range (the parity beyond the range joins the chunks' own).
TEST(CudaRangeBuild, RangesChunkedByTheBudgetGiveTheSameBytes) {
  HDT_REQUIRE_CUDA();
  for (const char* shape : {"sphere", "open_hemisphere"}) {
    const PreparedMesh mesh = prepareShapeCase(ShapeCase{shape, 512, 16, 16, false});
    const Volume whole = build(mesh, cudaOptions());
    BuildOptions small = cudaOptions();
    small.deviceMemoryBudget = whole.stats.peakDeviceBytes / 3;
    const uint64_t R = uint64_t(mesh.grid.rootGrid);
    for (int k : {1, 2, 3}) {
      const std::vector<RootRange> ranges = planRootRanges(cellLoads(mesh), R * R * R, k, R);
      const RangesRun run = runRanges(mesh, {small}, ranges);
      EXPECT_EQ(firstDifference(whole, joined(mesh, run.pieces)), "") << shape << " as " << describeRanges(ranges);
    }
  }
}

// Auto falls back to the CPU driver per range when the CUDA driver cannot
// build it (here: a budget below one root cell), and says so.
TEST(CudaRangeBuild, AutoFallsBackToTheCpuPerRange) {
  HDT_REQUIRE_CUDA();
  const PreparedMesh mesh = prepareShapeCase(ShapeCase{"sphere", 256, 2, 16, false});
  const Volume whole = build(mesh, cpuOptions());
  BuildOptions tiny;
  tiny.backend = Backend::Auto;
  tiny.deviceMemoryBudget = 4096; // not even the triangles fit
  std::vector<std::string> log;
  tiny.log = [&](const std::string& m) { log.push_back(m); };
  BuildOptions autoOk;
  autoOk.backend = Backend::Auto;
  const std::vector<RootRange> ranges = planRootRanges(cellLoads(mesh), 8, 2, 2);
  const RangesRun run = runRanges(mesh, {tiny, autoOk}, ranges);
  EXPECT_EQ(run.backends[0], "cpu");
  EXPECT_EQ(run.backends[1], "cuda");
  ASSERT_FALSE(log.empty());
  EXPECT_NE(log[0].find("CPU driver"), std::string::npos) << log[0];
  EXPECT_EQ(firstDifference(whole, joined(mesh, run.pieces)), "");
}

// Under the winding number the ranges are built as surfaces and the joining
// process classifies the joined volume (applyInsideTestAfterPhases): on its
// GPU, whichever driver built the ranges, the serial build's bytes; the
// device passes ran (the driver's log says so) unless the options say the
// joining process's own range ran on the CPU.
TEST(CudaRangeBuild, WindingPassOnTheJoiningProcesssDeviceGivesTheSerialVolume) {
  HDT_REQUIRE_CUDA();
  for (const WindingShape& shape : windingShapes()) {
    SCOPED_TRACE(shape.name);
    const PreparedMesh mesh = prepareMesh(shape.mesh, windingShapesConfig());
    const Volume serial = build(mesh, cpuOptions());
    const std::vector<RootRange> ranges = planRootRanges(cellLoads(mesh), 64, 3, 4);
    for (const BuildOptions& rangeOptions : {cudaOptions(), cpuOptions()}) {
      const Volume surfaces = joinRanges(mesh.grid, runRanges(mesh, {rangeOptions}, ranges).pieces);
      for (const int rangeDevice : {0, -1}) {
        SCOPED_TRACE("ranges on " + std::string(rangeOptions.backend == Backend::Cuda ? "cuda" : "cpu") +
                     ", the joining range's device " + std::to_string(rangeDevice));
        Volume v = surfaces;
        std::vector<std::string> log;
        BuildOptions automatic;
        automatic.backend = Backend::Auto;
        automatic.log = [&](const std::string& m) { log.push_back(m); };
        applyInsideTestAfterPhases(mesh, v, insideTestOptionsAfterRangeBuild(automatic, rangeDevice));
        computeStructureStatistics(v);
        EXPECT_EQ(v.insideTest, InsideTest::WindingNumber);
        EXPECT_EQ(firstDifference(serial, v), "");
        EXPECT_EQ(v.stats.insideVoxels, serial.stats.insideVoxels);
        const bool onDevice = std::any_of(log.begin(), log.end(), [](const std::string& m) {
          return m.find("winding pass on the device") != std::string::npos;
        });
        EXPECT_EQ(onDevice, rangeDevice >= 0);
      }
    }
  }
}

TEST(CudaRangeBuild, CellsOutsideTheRootGridAreRefused) {
  HDT_REQUIRE_CUDA();
  const PreparedMesh mesh = prepareShapeCase(ShapeCase{"sphere", 128, 4, 8, false});
  EXPECT_THROW(makeCudaRangeBuild(mesh, cudaOptions(), RootRange{0, 65}), Error);
  EXPECT_THROW(makeCudaRangeBuild(mesh, cudaOptions(), RootRange{5, 3}), Error);
}

} // namespace
} // namespace test
} // namespace hdt
