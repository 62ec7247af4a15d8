// hdt::Volume -> vtkHyperTreeGrid: every cell of the output against the core's
// own voxel states (hdt::voxelAt), on generated meshes from 64^3 to 256^3.
#include "hdt_vtk_test_util.h"

#include "vtkHDTHyperTreeGridConversion.h"
#include "vtkHDTVoxelizer.h"

#include "hdt/config.hpp"
#include "hdt/dense.hpp"
#include "hdt/error.hpp"
#include "hdt/volume.hpp"

#include "vtkCellData.h"
#include "vtkFieldData.h"
#include "vtkHyperTreeGrid.h"
#include "vtkNew.h"
#include "vtkPolyData.h"
#include "vtkStringArray.h"
#include "vtkUnsignedCharArray.h"

#include <gtest/gtest.h>

#include <cmath>
#include <memory>

namespace
{

struct Case
{
  const char* name;
  bool torus;
  int resolution, rootGrid, leafSize;
  bool surfaceOnly;
};

void PrintTo(const Case& c, std::ostream* os)
{
  *os << c.name;
}

std::string joined(const std::vector<std::string>& v)
{
  std::string s;
  for (const auto& x : v)
  {
    s += "\n  " + x;
  }
  return s;
}

// These tests were written for the masked conversion at full depth with 8^3
// leaves (the filter's defaults until issue 13); tests that vary them say so.
void UseMaskedFullDepthDefaults(vtkHDTVoxelizer* filter)
{
  filter->SetMaskOutside(true);
  filter->SetMaxDepth(-1);
  filter->SetLeafGridSize(8);
}

class Conversion : public ::testing::TestWithParam<Case>
{
};

// Runs the filter and checks the whole output against the dense states.
TEST_P(Conversion, EveryCellMatchesTheVolume)
{
  const Case c = GetParam();
  vtkSmartPointer<vtkPolyData> mesh = c.torus ? hdtvtk::MakeTorus() : hdtvtk::MakeSphere();
  vtkNew<vtkHDTVoxelizer> filter;
  UseMaskedFullDepthDefaults(filter);
  filter->SetInputData(mesh);
  filter->SetResolution(c.resolution);
  filter->SetRootGridSize(c.rootGrid);
  filter->SetLeafGridSize(c.leafSize);
  filter->SetSurfaceOnly(c.surfaceOnly);
  filter->SetBackend(vtkHDTVoxelizer::BACKEND_CPU);
  vtkNew<hdtvtk::MessageLog> log;
  filter->AddObserver(vtkCommand::ErrorEvent, log);
  filter->AddObserver(vtkCommand::WarningEvent, log);
  filter->Update();
  ASSERT_TRUE(log->Errors.empty()) << joined(log->Errors);
  EXPECT_TRUE(log->Warnings.empty()) << joined(log->Warnings);

  std::shared_ptr<const hdt::Volume> volume = filter->GetVolume();
  ASSERT_TRUE(volume);
  vtkHyperTreeGrid* htg = filter->GetOutput();
  const hdt::GridSpec& g = volume->grid;
  const int fullDepth = vtkHDTToHyperTreeGrid::FullDepth(*volume);
  EXPECT_EQ(fullDepth, g.height + int(std::log2(g.leafSize)));

  // Grid layout: R^3 trees, point dimensions R + 1, branch factor 2, 3D.
  unsigned int dims[3];
  htg->GetDimensions(dims);
  EXPECT_EQ(dims[0], unsigned(g.rootGrid + 1));
  EXPECT_EQ(dims[2], unsigned(g.rootGrid + 1));
  EXPECT_EQ(htg->GetBranchFactor(), 2u);
  EXPECT_EQ(htg->GetDimension(), 3u);
  EXPECT_EQ(htg->GetMaxNumberOfTrees(), vtkIdType(g.rootGrid) * g.rootGrid * g.rootGrid);
  EXPECT_EQ(int(htg->GetNumberOfLevels()), fullDepth + 1);

  const std::vector<uint8_t> dense = hdtvtk::DenseStates(*volume);
  // The core's two ways of reading voxels agree (tree walk vs dense export).
  EXPECT_TRUE(dense == hdt::denseStates(*volume));
  const hdtvtk::WalkResult walk = hdtvtk::WalkAndCheck(htg, *volume, dense, fullDepth, true);
  EXPECT_TRUE(walk.Problems.empty()) << joined(walk.Problems);

  // Cells per depth: geometric walk == independent recursion; octree depths
  // == the HDT's levels.
  const std::vector<int64_t> reference = hdtvtk::ReferenceCellsPerDepth(*volume, dense, fullDepth);
  EXPECT_EQ(walk.CellsPerDepth, reference);
  for (int level = 0; level <= g.height; ++level)
  {
    EXPECT_EQ(reference[size_t(level)],
      int64_t(volume->levelStart[size_t(level) + 1] - volume->levelStart[size_t(level)]))
      << "level " << level;
  }
  int64_t total = 0;
  for (int64_t n : reference)
  {
    total += n;
  }
  EXPECT_EQ(htg->GetNumberOfCells(), total);

  // The volume is what the mesh says: no inside voxels in surface-only mode;
  // otherwise the solid's volume in voxels is close to the analytic one.
  const hdt::Statistics& s = volume->stats;
  if (c.surfaceOnly)
  {
    EXPECT_EQ(s.insideVoxels, 0u);
  }
  else
  {
    const double vs = g.voxelSize;
    const double analytic = c.torus ? 2 * M_PI * M_PI * 1.0 * 0.35 * 0.35 / (vs * vs * vs)
                                    : 4.0 / 3.0 * M_PI * std::pow(0.5 / vs, 3);
    const double measured = double(s.insideVoxels) + 0.5 * double(s.activeVoxels);
    EXPECT_NEAR(measured / analytic, 1.0, 0.03);
  }

  // Field data.
  vtkFieldData* fd = htg->GetFieldData();
  for (const char* name : { "TreeElements", "LeafGrids", "LeafVoxels", "ActiveVoxels",
         "InsideVoxels", "PaperBitsPerActiveVoxel", "TopologyBytes", "LeafBytes", "TimeMapping",
         "TimeBranching", "TimeLeaf", "TimeClassify", "TimeTotal", "Backend", "Resolution",
         "Height" })
  {
    EXPECT_NE(fd->GetAbstractArray(name), nullptr) << name;
  }
  EXPECT_EQ(fd->GetArray("ActiveVoxels")->GetTuple1(0), double(s.activeVoxels));
  EXPECT_EQ(fd->GetArray("Resolution")->GetTuple1(0), double(c.resolution));
  EXPECT_EQ(fd->GetArray("Height")->GetTuple1(0), double(g.height));
  EXPECT_EQ(vtkStringArray::SafeDownCast(fd->GetAbstractArray("Backend"))->GetValue(0), "cpu");
}

INSTANTIATE_TEST_SUITE_P(Meshes, Conversion,
  ::testing::Values(Case{ "sphere64_R4_L8_h1", false, 64, 4, 8, false },
    Case{ "sphere128_R8_L16_h0", false, 128, 8, 16, false },
    Case{ "sphere128_R2_L32_h1", false, 128, 2, 32, false },
    Case{ "sphere256_R16_L8_h1_defaults", false, 256, 16, 8, false },
    Case{ "torus256_R4_L16_h2", true, 256, 4, 16, false },
    Case{ "torus128_surfaceOnly", true, 128, 4, 8, true }),
  [](const ::testing::TestParamInfo<Case>& info) { return std::string(info.param.name); });

// MaxDepth: every cut depth gives a tree of that depth whose cut cells carry
// the aggregated state; the filter re-converts without re-voxelizing.
TEST(ConversionMaxDepth, CutsAndAggregates)
{
  vtkNew<vtkHDTVoxelizer> filter;
  UseMaskedFullDepthDefaults(filter);
  filter->SetInputData(hdtvtk::MakeTorus());
  filter->SetResolution(128);
  filter->SetRootGridSize(4);
  filter->SetLeafGridSize(8); // height 2, full depth 5
  filter->Update();
  std::shared_ptr<const hdt::Volume> volume = filter->GetVolume();
  ASSERT_TRUE(volume);
  EXPECT_FALSE(filter->GetLastRunReusedVolume());
  const int fullDepth = vtkHDTToHyperTreeGrid::FullDepth(*volume);
  ASSERT_EQ(fullDepth, 5);
  const std::vector<uint8_t> dense = hdtvtk::DenseStates(*volume);

  for (int cut = 0; cut <= fullDepth + 2; ++cut)
  {
    filter->SetMaxDepth(cut);
    filter->Update();
    EXPECT_TRUE(filter->GetLastRunReusedVolume()) << "cut " << cut;
    EXPECT_EQ(filter->GetVolume(), volume);
    vtkHyperTreeGrid* htg = filter->GetOutput();
    const int expectedDepth = std::min(cut, fullDepth);
    EXPECT_EQ(int(htg->GetNumberOfLevels()), expectedDepth + 1) << "cut " << cut;
    const hdtvtk::WalkResult walk = hdtvtk::WalkAndCheck(htg, *volume, dense, expectedDepth, true);
    EXPECT_TRUE(walk.Problems.empty()) << "cut " << cut << joined(walk.Problems);
    EXPECT_EQ(walk.CellsPerDepth, hdtvtk::ReferenceCellsPerDepth(*volume, dense, expectedDepth));
  }

  // The conversion function directly reports the same counts.
  vtkHDTConversionOptions options;
  options.MaxDepth = 3;
  vtkNew<vtkHyperTreeGrid> htg;
  const vtkHDTConversionInfo info = vtkHDTToHyperTreeGrid::Convert(*volume, options, htg);
  EXPECT_EQ(info.Depth, 3);
  std::vector<int64_t> perDepth(info.CellsPerDepth.begin(), info.CellsPerDepth.end());
  EXPECT_EQ(perDepth, hdtvtk::ReferenceCellsPerDepth(*volume, dense, 3));
  EXPECT_EQ(info.Cells, htg->GetNumberOfCells());
  EXPECT_EQ(info.LeafCells, htg->GetNumberOfLeaves());

  options.MaxDepth = -3;
  EXPECT_THROW(vtkHDTToHyperTreeGrid::Convert(*volume, options, htg), hdt::Error);
}

// MaxDepth Auto (-2): the deepest depth with at most 1024 cells per axis.
TEST(ConversionMaxDepth, AutoDepth)
{
  hdt::Volume v;
  v.grid.rootGrid = 16;
  v.grid.leafSize = 16;
  v.grid.height = 4; // N = 4096, full depth 8
  EXPECT_EQ(vtkHDTToHyperTreeGrid::DepthCut(v, vtkHDTToHyperTreeGrid::AUTO_DEPTH), 6); // 16 << 6 = 1024
  EXPECT_EQ(vtkHDTToHyperTreeGrid::DepthCut(v, -1), 8);
  EXPECT_EQ(vtkHDTToHyperTreeGrid::DepthCut(v, 3), 3);
  EXPECT_EQ(vtkHDTToHyperTreeGrid::DepthCut(v, 20), 8);
  v.grid.height = 2; // N = 1024: full depth is within the bound
  EXPECT_EQ(vtkHDTToHyperTreeGrid::DepthCut(v, vtkHDTToHyperTreeGrid::AUTO_DEPTH), 6);
  v.grid.rootGrid = 2048; // a root grid finer than the bound: the root grid alone
  EXPECT_EQ(vtkHDTToHyperTreeGrid::DepthCut(v, vtkHDTToHyperTreeGrid::AUTO_DEPTH), 0);
}

// The aggregation rule itself, including the majority case that a correct
// build never needs.
TEST(ConversionMaxDepth, AggregateRule)
{
  EXPECT_EQ(vtkHDTToHyperTreeGrid::AggregateState(8, 1, 7), 2);
  EXPECT_EQ(vtkHDTToHyperTreeGrid::AggregateState(8, 0, 8), 1);
  EXPECT_EQ(vtkHDTToHyperTreeGrid::AggregateState(8, 0, 0), 0);
  EXPECT_EQ(vtkHDTToHyperTreeGrid::AggregateState(8, 0, 5), 1);
  EXPECT_EQ(vtkHDTToHyperTreeGrid::AggregateState(8, 0, 4), 0); // a tie is not a majority
}

// MaskOutside off: no mask at all, and the same states as with it.
TEST(ConversionMask, OffMeansNoMaskAndSameStates)
{
  vtkNew<vtkHDTVoxelizer> filter;
  UseMaskedFullDepthDefaults(filter);
  filter->SetInputData(hdtvtk::MakeSphere());
  filter->SetResolution(128);
  filter->Update();
  vtkNew<vtkHyperTreeGrid> masked;
  masked->ShallowCopy(filter->GetOutput());
  ASSERT_TRUE(masked->HasMask());

  filter->SetMaskOutside(false);
  filter->Update();
  EXPECT_TRUE(filter->GetLastRunReusedVolume());
  vtkHyperTreeGrid* unmasked = filter->GetOutput();
  EXPECT_FALSE(unmasked->HasMask());
  auto* a = vtkUnsignedCharArray::SafeDownCast(masked->GetCellData()->GetArray("VoxelState"));
  auto* b = vtkUnsignedCharArray::SafeDownCast(unmasked->GetCellData()->GetArray("VoxelState"));
  ASSERT_TRUE(a && b);
  ASSERT_EQ(a->GetNumberOfTuples(), b->GetNumberOfTuples());
  EXPECT_TRUE(std::equal(a->GetPointer(0), a->GetPointer(0) + a->GetNumberOfTuples(), b->GetPointer(0)));
  const std::vector<uint8_t> dense = hdtvtk::DenseStates(*filter->GetVolume());
  const hdtvtk::WalkResult walk = hdtvtk::WalkAndCheck(
    unmasked, *filter->GetVolume(), dense, vtkHDTToHyperTreeGrid::FullDepth(*filter->GetVolume()), false);
  EXPECT_TRUE(walk.Problems.empty()) << joined(walk.Problems);
  EXPECT_EQ(walk.Masked, 0);
}

// One thread and all threads give the same arrays.
TEST(ConversionThreads, SequentialEqualsParallel)
{
  vtkNew<vtkHDTVoxelizer> filter;
  UseMaskedFullDepthDefaults(filter);
  filter->SetInputData(hdtvtk::MakeTorus());
  filter->SetResolution(256);
  filter->SetRootGridSize(8);
  filter->SetLeafGridSize(16);
  filter->Update();
  std::shared_ptr<const hdt::Volume> volume = filter->GetVolume();
  ASSERT_TRUE(volume);
  vtkHDTConversionOptions one, all;
  one.Threads = 1;
  all.Threads = 0;
  vtkNew<vtkHyperTreeGrid> a, b;
  const vtkHDTConversionInfo ia = vtkHDTToHyperTreeGrid::Convert(*volume, one, a);
  const vtkHDTConversionInfo ib = vtkHDTToHyperTreeGrid::Convert(*volume, all, b);
  EXPECT_EQ(ia.Cells, ib.Cells);
  EXPECT_EQ(ia.CellsPerDepth, ib.CellsPerDepth);
  EXPECT_EQ(ia.MaskedCells, ib.MaskedCells);
  auto* sa = vtkUnsignedCharArray::SafeDownCast(a->GetCellData()->GetArray("VoxelState"));
  auto* sb = vtkUnsignedCharArray::SafeDownCast(b->GetCellData()->GetArray("VoxelState"));
  ASSERT_EQ(sa->GetNumberOfTuples(), sb->GetNumberOfTuples());
  EXPECT_TRUE(std::equal(sa->GetPointer(0), sa->GetPointer(0) + sa->GetNumberOfTuples(), sb->GetPointer(0)));
  EXPECT_EQ(a->GetNumberOfLeaves(), b->GetNumberOfLeaves());
}

// Both ways of building VTK's trees give the same, correct grid.
TEST(ConversionTreeBuild, InitializeForReaderEqualsBreadthFirstDescriptor)
{
  vtkNew<vtkHDTVoxelizer> filter;
  UseMaskedFullDepthDefaults(filter);
  filter->SetInputData(hdtvtk::MakeTorus());
  filter->SetResolution(128);
  filter->SetRootGridSize(4);
  filter->SetLeafGridSize(16); // height 1
  filter->Update();
  std::shared_ptr<const hdt::Volume> volume = filter->GetVolume();
  ASSERT_TRUE(volume);
  const std::vector<uint8_t> dense = hdtvtk::DenseStates(*volume);
  const int fullDepth = vtkHDTToHyperTreeGrid::FullDepth(*volume);
  for (int cut : { -1, 2 })
  {
    vtkHDTConversionOptions a, b;
    a.TreeBuild = vtkHDTConversionOptions::INITIALIZE_FOR_READER;
    b.TreeBuild = vtkHDTConversionOptions::BREADTH_FIRST_DESCRIPTOR;
    a.MaxDepth = b.MaxDepth = cut;
    vtkNew<vtkHyperTreeGrid> ha, hb;
    vtkHDTToHyperTreeGrid::Convert(*volume, a, ha);
    vtkHDTToHyperTreeGrid::Convert(*volume, b, hb);
    const int depth = cut < 0 ? fullDepth : cut;
    const hdtvtk::WalkResult wa = hdtvtk::WalkAndCheck(ha, *volume, dense, depth, true);
    const hdtvtk::WalkResult wb = hdtvtk::WalkAndCheck(hb, *volume, dense, depth, true);
    EXPECT_TRUE(wa.Problems.empty()) << joined(wa.Problems);
    EXPECT_TRUE(wb.Problems.empty()) << joined(wb.Problems);
    EXPECT_EQ(wa.CellsPerDepth, wb.CellsPerDepth);
    EXPECT_EQ(ha->GetNumberOfCells(), hb->GetNumberOfCells());
    EXPECT_EQ(ha->GetNumberOfLeaves(), hb->GetNumberOfLeaves());
    EXPECT_EQ(ha->GetNumberOfLevels(), hb->GetNumberOfLevels());
    EXPECT_EQ(int(ha->GetNumberOfLevels()), depth + 1);
  }
}

// A damaged volume is refused with hdt::Error, never a crash.
TEST(ConversionRobustness, InconsistentVolumesAreRefused)
{
  vtkNew<vtkHDTVoxelizer> filter;
  UseMaskedFullDepthDefaults(filter);
  filter->SetInputData(hdtvtk::MakeSphere());
  filter->SetResolution(64);
  filter->SetRootGridSize(4); // height 1
  filter->Update();
  ASSERT_TRUE(filter->GetVolume());
  const hdt::Volume good = *filter->GetVolume();
  vtkNew<vtkHyperTreeGrid> htg;
  const vtkHDTConversionOptions options;

  // A Branch element pointing past the element array.
  hdt::Volume v = good;
  for (auto& w : v.elements)
  {
    if (hdt::elementState(w) == hdt::ElementState::Branch)
    {
      w = hdt::makeElement(hdt::ElementState::Branch, uint32_t(v.elements.size()));
      break;
    }
  }
  EXPECT_THROW(vtkHDTToHyperTreeGrid::Convert(v, options, htg), hdt::Error);
  // A Boundary element with a leaf index out of range.
  v = good;
  for (auto& w : v.elements)
  {
    if (hdt::elementState(w) == hdt::ElementState::Boundary)
    {
      w = hdt::makeElement(hdt::ElementState::Boundary, uint32_t(v.leafCount()));
      break;
    }
  }
  EXPECT_THROW(vtkHDTToHyperTreeGrid::Convert(v, options, htg), hdt::Error);
  // A level table that does not add up.
  v = good;
  v.levelStart.pop_back();
  EXPECT_THROW(vtkHDTToHyperTreeGrid::Convert(v, options, htg), hdt::Error);
  // Truncated leaf payload.
  v = good;
  v.leafWords.resize(v.leafWords.size() - 1);
  EXPECT_THROW(vtkHDTToHyperTreeGrid::Convert(v, options, htg), hdt::Error);
  // And the good one still converts.
  EXPECT_NO_THROW(vtkHDTToHyperTreeGrid::Convert(good, options, htg));
  EXPECT_GT(htg->GetNumberOfCells(), 64);
}

} // namespace

// The output's memory check: a grid estimated to need more than the limit once
// shown is refused before it is built, naming Max Depth; the drawing warning
// starts above 10 million leaf cells.
TEST(ConversionMemory, RefusesGridsOverTheLimitAndWarnsBeforeHeavyViews)
{
  vtkNew<vtkHDTVoxelizer> filter;
  filter->SetInputData(hdtvtk::MakeSphere());
  filter->SetResolution(128);
  filter->SetLeafGridSize(8);
  filter->Update();
  ASSERT_TRUE(filter->GetVolume());
  vtkNew<vtkHyperTreeGrid> htg;
  vtkHDTConversionOptions options;
  options.MaxDepth = -1;
  const vtkHDTConversionInfo info = vtkHDTToHyperTreeGrid::Convert(*filter->GetVolume(), options, htg);
  options.MemoryLimitBytes = vtkHDTToHyperTreeGrid::EstimatedDisplayBytes(uint64_t(info.Cells)) - 1;
  try
  {
    vtkHDTToHyperTreeGrid::Convert(*filter->GetVolume(), options, htg);
    ADD_FAILURE() << "a grid over the memory limit was built";
  }
  catch (const hdt::Error& e)
  {
    EXPECT_EQ(e.kind(), hdt::ErrorKind::OutOfResources);
    EXPECT_NE(std::string(e.what()).find("Max Depth"), std::string::npos) << e.what();
  }
  options.MaxDepth = 2; // fewer cells: fits
  EXPECT_NO_THROW(vtkHDTToHyperTreeGrid::Convert(*filter->GetVolume(), options, htg));

  vtkHDTConversionInfo heavy;
  heavy.LeafCells = 10000000;
  EXPECT_TRUE(vtkHDTToHyperTreeGrid::DrawingWarning(heavy).empty());
  heavy.LeafCells = 10000001;
  EXPECT_NE(vtkHDTToHyperTreeGrid::DrawingWarning(heavy).find("Max Depth Auto"), std::string::npos);
}
