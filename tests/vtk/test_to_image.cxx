// HDT To Image (vtkHDTToImage) and the volume handle (vtkHDTVolumeHandle):
// the image equals the dense export on its region, for the voxelizer's and the
// reader's outputs, through SetInputConnection and SetInputData; the writer
// finds the volume without a pipeline walk (SetInputData works); refusals.
#include "hdt_vtk_test_util.h"

#include "vtkHDTReader.h"
#include "vtkHDTToImage.h"
#include "vtkHDTVoxelizer.h"
#include "vtkHDTWriter.h"

#include "hdt/region.hpp"
#include "hdt/volume.hpp"

#include "vtkCommand.h"
#include "vtkHyperTreeGrid.h"
#include "vtkImageData.h"
#include "vtkNew.h"
#include "vtkPointData.h"
#include "vtkPolyData.h"
#include "vtkUnsignedCharArray.h"

#include <gtest/gtest.h>

#include <csignal>
#include <cstdio>
#include <fstream>
#include <iterator>
#include <string>
#include <vector>

#include <dirent.h>
#include <sys/resource.h>
#include <sys/stat.h>

namespace
{
vtkSmartPointer<vtkHDTVoxelizer> Voxelized(int resolution)
{
  auto filter = vtkSmartPointer<vtkHDTVoxelizer>::New();
  filter->SetInputData(hdtvtk::MakeTorus());
  filter->SetResolution(resolution);
  filter->SetRootGridSize(4);
  filter->SetLeafGridSize(8);
  filter->SetBackend(vtkHDTVoxelizer::BACKEND_CPU);
  filter->SetMaxDepth(2); // the image ignores the grid's display options
  filter->Update();
  return filter;
}

std::vector<uint8_t> ImageStates(vtkImageData* image)
{
  auto* array = vtkUnsignedCharArray::SafeDownCast(image->GetPointData()->GetArray("VoxelState"));
  if (!array)
  {
    return {};
  }
  return std::vector<uint8_t>(array->GetPointer(0), array->GetPointer(0) + array->GetNumberOfValues());
}

// The dense export restricted to [lo, hi) per axis (level 0).
std::vector<uint8_t> DenseBox(const hdt::Volume& v, const int lo[3], const int hi[3])
{
  const std::vector<uint8_t> dense = hdtvtk::DenseStates(v);
  const int n = v.grid.resolution;
  std::vector<uint8_t> out;
  for (int z = lo[2]; z < hi[2]; ++z)
    for (int y = lo[1]; y < hi[1]; ++y)
      for (int x = lo[0]; x < hi[0]; ++x)
        out.push_back(dense[size_t(x) + size_t(n) * (size_t(y) + size_t(n) * size_t(z))]);
  return out;
}

void ExpectRegionMatchesDense(vtkHDTToImage* toImage, const hdt::Volume& v, const std::string& what)
{
  SCOPED_TRACE(what);
  const hdt::GridSpec& g = v.grid;
  // Whole grid, level 0: the dense export itself, at the voxel centres.
  toImage->SetLevel(0);
  toImage->UseRegionOff();
  toImage->Update();
  vtkImageData* image = toImage->GetOutput();
  int dims[3];
  image->GetDimensions(dims);
  EXPECT_EQ(dims[0], g.resolution);
  EXPECT_EQ(dims[2], g.resolution);
  EXPECT_DOUBLE_EQ(image->GetOrigin()[1], g.origin[1] + 0.5 * g.voxelSize);
  EXPECT_DOUBLE_EQ(image->GetSpacing()[0], g.voxelSize);
  EXPECT_EQ(ImageStates(image), hdtvtk::DenseStates(v));

  // A box in world coordinates: voxels [3, 20) x [10, 31) x [0, 17).
  const int lo[3] = { 3, 10, 0 }, hi[3] = { 20, 31, 17 };
  toImage->UseRegionOn();
  toImage->SetRegionOrigin(g.origin[0] + (lo[0] + 0.25) * g.voxelSize,
    g.origin[1] + (lo[1] + 0.5) * g.voxelSize, g.origin[2] - 5 * g.voxelSize);
  toImage->SetRegionSize((hi[0] - lo[0] - 0.5) * g.voxelSize, (hi[1] - lo[1] - 1) * g.voxelSize,
    (hi[2] + 5 - 0.5) * g.voxelSize);
  toImage->Update();
  image->GetDimensions(dims);
  EXPECT_EQ(dims[0], hi[0] - lo[0]);
  EXPECT_EQ(dims[1], hi[1] - lo[1]);
  EXPECT_EQ(dims[2], hi[2] - lo[2]);
  EXPECT_EQ(ImageStates(image), DenseBox(v, lo, hi));

  // Coarsened: the core's coarseStates on the aligned box (tested against brute force there).
  toImage->SetLevel(2);
  toImage->Update();
  hdt::VoxelBox box;
  for (int a = 0; a < 3; ++a)
  {
    box.lo[a] = lo[a];
    box.hi[a] = hi[a];
  }
  box = hdt::alignToBlocks(v, box, 2);
  EXPECT_EQ(ImageStates(toImage->GetOutput()), hdt::coarseStates(v, box, 2));
  EXPECT_DOUBLE_EQ(toImage->GetOutput()->GetSpacing()[2], 4 * g.voxelSize);
}
} // namespace

TEST(ToImage, VoxelizerOutputMatchesDenseExport)
{
  vtkSmartPointer<vtkHDTVoxelizer> vox = Voxelized(64);
  ASSERT_TRUE(vox->GetVolume());
  vtkNew<vtkHDTToImage> toImage;
  toImage->SetInputConnection(vox->GetOutputPort());
  ExpectRegionMatchesDense(toImage, *vox->GetVolume(), "SetInputConnection");

  // A pure-VTK pipeline with SetInputData finds the same volume.
  vtkNew<vtkHDTToImage> fromData;
  fromData->SetInputData(vox->GetOutput());
  ExpectRegionMatchesDense(fromData, *vox->GetVolume(), "SetInputData");
}

TEST(ToImage, ReaderOutputAndWriterWithSetInputData)
{
  vtkSmartPointer<vtkHDTVoxelizer> vox = Voxelized(64);
  const std::string path = ::testing::TempDir() + "to_image.hdt";
  std::remove(path.c_str());
  // The writer takes the volume through the field-data handle: SetInputData works.
  vtkNew<vtkHDTWriter> writer;
  writer->SetInputData(vox->GetOutput());
  writer->SetFileName(path.c_str());
  writer->Write();
  ASSERT_EQ(writer->GetErrorCode(), 0u);

  vtkNew<vtkHDTReader> reader;
  reader->SetFileName(path.c_str());
  reader->Update();
  ASSERT_TRUE(reader->GetVolume());
  vtkNew<vtkHDTToImage> toImage;
  toImage->SetInputConnection(reader->GetOutputPort());
  ExpectRegionMatchesDense(toImage, *reader->GetVolume(), "reader");
  EXPECT_EQ(hdtvtk::DenseStates(*reader->GetVolume()), hdtvtk::DenseStates(*vox->GetVolume()));
  std::remove(path.c_str());
}

TEST(ToImage, RefusesForeignGridsAndLargeImages)
{
  vtkNew<hdtvtk::MessageLog> log;
  vtkNew<vtkHyperTreeGrid> foreign;
  vtkNew<vtkHDTToImage> toImage;
  toImage->AddObserver(vtkCommand::ErrorEvent, log);
  toImage->SetInputData(foreign);
  toImage->Update();
  ASSERT_EQ(log->Errors.size(), 1u);
  EXPECT_NE(log->Errors[0].find("HDTVolumeId"), std::string::npos) << log->Errors[0];
  EXPECT_EQ(toImage->GetOutput()->GetNumberOfPoints(), 0);

  vtkSmartPointer<vtkHDTVoxelizer> vox = Voxelized(64);
  toImage->SetInputData(vox->GetOutput());
  toImage->SetMaxMegabytes(0.1); // 64^3 points = 0.25 MiB
  toImage->Update();
  ASSERT_EQ(log->Errors.size(), 2u);
  EXPECT_NE(log->Errors[1].find("set Level to 1"), std::string::npos) << log->Errors[1];
  EXPECT_EQ(toImage->GetOutput()->GetNumberOfPoints(), 0);
  toImage->SetLevel(1);
  toImage->Update();
  EXPECT_EQ(log->Errors.size(), 2u);
  EXPECT_EQ(toImage->GetOutput()->GetNumberOfPoints(), 32 * 32 * 32);

  // The producer re-ran: the old grid's volume is gone.
  vtkSmartPointer<vtkHyperTreeGrid> old = vtkSmartPointer<vtkHyperTreeGrid>::New();
  old->ShallowCopy(vox->GetOutput());
  vox->SetResolution(32);
  vox->Update();
  toImage->SetInputData(old);
  toImage->Update();
  ASSERT_EQ(log->Errors.size(), 3u);
  EXPECT_NE(log->Errors[2].find("no longer exists"), std::string::npos) << log->Errors[2];
}

// Issue 12, defect 2, for ParaView's writer: an overwrite that fails (here a
// file-size limit) keeps the old file and leaves no temporary file behind.
namespace
{
std::string fileBytes(const std::string& path)
{
  std::ifstream in(path, std::ios::binary);
  return std::string(std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>());
}
std::vector<std::string> entriesOf(const std::string& dir)
{
  std::vector<std::string> names;
  if (DIR* d = opendir(dir.c_str()))
  {
    while (dirent* e = readdir(d))
    {
      const std::string n = e->d_name;
      if (n != "." && n != "..")
      {
        names.push_back(n);
      }
    }
    closedir(d);
  }
  return names;
}
}

TEST(Writer, FailedOverwriteKeepsTheOldFile)
{
  const std::string dir = ::testing::TempDir() + "hdt_writer_overwrite";
  ::mkdir(dir.c_str(), 0755);
  const std::string path = dir + "/torus.hdt";
  std::remove(path.c_str());
  auto small = Voxelized(64);
  vtkNew<vtkHDTWriter> writer;
  writer->SetInputData(small->GetOutput());
  writer->SetFileName(path.c_str());
  writer->Write();
  ASSERT_EQ(writer->GetErrorCode(), 0u);
  const std::string before = fileBytes(path);
  ASSERT_FALSE(before.empty());

  auto large = Voxelized(256);
  vtkNew<hdtvtk::MessageLog> log;
  writer->AddObserver(vtkCommand::ErrorEvent, log);
  writer->SetInputData(large->GetOutput());
  rlimit old{};
  ::getrlimit(RLIMIT_FSIZE, &old);
  rlimit limited = old;
  limited.rlim_cur = before.size() + 1000;
  auto previous = std::signal(SIGXFSZ, SIG_IGN);
  ::setrlimit(RLIMIT_FSIZE, &limited);
  writer->Write();
  ::setrlimit(RLIMIT_FSIZE, &old);
  std::signal(SIGXFSZ, previous);
  EXPECT_EQ(log->Errors.size(), 1u);
  EXPECT_EQ(fileBytes(path), before) << "the old file was lost";
  EXPECT_EQ(entriesOf(dir), std::vector<std::string>{ "torus.hdt" }) << "a temporary file was left";
  std::remove(path.c_str());
}
