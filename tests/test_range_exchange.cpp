// What a build over processes exchanges (range_exchange.hpp), simulated in
// one process: every range built on its own, boundaries and trees passed as
// byte buffers, and the pieces each process keeps. The joined trees must be
// the one-piece build's bytes; the piece volumes, their statistics and their
// surfaces must add up to the whole volume's. Under the winding number the
// ranges are built as surfaces and the joined volume classified once, by the
// joining process.
#include "hdt/builder.hpp"
#include "hdt/error.hpp"
#include "hdt/mesh.hpp"
#include "hdt/range_exchange.hpp"
#include "hdt/winding_tree.hpp"
#include "hdt/voxel_surface.hpp"
#include "support/shapes.hpp"
#include "support/winding_reference.hpp"

#include <gtest/gtest.h>

#include <algorithm>
#include <memory>
#include <tuple>

namespace hdt {
namespace test {
namespace {

// The processes' side of a distributed build: each range built alone, only
// buffers crossing between them. Returns every range's tree.
std::vector<RangeTree> buildAsProcesses(const PreparedMesh& mesh, const std::vector<RootRange>& ranges) {
  BuildOptions options;
  options.backend = Backend::Cpu;
  const int rw = rowWordsFor(mesh.grid.leafSize);
  std::vector<std::unique_ptr<CpuRangeBuild>> builds;
  std::vector<std::vector<uint8_t>> sent;
  for (const RootRange& r : ranges) {
    builds.emplace_back(new CpuRangeBuild(mesh, options, r));
    sent.push_back(packBoundary(builds.back()->buildTree(), rw));
  }
  std::vector<RangeBoundary> received;
  for (const std::vector<uint8_t>& b : sent) received.push_back(unpackBoundary(b.data(), b.size(), rw));
  const std::vector<RangeBoundary> beyond = parityBeyondRanges(received, classifiedAxes(mesh.closed), rw);
  std::vector<RangeTree> trees;
  for (size_t i = 0; i < builds.size(); ++i) {
    const std::vector<uint8_t> bytes = packRangeTree(builds[i]->finish(&beyond[i]));
    trees.push_back(unpackRangeTree(bytes.data(), bytes.size(), mesh.grid));
  }
  return trees;
}

bool sameTree(const RangeTree& a, const RangeTree& b) {
  return a.cells == b.cells && a.levels == b.levels &&
         std::equal(a.leafWords.begin(), a.leafWords.end(), b.leafWords.begin(), b.leafWords.end());
}

std::vector<std::tuple<int, int, int, int, int, int>> quadKeys(const std::vector<SurfaceQuad>& quads) {
  std::vector<std::tuple<int, int, int, int, int, int>> k;
  for (const SurfaceQuad& q : quads) k.emplace_back(q.axis * 4 + q.outward + 1, q.state, q.plane, q.u, q.v, q.du * 65536 + q.dv);
  std::sort(k.begin(), k.end());
  return k;
}

class RangeExchange : public ::testing::TestWithParam<ShapeCase> {};

TEST_P(RangeExchange, ProcessesGiveTheSerialVolume) {
  const ShapeCase& c = GetParam();
  const PreparedMesh mesh = prepareShapeCase(c);
  BuildOptions options;
  options.backend = Backend::Cpu;
  Volume whole = buildCpu(mesh, options);
  const uint64_t R = uint64_t(c.r), cells = R * R * R;
  const std::vector<CellLoad> loads = cellLoads(mesh);
  for (int k : {1, 2, 3, 4, int(R * R) + 2}) {
    SCOPED_TRACE("ranks " + std::to_string(k));
    const std::vector<RootRange> ranges = planRootRanges(loads, cells, k, R);
    std::vector<RangeTree> trees = buildAsProcesses(mesh, ranges);

    Statistics sum;
    std::vector<SurfaceQuad> pieceQuads;
    for (const RangeTree& t : trees) {
      // A slice of the serial volume is what the range's process built.
      EXPECT_TRUE(sameTree(sliceVolume(whole, t.cells), t));
      addStructure(sum, rangeStructure(mesh.grid, t));
      // The piece volume holds the range's trees as they are.
      std::vector<RangeTree> own;
      own.push_back(t);
      Volume piece = pieceVolume(mesh.grid, std::move(own));
      EXPECT_TRUE(sameTree(sliceVolume(piece, t.cells), t));
      // Shown with the job's statistics (what every rank's field data says),
      // a piece is still a valid volume of its own contents' structure.
      piece.stats = whole.stats;
      EXPECT_NO_THROW(validateVolume(piece, StatisticsOf::WholeJob));
      if (t.cells.size() < cells && piece.elements.size() != whole.elements.size())
        EXPECT_THROW(validateVolume(piece), Error);
      // The faces of the range's cells, read from the whole volume.
      SurfaceOptions so;
      so.cellsFirst = t.cells.first;
      so.cellsEnd = t.cells.end;
      const std::vector<SurfaceQuad> q = extractSurfaceQuads(whole, so);
      pieceQuads.insert(pieceQuads.end(), q.begin(), q.end());
    }
    finishStructure(sum);
    EXPECT_EQ(sum.treeElements, whole.stats.treeElements);
    EXPECT_EQ(sum.leafGrids, whole.stats.leafGrids);
    EXPECT_EQ(sum.activeVoxels, whole.stats.activeVoxels);
    EXPECT_EQ(sum.insideVoxels, whole.stats.insideVoxels);
    EXPECT_EQ(sum.leafBytes, whole.stats.leafBytes);
    EXPECT_EQ(sum.topologyBytes, whole.stats.topologyBytes);
    EXPECT_DOUBLE_EQ(sum.paperBitsPerActiveVoxel, whole.stats.paperBitsPerActiveVoxel);
    EXPECT_EQ(quadKeys(pieceQuads), quadKeys(extractSurfaceQuads(whole)));

    // As a distributed gather joins them: range 0 is the gathering process's
    // own, the others send their levels and then their leaf words into place.
    std::vector<uint64_t> counts;
    for (const RangeTree& t : trees) counts.push_back(t.leafWords.size());
    PlacedGather gather(mesh.grid, counts);
    for (size_t r = 1; r < trees.size(); ++r) {
      const std::vector<uint8_t> levels = packRangeLevels(trees[r]);
      gather.addLevels(r, unpackRangeLevels(levels.data(), levels.size(), mesh.grid));
      ASSERT_EQ(gather.wordCountOf(r), trees[r].leafWords.size());
      std::copy(trees[r].leafWords.begin(), trees[r].leafWords.end(), gather.wordsOf(r));
    }
    gather.addOwn(0, RangeTree(trees[0]));
    Volume joined = joinRanges(mesh.grid, std::move(trees));
    Volume gathered = gather.join();
    for (Volume* v : {&joined, &gathered}) {
      v->surfaceOnly = whole.surfaceOnly;
      v->closedMesh = whole.closedMesh;
      computeStructureStatistics(*v);
      EXPECT_EQ(firstDifference(whole, *v), "");
    }
  }
}

INSTANTIATE_TEST_SUITE_P(Cpu, RangeExchange,
                         ::testing::Values(ShapeCase{"sphere", 128, 4, 8, false},
                                           ShapeCase{"open_hemisphere", 128, 4, 8, false},
                                           ShapeCase{"torus", 128, 4, 8, true}),
                         [](const ::testing::TestParamInfo<ShapeCase>& info) { return shapeCaseName(info.param); });

TEST(RangeExchange, DamagedBuffersAreRefused) {
  const PreparedMesh mesh = prepareShapeCase(ShapeCase{"sphere", 64, 4, 8, false});
  BuildOptions options;
  options.backend = Backend::Cpu;
  const Volume whole = buildCpu(mesh, options);
  std::vector<uint8_t> bytes = packRangeTree(sliceVolume(whole, RootRange{0, 64}));
  EXPECT_THROW(unpackRangeTree(bytes.data(), bytes.size() - 1, mesh.grid), Error);
  bytes[0] ^= 1;
  EXPECT_THROW(unpackRangeTree(bytes.data(), bytes.size(), mesh.grid), Error);
  EXPECT_THROW(sliceVolume(whole, RootRange{0, 65}), Error);

  // The levels alone: damaged, or from another grid.
  const RangeTree half = sliceVolume(whole, RootRange{0, 32});
  std::vector<uint8_t> levels = packRangeLevels(half);
  EXPECT_THROW(unpackRangeLevels(levels.data(), levels.size() - 1, mesh.grid), Error);
  GridSpec taller = mesh.grid;
  taller.height += 1;
  EXPECT_THROW(unpackRangeLevels(levels.data(), levels.size(), taller), Error);
  levels[0] ^= 1;
  EXPECT_THROW(unpackRangeLevels(levels.data(), levels.size(), mesh.grid), Error);
}

TEST(RangeExchange, PlacedGatherRefusesMismatchedCounts) {
  const PreparedMesh mesh = prepareShapeCase(ShapeCase{"sphere", 64, 4, 8, false});
  BuildOptions options;
  options.backend = Backend::Cpu;
  const Volume whole = buildCpu(mesh, options);
  const RangeTree a = sliceVolume(whole, RootRange{0, 32}), b = sliceVolume(whole, RootRange{32, 64});
  ASSERT_FALSE(a.leafWords.empty());
  ASSERT_FALSE(b.leafWords.empty());
  // Not whole leaves.
  EXPECT_THROW(PlacedGather(mesh.grid, {a.leafWords.size() + 1, b.leafWords.size()}), Error);
  // A range never added.
  {
    PlacedGather g(mesh.grid, {a.leafWords.size(), b.leafWords.size()});
    g.addOwn(0, RangeTree(a));
    EXPECT_THROW(g.join(), Error);
  }
  // A range that announced one leaf more than its tree has.
  {
    const uint64_t perLeaf = leafWordCount(mesh.grid.leafSize);
    PlacedGather g(mesh.grid, {a.leafWords.size(), b.leafWords.size() + perLeaf});
    g.addOwn(0, RangeTree(a));
    RangeTree bLevels = b;
    bLevels.leafWords = LeafWordVector();
    bLevels.leafCoord.clear();
    std::fill(g.wordsOf(1), g.wordsOf(1) + g.wordCountOf(1), 0u);
    g.addLevels(1, std::move(bLevels));
    EXPECT_THROW(g.join(), Error);
  }
  // The own range's words must be what it announced; levels come without words.
  {
    const uint64_t perLeaf = leafWordCount(mesh.grid.leafSize);
    PlacedGather g(mesh.grid, {a.leafWords.size() + perLeaf, b.leafWords.size()});
    EXPECT_THROW(g.addOwn(0, RangeTree(a)), Error);
    EXPECT_THROW(g.addLevels(1, RangeTree(b)), Error);
  }
}

} // namespace
} // namespace test
} // namespace hdt

namespace hdt {
namespace test {
namespace {

// The distributed winding-number build (apps/cli_mpi.cpp,
// filters/vtkHDTDistributedBuild.cxx): the ranges' surface trees joined,
// classified by applyInsideTest in the joining process, each range's trees
// sliced out again for its process. Equal to the serial build's, whole and
// range by range, for every open, overlapping and nested test shape.
TEST(RangeExchange, WindingNumberAcrossProcessesGivesTheSerialVolume) {
  const BuildConfig config = windingShapesConfig();
  BuildOptions options;
  options.backend = Backend::Cpu;
  for (const WindingShape& shape : windingShapes()) {
    SCOPED_TRACE(shape.name);
    const PreparedMesh mesh = prepareMesh(shape.mesh, config);
    const Volume serial = buildCpu(mesh, options);
    const uint64_t R = uint64_t(config.rootGrid);
    for (int k : {2, 3}) {
      SCOPED_TRACE("ranks " + std::to_string(k));
      const std::vector<RootRange> ranges = planRootRanges(cellLoads(mesh), R * R * R, k, R);
      Volume joined = joinRanges(mesh.grid, buildAsProcesses(mesh, ranges));
      applyInsideTest(mesh, joined);
      computeStructureStatistics(joined);
      EXPECT_EQ(joined.insideTest, InsideTest::WindingNumber);
      EXPECT_EQ(joined.levelStart, serial.levelStart);
      EXPECT_TRUE(joined.elements == serial.elements);
      EXPECT_TRUE(joined.leafWords == serial.leafWords);
      EXPECT_EQ(joined.stats.insideVoxels, serial.stats.insideVoxels);
      for (const RootRange& r : ranges) {
        const std::vector<uint8_t> bytes = packRangeTree(sliceVolume(joined, r));
        EXPECT_TRUE(sameTree(unpackRangeTree(bytes.data(), bytes.size(), mesh.grid), sliceVolume(serial, r)));
      }
    }
  }
}

// The joining process's pass through the dispatcher (applyInsideTestAfterPhases):
// on the host for Backend Cpu and for a joining process whose own range ran on
// the CPU (insideTestOptionsAfterRangeBuild with device -1), whatever backend
// was asked; the serial bytes. (With a device, tests/cuda/test_cuda_ranges.cpp.)
TEST(RangeExchange, InsideTestAfterPhasesOnTheHostGivesTheSerialVolume) {
  const BuildConfig config = windingShapesConfig();
  BuildOptions cpu;
  cpu.backend = Backend::Cpu;
  BuildOptions cuda;
  cuda.backend = Backend::Cuda;
  cuda.device = 3;
  for (const WindingShape& shape : windingShapes()) {
    SCOPED_TRACE(shape.name);
    const PreparedMesh mesh = prepareMesh(shape.mesh, config);
    const Volume serial = buildCpu(mesh, cpu);
    const std::vector<RootRange> ranges = planRootRanges(cellLoads(mesh), 64, 2, 4);
    for (const BuildOptions& o : {cpu, insideTestOptionsAfterRangeBuild(cuda, -1)}) {
      Volume joined = joinRanges(mesh.grid, buildAsProcesses(mesh, ranges));
      applyInsideTestAfterPhases(mesh, joined, o);
      computeStructureStatistics(joined);
      EXPECT_EQ(joined.insideTest, InsideTest::WindingNumber);
      EXPECT_TRUE(joined.elements == serial.elements);
      EXPECT_TRUE(joined.leafWords == serial.leafWords);
      EXPECT_EQ(joined.stats.insideVoxels, serial.stats.insideVoxels);
    }
  }
  // A range that ran on a GPU keeps the backend asked and names its device.
  const BuildOptions onGpu = insideTestOptionsAfterRangeBuild(cuda, 1);
  EXPECT_EQ(onGpu.backend, Backend::Cuda);
  EXPECT_EQ(onGpu.device, 1);
  EXPECT_EQ(insideTestOptionsAfterRangeBuild(cuda, -1).backend, Backend::Cpu);
}

} // namespace
} // namespace test
} // namespace hdt
