#include "vtkHDTWriter.h"

#include "vtkHDTDistributedBuild.h"
#include "vtkFieldData.h"
#include "vtkInformationVector.h"
#include "vtkMultiProcessController.h"
#include "vtkStreamingDemandDrivenPipeline.h"

#include "vtkHDTVolumeHandle.h" // HDT::Filters

#include "hdt/error.hpp"
#include "hdt/hdt_file.hpp"
#include "hdt/volume.hpp"

#include "vtkAlgorithm.h"
#include "vtkErrorCode.h"
#include "vtkHyperTreeGrid.h"
#include "vtkInformation.h"
#include "vtkObjectFactory.h"

#include <memory>
#include <new>
#include <string>

vtkStandardNewMacro(vtkHDTWriter);


//------------------------------------------------------------------------------
vtkHDTWriter::vtkHDTWriter() = default;

//------------------------------------------------------------------------------
vtkHDTWriter::~vtkHDTWriter()
{
  this->SetFileName(nullptr);
}

//------------------------------------------------------------------------------
vtkHyperTreeGrid* vtkHDTWriter::GetInput()
{
  return vtkHyperTreeGrid::SafeDownCast(this->Superclass::GetInput());
}

//------------------------------------------------------------------------------
int vtkHDTWriter::FillInputPortInformation(int, vtkInformation* info)
{
  info->Set(vtkAlgorithm::INPUT_REQUIRED_DATA_TYPE(), "vtkHyperTreeGrid");
  return 1;
}

//------------------------------------------------------------------------------
vtkTypeBool vtkHDTWriter::ProcessRequest(
  vtkInformation* request, vtkInformationVector** inInfo, vtkInformationVector* outInfo)
{
  vtkMultiProcessController* ranks = vtkHDTDistributed::Controller();
  if (ranks && request->Has(vtkStreamingDemandDrivenPipeline::REQUEST_UPDATE_EXTENT()))
  {
    vtkInformation* in = inInfo[0]->GetInformationObject(0);
    in->Set(vtkStreamingDemandDrivenPipeline::UPDATE_PIECE_NUMBER(), ranks->GetLocalProcessId());
    in->Set(vtkStreamingDemandDrivenPipeline::UPDATE_NUMBER_OF_PIECES(), ranks->GetNumberOfProcesses());
    return 1;
  }
  return this->Superclass::ProcessRequest(request, inInfo, outInfo);
}

//------------------------------------------------------------------------------
void vtkHDTWriter::WriteData()
{
  if (!this->FileName || !*this->FileName)
  {
    vtkErrorMacro(<< "no FileName given");
    this->SetErrorCode(vtkErrorCode::NoFileNameError);
    return;
  }
  const std::string fileName = this->FileName;
  auto fail = [&](unsigned long code, const std::string& message) {
    vtkErrorMacro(<< fileName << ": " << message);
    this->SetErrorCode(code);
  };

  std::string why;
  std::shared_ptr<const hdt::Volume> volume = vtkHDTVolumeHandle::Find(this->GetInput(), why);
  // Across MPI ranks (a grid split by the voxelizer or the reader): the
  // ranks' trees are gathered on rank 0, which writes the one file.
  if (vtkMultiProcessController* ranks = vtkHDTDistributed::Controller())
  {
    if (vtkHDTDistributed::Any(ranks, !volume))
    {
      fail(vtkErrorCode::UserError, volume ? "no HDT volume on another rank" : why);
      return;
    }
    const std::vector<hdt::RootRange> split =
      vtkHDTDistributed::RangesOf(this->GetInput()->GetFieldData(), ranks->GetNumberOfProcesses());
    if (vtkHDTDistributed::Any(ranks, split.empty()))
    {
      // Not a split grid (every rank holds the whole volume): rank 0 writes it.
      if (ranks->GetLocalProcessId() != 0)
      {
        return;
      }
    }
    else
    {
      try
      {
        volume = vtkHDTDistributed::Gather(ranks, *volume, split, 0);
      }
      catch (const std::exception& e)
      {
        fail(vtkErrorCode::UserError, e.what());
        return;
      }
      if (!volume)
      {
        return; // not rank 0
      }
    }
  }
  else if (!volume)
  {
    fail(vtkErrorCode::UserError, why);
    return;
  }

  hdt::HdtWriteOptions options;
  options.compressLeaves = this->CompressLeaves != 0;
  options.zstdLevel = this->CompressionLevel;
  try
  {
    // Checks the volume before creating the file; writes a temporary file and
    // renames it over FileName only when complete (hdt/atomic_file.hpp).
    hdt::writeHdt(*volume, fileName, options);
  }
  catch (const hdt::Error& e)
  {
    // The message already names the file.
    vtkErrorMacro(<< e.what());
    this->SetErrorCode(e.kind() == hdt::ErrorKind::OutputFailed ? vtkErrorCode::CannotOpenFileError
                                                                : vtkErrorCode::UserError);
  }
  catch (const std::bad_alloc&)
  {
    fail(vtkErrorCode::UserError, "out of memory while encoding the volume");
  }
  catch (const std::exception& e)
  {
    fail(vtkErrorCode::UserError, e.what());
  }
}

//------------------------------------------------------------------------------
void vtkHDTWriter::PrintSelf(ostream& os, vtkIndent indent)
{
  this->Superclass::PrintSelf(os, indent);
  os << indent << "FileName: " << (this->FileName ? this->FileName : "(none)") << "\n";
  os << indent << "CompressLeaves: " << this->CompressLeaves << "\n";
  os << indent << "CompressionLevel: " << this->CompressionLevel << "\n";
}
