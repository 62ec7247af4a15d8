// vtkHDTVoxelizer as a VTK filter: inputs it must take (strips, quads, concave
// polygons, composites), inputs it must refuse cleanly, backends, caching.
#include "hdt_vtk_test_util.h"

#include "vtkHDTMeshConversion.h"
#include "vtkHDTVoxelizer.h"

#include "hdt/builder.hpp"
#include "hdt/mesh.hpp"
#include "hdt/volume.hpp"

#include "vtkAppendPolyData.h"
#include "vtkCallbackCommand.h"
#include "vtkCellArray.h"
#include "vtkCellData.h"
#include "vtkCubeSource.h"
#include "vtkFieldData.h"
#include "vtkHyperTreeGrid.h"
#include "vtkImageData.h"
#include "vtkInformation.h"
#include "vtkMultiBlockDataSet.h"
#include "vtkNew.h"
#include "vtkPoints.h"
#include "vtkPolyData.h"
#include "vtkSphereSource.h"
#include "vtkStringArray.h"
#include "vtkStripper.h"
#include "vtkUnsignedCharArray.h"

#include <gtest/gtest.h>

#include <cmath>
#include <limits>

namespace
{

std::string joined(const std::vector<std::string>& v)
{
  std::string s;
  for (const auto& x : v)
  {
    s += "\n  " + x;
  }
  return s;
}

bool anyContains(const std::vector<std::string>& v, const std::string& needle)
{
  for (const auto& x : v)
  {
    if (x.find(needle) != std::string::npos)
    {
      return true;
    }
  }
  return false;
}

// A filter with its messages recorded (so they are not printed) and small settings.
struct Harness
{
  vtkNew<vtkHDTVoxelizer> Filter;
  vtkNew<hdtvtk::MessageLog> Log;
  Harness()
  {
    this->Filter->AddObserver(vtkCommand::ErrorEvent, this->Log);
    this->Filter->AddObserver(vtkCommand::WarningEvent, this->Log);
    this->Filter->SetResolution(64);
    this->Filter->SetRootGridSize(4);
    this->Filter->SetLeafGridSize(8);
  }
  vtkHyperTreeGrid* Run(vtkDataObject* input)
  {
    this->Log->Clear();
    this->Filter->SetInputData(input);
    this->Filter->Update();
    return this->Filter->GetOutput();
  }
};

std::vector<uint8_t> statesOf(vtkHyperTreeGrid* htg)
{
  auto* a = vtkUnsignedCharArray::SafeDownCast(htg->GetCellData()->GetArray("VoxelState"));
  if (!a)
  {
    return {};
  }
  return std::vector<uint8_t>(a->GetPointer(0), a->GetPointer(0) + a->GetNumberOfTuples());
}

std::string fieldString(vtkHyperTreeGrid* htg, const char* name)
{
  auto* a = vtkStringArray::SafeDownCast(htg->GetFieldData()->GetAbstractArray(name));
  return a ? a->GetValue(0) : std::string();
}

std::string backendOf(vtkHyperTreeGrid* htg)
{
  return fieldString(htg, "Backend");
}

// A sphere without its cap beyond 120 degrees: open.
vtkSmartPointer<vtkPolyData> openSphere()
{
  vtkNew<vtkSphereSource> sphere;
  sphere->SetThetaResolution(32);
  sphere->SetPhiResolution(24);
  sphere->SetEndPhi(120.0);
  sphere->Update();
  return sphere->GetOutput();
}

vtkSmartPointer<vtkPolyData> linesOnly()
{
  vtkNew<vtkPoints> points;
  points->InsertNextPoint(0, 0, 0);
  points->InsertNextPoint(1, 0, 0);
  points->InsertNextPoint(1, 1, 0);
  vtkNew<vtkCellArray> lines;
  const vtkIdType line[3] = { 0, 1, 2 };
  lines->InsertNextCell(3, line);
  vtkNew<vtkCellArray> verts;
  verts->InsertNextCell(1, line);
  auto pd = vtkSmartPointer<vtkPolyData>::New();
  pd->SetPoints(points);
  pd->SetLines(lines);
  pd->SetVerts(verts);
  return pd;
}

// ---- inputs that must be refused ---------------------------------------------

TEST(VoxelizerBadInput, EmptyPolyDataIsAnErrorAndEmptyOutput)
{
  Harness h;
  vtkNew<vtkPolyData> empty;
  vtkHyperTreeGrid* out = h.Run(empty);
  ASSERT_EQ(h.Log->Errors.size(), 1u);
  EXPECT_TRUE(anyContains(h.Log->Errors, "empty")) << joined(h.Log->Errors);
  EXPECT_EQ(out->GetNumberOfCells(), 0);
  EXPECT_FALSE(h.Filter->GetVolume());
}

TEST(VoxelizerBadInput, NaNPointIsAnError)
{
  Harness h;
  vtkSmartPointer<vtkPolyData> sphere = hdtvtk::MakeSphere(16);
  sphere->GetPoints()->SetPoint(5, std::numeric_limits<double>::quiet_NaN(), 0, 0);
  vtkHyperTreeGrid* out = h.Run(sphere);
  ASSERT_EQ(h.Log->Errors.size(), 1u);
  EXPECT_TRUE(anyContains(h.Log->Errors, "non-finite")) << joined(h.Log->Errors);
  EXPECT_EQ(out->GetNumberOfCells(), 0);
}

TEST(VoxelizerBadInput, InvalidResolutionNamesTheValidOnes)
{
  Harness h;
  h.Filter->SetResolution(100); // R = 4, L = 8: valid are 32, 64, 128, ...
  vtkHyperTreeGrid* out = h.Run(hdtvtk::MakeSphere(16));
  ASSERT_EQ(h.Log->Errors.size(), 1u);
  EXPECT_TRUE(anyContains(h.Log->Errors, "64 or 128")) << joined(h.Log->Errors);
  EXPECT_EQ(out->GetNumberOfCells(), 0);

  for (int bad : { 0, -64, 70000 })
  {
    h.Filter->SetResolution(bad);
    out = h.Run(hdtvtk::MakeSphere(16));
    EXPECT_EQ(h.Log->Errors.size(), 1u) << bad;
    EXPECT_EQ(out->GetNumberOfCells(), 0) << bad;
  }
  h.Filter->SetResolution(64);
  h.Filter->SetLeafGridSize(12);
  h.Run(hdtvtk::MakeSphere(16));
  EXPECT_TRUE(anyContains(h.Log->Errors, "leaf grid size")) << joined(h.Log->Errors);
  h.Filter->SetLeafGridSize(8);
  h.Filter->SetRootGridSize(0);
  h.Run(hdtvtk::MakeSphere(16));
  EXPECT_EQ(h.Log->Errors.size(), 1u);
}

TEST(VoxelizerBadInput, LinesOnlyWarnsOnceAndGivesEmptyOutput)
{
  Harness h;
  vtkHyperTreeGrid* out = h.Run(linesOnly());
  EXPECT_TRUE(h.Log->Errors.empty()) << joined(h.Log->Errors);
  ASSERT_EQ(h.Log->Warnings.size(), 1u);
  EXPECT_TRUE(anyContains(h.Log->Warnings, "1 vertex and 1 line")) << joined(h.Log->Warnings);
  EXPECT_EQ(out->GetNumberOfCells(), 0);
}

TEST(VoxelizerBadInput, LinesBesidePolygonsWarnOnceAndAreIgnored)
{
  Harness h;
  vtkNew<vtkAppendPolyData> append;
  append->AddInputData(hdtvtk::MakeSphere(16));
  append->AddInputData(linesOnly());
  append->Update();
  vtkHyperTreeGrid* out = h.Run(append->GetOutput());
  EXPECT_TRUE(h.Log->Errors.empty()) << joined(h.Log->Errors);
  EXPECT_EQ(h.Log->Warnings.size(), 1u) << joined(h.Log->Warnings);
  EXPECT_GT(out->GetNumberOfCells(), 0);
}

TEST(VoxelizerBadInput, NegativeMaxDepthBelowMinusOneIsAnError)
{
  Harness h;
  h.Filter->SetMaxDepth(-3);
  vtkHyperTreeGrid* out = h.Run(hdtvtk::MakeSphere(16));
  ASSERT_EQ(h.Log->Errors.size(), 1u);
  EXPECT_TRUE(anyContains(h.Log->Errors, "MaxDepth")) << joined(h.Log->Errors);
  EXPECT_EQ(out->GetNumberOfCells(), 0);
}

TEST(VoxelizerBadInput, NonPolyDataBlocksAreIgnoredWithAWarning)
{
  Harness h;
  vtkNew<vtkMultiBlockDataSet> mb;
  vtkNew<vtkImageData> image;
  image->SetDimensions(2, 2, 2);
  mb->SetBlock(0, image);
  h.Run(mb);
  EXPECT_EQ(h.Log->Errors.size(), 1u) << joined(h.Log->Errors);
  EXPECT_TRUE(anyContains(h.Log->Warnings, "vtkImageData")) << joined(h.Log->Warnings);
  mb->SetBlock(1, hdtvtk::MakeSphere(16));
  vtkHyperTreeGrid* out = h.Run(mb);
  EXPECT_TRUE(h.Log->Errors.empty()) << joined(h.Log->Errors);
  EXPECT_EQ(h.Log->Warnings.size(), 1u);
  EXPECT_GT(out->GetNumberOfCells(), 0);
}

// ---- backends ------------------------------------------------------------------

TEST(VoxelizerBackend, AutoWorksAndSaysWhichDriverRan)
{
  Harness h;
  h.Filter->SetBackend(vtkHDTVoxelizer::BACKEND_AUTO);
  vtkHyperTreeGrid* out = h.Run(hdtvtk::MakeSphere(16));
  EXPECT_TRUE(h.Log->Errors.empty()) << joined(h.Log->Errors);
  ASSERT_GT(out->GetNumberOfCells(), 0);
  if (hdt::cudaAvailable())
  {
    EXPECT_EQ(backendOf(out), "cuda");
  }
  else
  {
    EXPECT_EQ(backendOf(out), "cpu");
    EXPECT_TRUE(h.Log->Warnings.empty()) << joined(h.Log->Warnings);
  }
}

TEST(VoxelizerBackend, CudaWithoutADeviceIsAClearError)
{
  if (hdt::cudaAvailable())
  {
    GTEST_SKIP() << "a CUDA device is usable here; this test is for CPU-only builds/machines";
  }
  Harness h;
  h.Filter->SetBackend(vtkHDTVoxelizer::BACKEND_CUDA);
  vtkHyperTreeGrid* out = h.Run(hdtvtk::MakeSphere(16));
  ASSERT_EQ(h.Log->Errors.size(), 1u);
  EXPECT_TRUE(anyContains(h.Log->Errors, "CUDA")) << joined(h.Log->Errors);
  EXPECT_EQ(out->GetNumberOfCells(), 0);
}

TEST(VoxelizerBackend, CpuAndAutoGiveTheSameVolume)
{
  Harness a, b;
  a.Filter->SetBackend(vtkHDTVoxelizer::BACKEND_CPU);
  b.Filter->SetBackend(vtkHDTVoxelizer::BACKEND_AUTO);
  vtkSmartPointer<vtkPolyData> torus = hdtvtk::MakeTorus();
  a.Filter->SetResolution(128);
  b.Filter->SetResolution(128);
  EXPECT_EQ(statesOf(a.Run(torus)), statesOf(b.Run(torus)));
}

// ---- inputs that must be taken ---------------------------------------------------

TEST(VoxelizerInput, StripsGiveTheSameVolumeAsTriangles)
{
  vtkSmartPointer<vtkPolyData> sphere = hdtvtk::MakeSphere(24);
  vtkNew<vtkStripper> stripper;
  stripper->SetInputData(sphere);
  stripper->Update();
  ASSERT_GT(stripper->GetOutput()->GetNumberOfStrips(), 0);
  Harness a, b;
  const std::vector<uint8_t> tri = statesOf(a.Run(sphere));
  const std::vector<uint8_t> strips = statesOf(b.Run(stripper->GetOutput()));
  EXPECT_FALSE(tri.empty());
  EXPECT_EQ(tri, strips);
  EXPECT_TRUE(a.Log->Warnings.empty() && b.Log->Warnings.empty());
}

TEST(VoxelizerInput, MultiBlockIsOneMesh)
{
  vtkSmartPointer<vtkPolyData> s1 = hdtvtk::MakeSphere(24, 0.5, 0, 0, 0);
  vtkSmartPointer<vtkPolyData> s2 = hdtvtk::MakeSphere(24, 0.3, 1.2, 0, 0);
  vtkNew<vtkAppendPolyData> append;
  append->AddInputData(s1);
  append->AddInputData(s2);
  append->Update();
  vtkNew<vtkMultiBlockDataSet> inner, outer;
  inner->SetBlock(0, s2);
  outer->SetBlock(0, s1);
  outer->SetBlock(1, inner); // nested
  Harness a, b;
  a.Filter->SetResolution(128);
  b.Filter->SetResolution(128);
  const std::vector<uint8_t> appended = statesOf(a.Run(append->GetOutput()));
  const std::vector<uint8_t> blocks = statesOf(b.Run(outer));
  EXPECT_FALSE(appended.empty());
  EXPECT_EQ(appended, blocks);
  EXPECT_TRUE(b.Log->Errors.empty()) << joined(b.Log->Errors);
}

// Quads (a cube) and a concave hexagon prism (ear-cut caps): the solid's
// volume in voxels matches the analytic volume.
double solidVoxels(vtkHDTVoxelizer* f)
{
  const hdt::Statistics& s = f->GetVolume()->stats;
  return double(s.insideVoxels) + 0.5 * double(s.activeVoxels);
}

TEST(VoxelizerInput, QuadsAndConcavePolygons)
{
  {
    vtkNew<vtkCubeSource> cube; // six quads
    cube->SetBounds(0, 1, 0, 0.5, 0, 0.75);
    cube->Update();
    Harness h;
    h.Filter->SetResolution(128);
    h.Run(cube->GetOutput());
    ASSERT_TRUE(h.Filter->GetVolume());
    const double vs = h.Filter->GetVolume()->grid.voxelSize;
    EXPECT_NEAR(solidVoxels(h.Filter) / (0.5 * 0.75 / (vs * vs * vs)), 1.0, 0.02);
  }
  {
    // An L-shaped prism: the caps are concave hexagons, which a fan would get wrong.
    const double xy[6][2] = { { 0, 0 }, { 1, 0 }, { 1, 0.4 }, { 0.4, 0.4 }, { 0.4, 1 }, { 0, 1 } };
    vtkNew<vtkPoints> points;
    for (double z : { 0.0, 0.5 })
    {
      for (const auto& p : xy)
      {
        points->InsertNextPoint(p[0], p[1], z);
      }
    }
    vtkNew<vtkCellArray> polys;
    // Start the caps at the reflex corner's neighbour so that a fan from
    // vertex 0 would spill outside the L.
    const vtkIdType bottom[6] = { 2, 1, 0, 5, 4, 3 };
    const vtkIdType top[6] = { 8, 9, 10, 11, 6, 7 };
    polys->InsertNextCell(6, bottom);
    polys->InsertNextCell(6, top);
    for (vtkIdType i = 0; i < 6; ++i)
    {
      const vtkIdType j = (i + 1) % 6;
      const vtkIdType quad[4] = { i, j, j + 6, i + 6 };
      polys->InsertNextCell(4, quad);
    }
    vtkNew<vtkPolyData> prism;
    prism->SetPoints(points);
    prism->SetPolys(polys);
    Harness h;
    h.Filter->SetResolution(128);
    h.Run(prism);
    ASSERT_TRUE(h.Filter->GetVolume()) << joined(h.Log->Errors);
    EXPECT_TRUE(h.Filter->GetVolume()->closedMesh);
    const double vs = h.Filter->GetVolume()->grid.voxelSize;
    const double area = 1.0 - 0.6 * 0.6;
    EXPECT_NEAR(solidVoxels(h.Filter) / (area * 0.5 / (vs * vs * vs)), 1.0, 0.02);
  }
}

TEST(VoxelizerInput, MeshConversionCounts)
{
  hdt::TriangleMesh mesh;
  vtkHDTMeshConversionInfo info;
  vtkNew<vtkCubeSource> cube;
  cube->Update();
  vtkHDTMeshConversion::AppendPolyData(cube->GetOutput(), mesh, info);
  EXPECT_EQ(info.Triangles, 12);
  EXPECT_EQ(mesh.triangleCount(), 12u);
  EXPECT_EQ(mesh.pointCount(), size_t(cube->GetOutput()->GetNumberOfPoints()));
  vtkHDTMeshConversion::AppendPolyData(linesOnly(), mesh, info);
  EXPECT_EQ(info.LineCells, 1);
  EXPECT_EQ(info.VertexCells, 1);
  EXPECT_EQ(mesh.triangleCount(), 12u);
}

// ---- pipeline behaviour ------------------------------------------------------------

TEST(VoxelizerPipeline, RebuildsOnlyWhenNeeded)
{
  Harness h;
  vtkSmartPointer<vtkPolyData> sphere = hdtvtk::MakeSphere(16);
  h.Run(sphere);
  auto first = h.Filter->GetVolume();
  ASSERT_TRUE(first);
  EXPECT_FALSE(h.Filter->GetLastRunReusedVolume());
  EXPECT_GT(h.Filter->GetLastVoxelizationTime(), 0.0);

  h.Filter->SetMaxDepth(1);
  h.Filter->Update();
  EXPECT_TRUE(h.Filter->GetLastRunReusedVolume());
  EXPECT_EQ(h.Filter->GetVolume(), first);

  h.Filter->SetSurfaceOnly(true); // a build property
  h.Filter->Update();
  EXPECT_FALSE(h.Filter->GetLastRunReusedVolume());
  EXPECT_NE(h.Filter->GetVolume(), first);

  auto second = h.Filter->GetVolume();
  sphere->GetPoints()->SetPoint(0, 0.1, 0.1, 0.9); // the input changes
  sphere->GetPoints()->Modified();
  h.Filter->Update();
  EXPECT_FALSE(h.Filter->GetLastRunReusedVolume());
  EXPECT_NE(h.Filter->GetVolume(), second);
}

// Aborting through the progress callback ends quietly with an empty output.
class AbortOnProgress : public vtkCommand
{
public:
  static AbortOnProgress* New() { return new AbortOnProgress; }
  void Execute(vtkObject* caller, unsigned long, void*) override
  {
    static_cast<vtkAlgorithm*>(caller)->SetAbortExecute(1);
  }
};

TEST(VoxelizerPipeline, AbortGivesEmptyOutputWithoutError)
{
  Harness h;
  vtkNew<AbortOnProgress> abort;
  h.Filter->AddObserver(vtkCommand::ProgressEvent, abort);
  vtkHyperTreeGrid* out = h.Run(hdtvtk::MakeSphere(16));
  EXPECT_TRUE(h.Log->Errors.empty()) << joined(h.Log->Errors);
  EXPECT_EQ(out->GetNumberOfCells(), 0);
  EXPECT_FALSE(h.Filter->GetVolume());
}

// An open mesh under Auto takes the winding number after the build's phases:
// the filter shows that pass as its own progress text, and an abort there
// ends quietly too.
class AbortInWindingPass : public vtkCommand
{
public:
  static AbortInWindingPass* New() { return new AbortInWindingPass; }
  void Execute(vtkObject* caller, unsigned long, void*) override
  {
    auto* filter = static_cast<vtkAlgorithm*>(caller);
    const std::string text = filter->GetProgressText() ? filter->GetProgressText() : "";
    if (text == "inside test: winding number")
    {
      this->Seen = true;
      filter->SetAbortExecute(1);
    }
  }
  bool Seen = false;
};

TEST(VoxelizerPipeline, AbortInTheWindingPassGivesEmptyOutput)
{
  Harness h;
  vtkNew<AbortInWindingPass> abort;
  h.Filter->AddObserver(vtkCommand::ProgressEvent, abort);
  vtkHyperTreeGrid* out = h.Run(openSphere());
  EXPECT_TRUE(abort->Seen);
  EXPECT_TRUE(h.Log->Errors.empty()) << joined(h.Log->Errors);
  EXPECT_EQ(out->GetNumberOfCells(), 0);
  EXPECT_FALSE(h.Filter->GetVolume());
}

// The aborted run's empty outputs stand until the filter changes: the next
// requests (ParaView updates each output port in turn, then renders) must not
// start the build again; a changed property builds again once the flag is
// cleared (the plugin's Abort button clears it when the run ends).
TEST(VoxelizerPipeline, AbortedOutputsStandUntilAChange)
{
  Harness h;
  int runs = 0;
  vtkNew<vtkCallbackCommand> countRuns;
  countRuns->SetClientData(&runs);
  countRuns->SetCallback([](vtkObject*, unsigned long, void* n, void*) { ++*static_cast<int*>(n); });
  h.Filter->AddObserver(vtkCommand::StartEvent, countRuns);
  h.Filter->SetInputData(hdtvtk::MakeSphere(16));
  auto updateEachPort = [&h]() {
    h.Filter->Update(0);
    h.Filter->Update(1);
  };
  auto cells = [&h](int port) {
    return vtkDataSet::SafeDownCast(h.Filter->GetOutputDataObject(port))
      ? vtkDataSet::SafeDownCast(h.Filter->GetOutputDataObject(port))->GetNumberOfCells()
      : vtkHyperTreeGrid::SafeDownCast(h.Filter->GetOutputDataObject(port))->GetNumberOfCells();
  };
  // As the plugin's Abort button does: the flag is set during the run and
  // cleared when the run ends (EndEvent; SetAbortExecute also marks the
  // algorithm modified, which is already older than the outputs then).
  vtkNew<AbortOnProgress> abort;
  const unsigned long abortId = h.Filter->AddObserver(vtkCommand::ProgressEvent, abort);
  vtkNew<vtkCallbackCommand> clearOnEnd;
  clearOnEnd->SetCallback(
    [](vtkObject* caller, unsigned long, void*, void*) { static_cast<vtkAlgorithm*>(caller)->SetAbortExecute(0); });
  const unsigned long clearId = h.Filter->AddObserver(vtkCommand::EndEvent, clearOnEnd);
  updateEachPort();
  h.Filter->RemoveObserver(abortId);
  h.Filter->RemoveObserver(clearId);
  ASSERT_FALSE(h.Filter->GetAbortExecute());
  updateEachPort();
  EXPECT_EQ(runs, 1);
  EXPECT_EQ(cells(0), 0);
  EXPECT_EQ(cells(1), 0);
  EXPECT_TRUE(h.Log->Errors.empty()) << joined(h.Log->Errors);

  h.Filter->SetResolution(h.Filter->GetResolution() * 2);
  updateEachPort();
  updateEachPort();
  EXPECT_EQ(runs, 2);
  EXPECT_GT(cells(0), 0);
  EXPECT_GT(cells(1), 0);
}

} // namespace

// Issue 12, defect 9: a closed mesh with every triangle twice has nothing
// inside (the copies cancel in the parity); the filter says so, as the CLI
// does (hdt::buildWarnings), and a single copy gives no warning.
TEST(VoxelizerWarnings, DoubledClosedMeshIsReported)
{
  Harness once;
  vtkHyperTreeGrid* single = once.Run(hdtvtk::MakeSphere(16));
  EXPECT_TRUE(once.Log->Errors.empty()) << joined(once.Log->Errors);
  EXPECT_TRUE(once.Log->Warnings.empty()) << joined(once.Log->Warnings);
  EXPECT_GT(single->GetNumberOfCells(), 0);

  Harness twice;
  vtkNew<vtkAppendPolyData> append;
  append->AddInputData(hdtvtk::MakeSphere(16));
  append->AddInputData(hdtvtk::MakeSphere(16));
  append->Update();
  twice.Run(append->GetOutput());
  EXPECT_TRUE(twice.Log->Errors.empty()) << joined(twice.Log->Errors);
  EXPECT_TRUE(anyContains(twice.Log->Warnings, "repeat another triangle's corners")) << joined(twice.Log->Warnings);
  EXPECT_TRUE(anyContains(twice.Log->Warnings, "no voxel is inside")) << joined(twice.Log->Warnings);
}

// A labelled build of two blocks logs how its parts were split and built:
// information, not a warning (ParaView shows warnings in a window of their own).
TEST(VoxelizerWarnings, LabelledBuildLogIsNoWarning)
{
  vtkNew<vtkMultiBlockDataSet> blocks;
  blocks->SetBlock(0, hdtvtk::MakeSphere(24, 0.5, 0, 0, 0));
  blocks->SetBlock(1, hdtvtk::MakeSphere(24, 0.3, 1.2, 0, 0));
  Harness h;
  h.Filter->SetBackend(vtkHDTVoxelizer::BACKEND_CPU);
  h.Filter->SetLabelBy(vtkHDTVoxelizer::LABEL_BLOCK);
  vtkHyperTreeGrid* out = h.Run(blocks);
  ASSERT_NE(out->GetCellData()->GetArray("Label"), nullptr);
  EXPECT_TRUE(h.Log->Errors.empty()) << joined(h.Log->Errors);
  EXPECT_TRUE(h.Log->Warnings.empty()) << joined(h.Log->Warnings);
}

// Issue 16: the inside test defaults to Auto, which decides an open mesh by the
// winding number and a closed one by exact parity (the same states as asking
// for them), with no open-mesh warning; the field data say which ran and why.
TEST(VoxelizerInsideTest, DefaultIsAutoWindingWhenOpenParityWhenClosed)
{
  Harness automatic;
  EXPECT_EQ(automatic.Filter->GetInsideTest(), vtkHDTVoxelizer::INSIDE_TEST_AUTO);
  const auto openMesh = openSphere();
  vtkHyperTreeGrid* open = automatic.Run(openMesh);
  EXPECT_TRUE(automatic.Log->Errors.empty()) << joined(automatic.Log->Errors);
  EXPECT_FALSE(anyContains(automatic.Log->Warnings, "Parity inside test")) << joined(automatic.Log->Warnings);
  EXPECT_EQ(fieldString(open, "InsideTest"), "winding");
  EXPECT_EQ(fieldString(open, "InsideTestReason"), "Auto: the mesh is open, winding number");
  const std::vector<uint8_t> openStates = statesOf(open);

  Harness winding;
  winding.Filter->SetInsideTest(vtkHDTVoxelizer::INSIDE_TEST_WINDING);
  EXPECT_EQ(statesOf(winding.Run(openMesh)), openStates);
  Harness parity;
  parity.Filter->SetInsideTest(vtkHDTVoxelizer::INSIDE_TEST_PARITY);
  vtkHyperTreeGrid* openParity = parity.Run(openMesh);
  EXPECT_EQ(fieldString(openParity, "InsideTest"), "parity");
  EXPECT_TRUE(anyContains(parity.Log->Warnings, "Parity inside test was asked for")) << joined(parity.Log->Warnings);

  const auto closedMesh = hdtvtk::MakeSphere(16);
  vtkHyperTreeGrid* closed = automatic.Run(closedMesh);
  EXPECT_EQ(fieldString(closed, "InsideTest"), "parity");
  EXPECT_EQ(fieldString(closed, "InsideTestReason"), "Auto: the mesh is closed, exact ray parity");
  const std::vector<uint8_t> closedStates = statesOf(closed);
  EXPECT_FALSE(closedStates.empty());
  EXPECT_EQ(statesOf(parity.Run(closedMesh)), closedStates);
}
