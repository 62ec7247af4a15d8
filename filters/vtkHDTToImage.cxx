#include "vtkHDTToImage.h"

#include "vtkHDTVoxelArrays.h"

#include "vtkHDTVolumeHandle.h"

#include "hdt/error.hpp"
#include "hdt/region.hpp"
#include "hdt/volume.hpp"

#include "vtkDataObject.h"
#include "vtkHyperTreeGrid.h"
#include "vtkImageData.h"
#include "vtkInformation.h"
#include "vtkInformationVector.h"
#include "vtkIntArray.h"
#include "vtkObjectFactory.h"
#include "vtkPointData.h"
#include "vtkStreamingDemandDrivenPipeline.h"
#include "vtkUnsignedCharArray.h"

#include <cmath>
#include <memory>
#include <new>
#include <sstream>
#include <string>

vtkStandardNewMacro(vtkHDTToImage);

// What the output will be: the volume, the aligned voxel box and the image geometry.
struct vtkHDTToImage::Plan
{
  std::shared_ptr<const hdt::Volume> Volume;
  hdt::VoxelBox Box;
  int Dimensions[3] = { 0, 0, 0 };
  double Origin[3] = { 0, 0, 0 };
  double Spacing[3] = { 1, 1, 1 };
};

//------------------------------------------------------------------------------
vtkHDTToImage::vtkHDTToImage()
{
  this->SetNumberOfInputPorts(1);
  this->SetNumberOfOutputPorts(1);
}

//------------------------------------------------------------------------------
int vtkHDTToImage::FillInputPortInformation(int, vtkInformation* info)
{
  info->Set(vtkAlgorithm::INPUT_REQUIRED_DATA_TYPE(), "vtkHyperTreeGrid");
  return 1;
}

//------------------------------------------------------------------------------
bool vtkHDTToImage::MakePlan(vtkInformationVector** inputVector, Plan& plan, bool report)
{
  std::string why;
  plan.Volume = vtkHDTVolumeHandle::Find(vtkHyperTreeGrid::GetData(inputVector[0], 0), why);
  if (!plan.Volume)
  {
    if (report)
    {
      vtkErrorMacro(<< why);
    }
    return false;
  }
  const hdt::GridSpec& g = plan.Volume->grid;
  hdt::VoxelBox wanted;
  for (int a = 0; a < 3; ++a)
  {
    wanted.lo[a] = 0;
    wanted.hi[a] = g.resolution;
    if (this->UseRegion)
    {
      const double lo = (this->RegionOrigin[a] - g.origin[a]) / g.voxelSize;
      const double hi = lo + this->RegionSize[a] / g.voxelSize;
      wanted.lo[a] = static_cast<int64_t>(std::floor(std::max(std::min(lo, hi), -1.0)));
      wanted.hi[a] = static_cast<int64_t>(std::ceil(std::min(std::max(lo, hi), 1.0 + g.resolution)));
    }
  }
  plan.Box = hdt::alignToBlocks(*plan.Volume, wanted, this->Level);
  const int64_t f = int64_t(1) << this->Level;
  double points = 1;
  for (int a = 0; a < 3; ++a)
  {
    plan.Dimensions[a] = static_cast<int>((plan.Box.size(a) + f - 1) / f);
    plan.Spacing[a] = g.voxelSize * double(f);
    plan.Origin[a] = g.origin[a] + (double(plan.Box.lo[a]) + 0.5 * double(f)) * g.voxelSize;
    points *= plan.Dimensions[a];
  }
  if (points == 0)
  {
    if (report)
    {
      vtkErrorMacro(<< "the region does not meet the grid");
    }
    return false;
  }
  const double megabytes = points / (1024.0 * 1024.0);
  if (megabytes > this->MaxMegabytes)
  {
    if (report)
    {
      int level = this->Level;
      while (level < 16 && megabytes / std::pow(8.0, level - this->Level) > this->MaxMegabytes)
      {
        ++level;
      }
      std::ostringstream msg;
      msg << "the image would be " << plan.Dimensions[0] << " x " << plan.Dimensions[1] << " x "
          << plan.Dimensions[2] << " points (" << std::ceil(megabytes) << " MiB), over the bound of "
          << this->MaxMegabytes << " MiB: set Level to " << level
          << " or more, choose a smaller region, or raise MaxMegabytes";
      vtkErrorMacro(<< msg.str());
    }
    return false;
  }
  return true;
}

//------------------------------------------------------------------------------
int vtkHDTToImage::RequestInformation(
  vtkInformation*, vtkInformationVector** inputVector, vtkInformationVector* outputVector)
{
  // The extent depends on the volume, which exists only once the producer has
  // run: bring it up to date first (a source's data is not part of the
  // information pass otherwise).
  int port = 0;
  if (vtkAlgorithm* producer = this->GetInputAlgorithm(0, 0, port))
  {
    producer->Update(port);
  }
  vtkInformation* outInfo = outputVector->GetInformationObject(0);
  Plan plan;
  int extent[6] = { 0, -1, 0, -1, 0, -1 };
  if (this->MakePlan(inputVector, plan, false))
  {
    for (int a = 0; a < 3; ++a)
    {
      extent[2 * a + 1] = plan.Dimensions[a] - 1;
    }
    outInfo->Set(vtkDataObject::ORIGIN(), plan.Origin, 3);
    outInfo->Set(vtkDataObject::SPACING(), plan.Spacing, 3);
  }
  outInfo->Set(vtkStreamingDemandDrivenPipeline::WHOLE_EXTENT(), extent, 6);
  vtkDataObject::SetPointDataActiveScalarInfo(outInfo, VTK_UNSIGNED_CHAR, 1);
  return 1;
}

//------------------------------------------------------------------------------
int vtkHDTToImage::RequestUpdateExtent(
  vtkInformation*, vtkInformationVector** inputVector, vtkInformationVector*)
{
  // The input is a hyper tree grid: ask for all of it, not the image's extent.
  vtkInformation* inInfo = inputVector[0]->GetInformationObject(0);
  if (inInfo->Has(vtkStreamingDemandDrivenPipeline::WHOLE_EXTENT()))
  {
    inInfo->Set(vtkStreamingDemandDrivenPipeline::UPDATE_EXTENT(),
      inInfo->Get(vtkStreamingDemandDrivenPipeline::WHOLE_EXTENT()), 6);
  }
  return 1;
}

//------------------------------------------------------------------------------
int vtkHDTToImage::RequestData(
  vtkInformation*, vtkInformationVector** inputVector, vtkInformationVector* outputVector)
{
  vtkImageData* output = vtkImageData::GetData(outputVector, 0);
  if (!output)
  {
    vtkErrorMacro(<< "no vtkImageData output");
    return 0;
  }
  output->Initialize();
  Plan plan;
  if (!this->MakePlan(inputVector, plan, true))
  {
    return 1;
  }
  try
  {
    const std::vector<uint8_t> states = hdt::coarseStates(*plan.Volume, plan.Box, this->Level);
    output->SetExtent(0, plan.Dimensions[0] - 1, 0, plan.Dimensions[1] - 1, 0, plan.Dimensions[2] - 1);
    output->SetOrigin(plan.Origin);
    output->SetSpacing(plan.Spacing);
    vtkNew<vtkUnsignedCharArray> array;
    array->SetName("VoxelState");
    array->SetNumberOfValues(static_cast<vtkIdType>(states.size()));
    std::copy(states.begin(), states.end(), array->GetPointer(0));
    output->GetPointData()->SetScalars(array);
    const long long lo[3] = { plan.Box.lo[0], plan.Box.lo[1], plan.Box.lo[2] };
    vtkHDTAddVoxelImageArrays(*plan.Volume, lo, this->Level, output); // transferred mesh data, if any
    // The voxel box it covers, for scripts: lo and hi (exclusive) per axis.
    vtkNew<vtkIntArray> box;
    box->SetName("VoxelBox");
    for (int a = 0; a < 3; ++a)
    {
      box->InsertNextValue(static_cast<int>(plan.Box.lo[a]));
      box->InsertNextValue(static_cast<int>(plan.Box.hi[a]));
    }
    output->GetFieldData()->AddArray(box);
  }
  catch (const std::bad_alloc&)
  {
    output->Initialize();
    vtkErrorMacro(<< "out of memory for the image: raise Level or choose a smaller region");
  }
  catch (const std::exception& e)
  {
    output->Initialize();
    vtkErrorMacro(<< e.what());
  }
  return 1;
}

//------------------------------------------------------------------------------
void vtkHDTToImage::PrintSelf(ostream& os, vtkIndent indent)
{
  this->Superclass::PrintSelf(os, indent);
  os << indent << "Level: " << this->Level << "\n";
  os << indent << "UseRegion: " << this->UseRegion << "\n";
  os << indent << "RegionOrigin: " << this->RegionOrigin[0] << " " << this->RegionOrigin[1] << " "
     << this->RegionOrigin[2] << "\n";
  os << indent << "RegionSize: " << this->RegionSize[0] << " " << this->RegionSize[1] << " "
     << this->RegionSize[2] << "\n";
  os << indent << "MaxMegabytes: " << this->MaxMegabytes << "\n";
}
