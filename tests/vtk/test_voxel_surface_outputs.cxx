// The voxel surface as the second output port of vtkHDTVoxelizer and
// vtkHDTReader: a vtkPolyData of quads that is exactly the core's extraction
// (hdt/voxel_surface.hpp, checked against the dense export in hdt_tests),
// following MaxDepth, empty after a failure, beside an unchanged hyper tree grid.
#include "hdt_vtk_test_util.h"

#include "vtkHDTReader.h"
#include "vtkHDTVoxelizer.h"

#include "hdt/hdt_file.hpp"
#include "hdt/volume.hpp"
#include "hdt/voxel_surface.hpp"

#include "vtkCellArray.h"
#include "vtkCellData.h"
#include "vtkCellTypes.h"
#include "vtkDataArray.h"
#include "vtkFieldData.h"
#include "vtkHyperTreeGrid.h"
#include "vtkNew.h"
#include "vtkPoints.h"
#include "vtkPolyData.h"
#include "vtkCompositeDataSet.h"
#include "vtkInformation.h"
#include "vtkMultiBlockDataSet.h"
#include "vtkStringArray.h"
#include "vtkUnsignedCharArray.h"
#include "vtkUnsignedShortArray.h"

#include <gtest/gtest.h>

#include <cstdio>
#include <cstdlib>
#include <string>

namespace
{

// Where the first difference between `surface` and the core's extraction lies ("" if none).
std::string compareWithCore(vtkPolyData* surface, const hdt::Volume& volume, int maxDepth)
{
  hdt::SurfaceOptions options;
  options.maxDepth = maxDepth;
  const hdt::VoxelSurface core = hdt::extractVoxelSurface(volume, options);
  if (!surface)
  {
    return "no vtkPolyData on port 1";
  }
  const vtkIdType quads = vtkIdType(core.quadCount());
  if (surface->GetNumberOfPolys() != quads || surface->GetNumberOfCells() != quads)
  {
    return "cells: " + std::to_string(surface->GetNumberOfCells()) + " vs core quads " +
      std::to_string(quads);
  }
  if (surface->GetNumberOfPoints() != 4 * quads)
  {
    return "points: " + std::to_string(surface->GetNumberOfPoints());
  }
  for (vtkIdType p = 0; p < 4 * quads; ++p)
  {
    double x[3];
    surface->GetPoint(p, x);
    for (int a = 0; a < 3; ++a)
    {
      if (float(x[a]) != core.points[size_t(3 * p + a)])
      {
        return "point " + std::to_string(p) + " differs";
      }
    }
  }
  vtkNew<vtkIdList> ids;
  for (vtkIdType c = 0; c < quads; ++c)
  {
    surface->GetCellPoints(c, ids);
    if (surface->GetCellType(c) != VTK_QUAD || ids->GetNumberOfIds() != 4 || ids->GetId(0) != 4 * c ||
      ids->GetId(3) != 4 * c + 3)
    {
      return "cell " + std::to_string(c) + " is not quad 4c .. 4c + 3";
    }
  }
  auto* states = vtkUnsignedCharArray::SafeDownCast(surface->GetCellData()->GetArray("VoxelState"));
  if (!states || states->GetNumberOfValues() != quads)
  {
    return "no VoxelState cell array of one value a quad";
  }
  for (vtkIdType c = 0; c < quads; ++c)
  {
    if (states->GetValue(c) != core.states[size_t(c)])
    {
      return "VoxelState of cell " + std::to_string(c) + " differs";
    }
  }
  vtkDataArray* labelArray = surface->GetCellData()->GetArray("Label");
  if (core.labels.empty())
  {
    return labelArray ? "a Label array on the surface of an unlabelled volume" : "";
  }
  auto* labels = vtkUnsignedShortArray::SafeDownCast(labelArray);
  if (!labels || labels->GetNumberOfValues() != quads)
  {
    return "no Label cell array (unsigned short) of one value a quad";
  }
  for (vtkIdType c = 0; c < quads; ++c)
  {
    if (labels->GetValue(c) != core.labels[size_t(c)])
    {
      return "Label of cell " + std::to_string(c) + " differs";
    }
  }
  return "";
}

struct Voxelizer
{
  vtkNew<vtkHDTVoxelizer> Filter;
  vtkNew<hdtvtk::MessageLog> Log;
  Voxelizer()
  {
    this->Filter->AddObserver(vtkCommand::ErrorEvent, this->Log);
    this->Filter->AddObserver(vtkCommand::WarningEvent, this->Log);
    this->Filter->SetInputData(hdtvtk::MakeTorus());
    this->Filter->SetResolution(128);
    this->Filter->SetRootGridSize(4);
    this->Filter->SetLeafGridSize(8);
    this->Filter->SetBackend(vtkHDTVoxelizer::BACKEND_CPU);
  }
};

TEST(VoxelSurfaceOutput, VoxelizerPortOneIsTheCoreSurfaceAtEveryMaxDepth)
{
  Voxelizer v;
  ASSERT_EQ(v.Filter->GetNumberOfOutputPorts(), 2);
  for (int depth : { -1, 4, 2, 0 })
  {
    v.Filter->SetMaxDepth(depth);
    v.Filter->Update(1);
    ASSERT_TRUE(v.Log->Errors.empty());
    const auto volume = v.Filter->GetVolume();
    ASSERT_TRUE(volume);
    vtkPolyData* surface = v.Filter->GetSurfaceOutput();
    ASSERT_TRUE(surface);
    EXPECT_GT(surface->GetNumberOfCells(), 0);
    EXPECT_EQ(compareWithCore(surface, *volume, depth), "") << "MaxDepth " << depth;
  }
}

TEST(VoxelSurfaceOutput, VoxelizerPortZeroStaysTheHyperTreeGrid)
{
  Voxelizer v;
  v.Filter->Update(); // all ports
  vtkHyperTreeGrid* htg = v.Filter->GetOutput(0);
  ASSERT_TRUE(htg);
  EXPECT_GT(htg->GetNumberOfCells(), 0);
  ASSERT_TRUE(htg->GetCellData()->GetArray("VoxelState"));
  vtkPolyData* surface = v.Filter->GetSurfaceOutput();
  EXPECT_GT(surface->GetNumberOfCells(), 0);
  // The build statistics come along with the surface.
  EXPECT_TRUE(surface->GetFieldData()->GetAbstractArray("ActiveVoxels"));
  EXPECT_TRUE(surface->GetFieldData()->GetAbstractArray("TimeSurface"));
}

TEST(VoxelSurfaceOutput, VoxelizerFailureEmptiesTheSurface)
{
  Voxelizer v;
  v.Filter->Update();
  ASSERT_GT(v.Filter->GetSurfaceOutput()->GetNumberOfCells(), 0);
  v.Filter->SetResolution(100); // not R * 2^h * L
  v.Filter->Update();
  EXPECT_FALSE(v.Log->Errors.empty());
  EXPECT_EQ(v.Filter->GetSurfaceOutput()->GetNumberOfCells(), 0);
  EXPECT_EQ(v.Filter->GetSurfaceOutput()->GetNumberOfPoints(), 0);
}

TEST(VoxelSurfaceOutput, ReaderGivesTheHyperTreeGridAndTheSurface)
{
  Voxelizer v;
  v.Filter->Update();
  const auto volume = v.Filter->GetVolume();
  ASSERT_TRUE(volume);
  const char* tmp = std::getenv("HDT_TEST_TMPDIR");
  const std::string path = std::string(tmp ? tmp : "/tmp") + "/voxel_surface_reader.hdt";
  hdt::writeHdt(*volume, path);

  vtkNew<vtkHDTReader> reader;
  vtkNew<hdtvtk::MessageLog> log;
  reader->AddObserver(vtkCommand::ErrorEvent, log);
  reader->SetFileName(path.c_str());
  ASSERT_EQ(reader->GetNumberOfOutputPorts(), 2);
  for (int depth : { -1, 3 })
  {
    reader->SetMaxDepth(depth);
    v.Filter->SetMaxDepth(depth);
    reader->Update();
    v.Filter->Update();
    ASSERT_TRUE(log->Errors.empty());
    EXPECT_EQ(reader->GetOutput()->GetNumberOfCells(), v.Filter->GetOutput()->GetNumberOfCells());
    EXPECT_EQ(compareWithCore(reader->GetSurfaceOutput(), *volume, depth), "") << "MaxDepth " << depth;
  }

  reader->SetFileName((path + ".missing").c_str());
  reader->Update();
  EXPECT_FALSE(log->Errors.empty());
  EXPECT_EQ(reader->GetSurfaceOutput()->GetNumberOfCells(), 0);
  std::remove(path.c_str());
}

// Label By Block on two named blocks that touch: the surface carries the
// core's labels (checked against the dense label export in hdt_tests) and the
// label names, from the voxelizer and from the reader of its .hdt file.
TEST(VoxelSurfaceOutput, LabelledBuildsCarryTheLabelOnBothPorts)
{
  vtkNew<vtkMultiBlockDataSet> blocks;
  blocks->SetBlock(0, hdtvtk::MakeSphere(32, 0.5, -0.3, 0, 0));
  blocks->SetBlock(1, hdtvtk::MakeSphere(32, 0.4, 0.4, 0, 0));
  blocks->GetMetaData(0u)->Set(vtkCompositeDataSet::NAME(), "left");
  blocks->GetMetaData(1u)->Set(vtkCompositeDataSet::NAME(), "right");
  Voxelizer v;
  v.Filter->SetInputData(blocks);
  v.Filter->SetResolution(64);
  v.Filter->SetRootGridSize(2);
  v.Filter->SetLabelBy(vtkHDTVoxelizer::LABEL_BLOCK);
  const char* tmp = std::getenv("HDT_TEST_TMPDIR");
  const std::string path = std::string(tmp ? tmp : "/tmp") + "/voxel_surface_labels.hdt";
  vtkNew<vtkHDTReader> reader;
  reader->SetFileName(path.c_str());
  for (int depth : { -1, 4, 2 })
  {
    v.Filter->SetMaxDepth(depth);
    v.Filter->Update();
    ASSERT_TRUE(v.Log->Errors.empty());
    const auto volume = v.Filter->GetVolume();
    ASSERT_TRUE(volume && !volume->labels.empty());
    vtkPolyData* surface = v.Filter->GetSurfaceOutput();
    EXPECT_EQ(compareWithCore(surface, *volume, depth), "") << "MaxDepth " << depth;
    auto* names = vtkStringArray::SafeDownCast(surface->GetFieldData()->GetAbstractArray("LabelNames"));
    ASSERT_TRUE(names);
    ASSERT_EQ(names->GetNumberOfValues(), 2);
    EXPECT_EQ(names->GetValue(0), "left");
    EXPECT_EQ(names->GetValue(1), "right");
    double range[2];
    surface->GetCellData()->GetArray("Label")->GetRange(range);
    EXPECT_EQ(range[0], 1);
    EXPECT_EQ(range[1], 2);

    hdt::writeHdt(*volume, path);
    reader->SetMaxDepth(depth);
    reader->Modified();
    reader->Update();
    EXPECT_EQ(compareWithCore(reader->GetSurfaceOutput(), *volume, depth), "") << "reader, MaxDepth " << depth;
  }
  std::remove(path.c_str());
}

} // namespace
