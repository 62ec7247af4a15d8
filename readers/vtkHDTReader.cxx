#include "vtkHDTReader.h"

#include "vtkHDTDistributedBuild.h"
#include "vtkMultiProcessController.h"

#include "vtkHDTHyperTreeGridConversion.h" // HDT::Filters
#include "vtkHDTVolumeHandle.h"            // HDT::Filters
#include "vtkHDTVoxelArrays.h"             // HDT::Filters
#include "vtkHDTVoxelSurface.h"            // HDT::Filters

#include "hdt/error.hpp"
#include "hdt/hdt_file.hpp"
#include "hdt/volume.hpp"

#include "vtkDemandDrivenPipeline.h"
#include "vtkDoubleArray.h"
#include "vtkErrorCode.h"
#include "vtkFieldData.h"
#include "vtkHyperTreeGrid.h"
#include "vtkInformation.h"
#include "vtkInformationVector.h"
#include "vtkNew.h"
#include "vtkObjectFactory.h"
#include "vtkPolyData.h"

#include <cstdint>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <new>
#include <string>
#include <system_error>

vtkStandardNewMacro(vtkHDTReader);

namespace
{
// What identifies the bytes a volume was read from, for re-using it when only
// MaxDepth or MaskOutside changed.
struct FileStamp
{
  std::string Name;
  std::uintmax_t Size = 0;
  std::filesystem::file_time_type Time{};

  bool operator==(const FileStamp& o) const
  {
    return this->Name == o.Name && this->Size == o.Size && this->Time == o.Time;
  }
};

// False (and `why` set) when the file cannot be stat'ed as a regular file.
bool stampOf(const std::string& name, FileStamp& stamp, std::string& why)
{
  namespace fs = std::filesystem;
  std::error_code ec;
  const fs::file_status status = fs::status(name, ec);
  if (ec || !fs::exists(status))
  {
    why = "cannot open: " + (ec ? ec.message() : std::string("no such file"));
    return false;
  }
  if (!fs::is_regular_file(status))
  {
    why = "not a regular file";
    return false;
  }
  stamp.Name = name;
  stamp.Size = fs::file_size(name, ec);
  stamp.Time = fs::last_write_time(name, ec);
  if (ec)
  {
    why = "cannot open: " + ec.message();
    return false;
  }
  return true;
}
} // namespace

struct vtkHDTReader::Internals
{
  std::shared_ptr<const hdt::Volume> Volume;
  std::shared_ptr<const hdt::Volume> Piece; // this rank's share, across MPI ranks (kept for the writer)
  FileStamp Stamp;
};

//------------------------------------------------------------------------------
vtkHDTReader::vtkHDTReader()
  : Internal(new Internals)
{
  this->SetNumberOfInputPorts(0);
  this->SetNumberOfOutputPorts(2); // the hyper tree grid, the voxel surface
}

//------------------------------------------------------------------------------
vtkHDTReader::~vtkHDTReader()
{
  this->SetFileName(nullptr);
  delete this->Internal;
}

//------------------------------------------------------------------------------
std::shared_ptr<const hdt::Volume> vtkHDTReader::GetVolume() const
{
  return this->Internal->Volume;
}

//------------------------------------------------------------------------------
int vtkHDTReader::CanReadFile(const char* fileName)
{
  if (!fileName || !*fileName)
  {
    return 0;
  }
  std::ifstream in(fileName, std::ios::binary);
  char magic[4] = {};
  if (!in.read(magic, sizeof(magic)))
  {
    return 0;
  }
  return std::memcmp(magic, "HDT\0", 4) == 0 ? 1 : 0;
}

//------------------------------------------------------------------------------
vtkHyperTreeGrid* vtkHDTReader::GetOutput()
{
  return vtkHyperTreeGrid::SafeDownCast(this->GetOutputDataObject(0));
}

//------------------------------------------------------------------------------
vtkPolyData* vtkHDTReader::GetSurfaceOutput()
{
  return vtkPolyData::SafeDownCast(this->GetOutputDataObject(1));
}

//------------------------------------------------------------------------------
int vtkHDTReader::FillOutputPortInformation(int port, vtkInformation* info)
{
  info->Set(vtkDataObject::DATA_TYPE_NAME(), port == 0 ? "vtkHyperTreeGrid" : "vtkPolyData");
  return 1;
}

//------------------------------------------------------------------------------
vtkTypeBool vtkHDTReader::ProcessRequest(
  vtkInformation* request, vtkInformationVector** inInfo, vtkInformationVector* outInfo)
{
  if (request->Has(vtkDemandDrivenPipeline::REQUEST_DATA()))
  {
    return this->RequestData(request, inInfo, outInfo);
  }
  if (request->Has(vtkDemandDrivenPipeline::REQUEST_INFORMATION()))
  {
    // Every rank runs (and shows its share of the trees): without this the
    // executive runs a reader for piece 0 only.
    for (int port = 0; port < outInfo->GetNumberOfInformationObjects(); ++port)
    {
      outInfo->GetInformationObject(port)->Set(CAN_HANDLE_PIECE_REQUEST(), 1);
    }
  }
  return this->Superclass::ProcessRequest(request, inInfo, outInfo);
}

//------------------------------------------------------------------------------
int vtkHDTReader::RequestData(
  vtkInformation*, vtkInformationVector**, vtkInformationVector* outputVector)
{
  vtkHyperTreeGrid* output = vtkHyperTreeGrid::GetData(outputVector, 0);
  if (!output)
  {
    vtkErrorMacro(<< "no vtkHyperTreeGrid output");
    return 0;
  }
  this->SetErrorCode(vtkErrorCode::NoError);
  vtkPolyData* surface = vtkPolyData::GetData(outputVector, 1);
  if (surface)
  {
    surface->Initialize(); // empty unless this run succeeds
  }

  // Every failure: one message, an empty output, no volume kept, and the
  // pipeline goes on (as vtkHDTVoxelizer does).
  auto fail = [&](unsigned long code, const std::string& message) {
    vtkErrorMacro(<< message);
    this->SetErrorCode(code);
    this->Internal->Volume.reset();
    this->Internal->Stamp = FileStamp();
    output->Initialize();
    if (surface)
    {
      surface->Initialize();
    }
    return 1;
  };

  if (!this->FileName || !*this->FileName)
  {
    return fail(vtkErrorCode::NoFileNameError, "no FileName given");
  }
  const std::string fileName = this->FileName;

  FileStamp stamp;
  std::string why;
  if (!stampOf(fileName, stamp, why))
  {
    return fail(vtkErrorCode::CannotOpenFileError, fileName + ": " + why);
  }

  // 1. The volume: read and validated by the core library, unless the same
  // file was read last time.
  if (!this->Internal->Volume || !(this->Internal->Stamp == stamp))
  {
    this->Internal->Volume.reset();
    this->SetProgressText("reading .hdt file");
    this->UpdateProgress(0.0);
    try
    {
      this->Internal->Volume = std::make_shared<const hdt::Volume>(hdt::readHdt(fileName));
      this->Internal->Stamp = stamp;
    }
    catch (const hdt::Error& e)
    {
      // The message already names the file and what is wrong with it.
      return fail(e.kind() == hdt::ErrorKind::OutOfResources ? vtkErrorCode::UserError
                                                             : vtkErrorCode::FileFormatError,
        e.what());
    }
    catch (const std::bad_alloc&)
    {
      return fail(vtkErrorCode::UserError, fileName + ": not enough memory to load the volume");
    }
    catch (const std::exception& e)
    {
      return fail(vtkErrorCode::UserError, fileName + ": " + e.what());
    }
  }

  // 2. The hyper tree grid, by the voxelizer's own conversion.
  this->SetProgressText("building hyper tree grid");
  this->UpdateProgress(0.7);
  try
  {
    vtkHDTConversionOptions options;
    options.MaxDepth = this->MaxDepth;
    options.MaskOutside = this->MaskOutside != 0;
    // Across MPI ranks every rank read the file and shows a share of its
    // trees: the whole root grid, its own trees (vtkHDTDistributedBuild.h).
    std::shared_ptr<const hdt::Volume> shown = this->Internal->Volume;
    vtkHDTDistributedPiece piece;
    vtkMultiProcessController* ranks = vtkHDTDistributed::Controller();
    if (ranks)
    {
      piece = vtkHDTDistributed::Share(ranks, this->Internal->Volume);
      shown = piece.Volume;
      this->Internal->Piece = piece.Volume;
      options.FirstTree = piece.Cells.first;
      options.EndTree = piece.Cells.end;
    }
    const vtkHDTConversionInfo info = vtkHDTToHyperTreeGrid::Convert(*shown, options, output);
    if (ranks)
    {
      vtkHDTDistributed::AddFieldData(piece, output->GetFieldData());
    }
    // Same field arrays as the voxelizer's output (TimeConversion is this run's).
    vtkNew<vtkDoubleArray> conversionTime;
    conversionTime->SetName("TimeConversion");
    conversionTime->InsertNextValue(info.Milliseconds);
    output->GetFieldData()->AddArray(conversionTime);
    vtkHDTVolumeHandle::Attach(shown, output);
    const std::string warning = vtkHDTToHyperTreeGrid::DrawingWarning(info);
    if (!warning.empty())
    {
      vtkWarningMacro(<< warning);
    }
    if (surface)
    {
      // The same level of detail as the hyper tree grid (Max Depth, Auto included).
      this->SetProgressText("extracting voxel surface");
      this->UpdateProgress(0.95);
      const hdt::Volume& volume = *shown;
      const int depth = vtkHDTToHyperTreeGrid::DepthCut(volume, this->MaxDepth);
      const double ms =
        vtkHDTFillVoxelSurface(volume, depth, surface, options.FirstTree, options.EndTree).Milliseconds;
      vtkHDTCopyFieldData(output, surface, ms);
      vtkHDTAddVoxelSurfaceArrays(volume, depth, surface, options.FirstTree, options.EndTree);
    }
  }
  catch (const std::bad_alloc&)
  {
    return fail(vtkErrorCode::UserError,
      fileName + ": not enough memory for the hyper tree grid; set MaxDepth for a coarser view");
  }
  catch (const std::exception& e)
  {
    return fail(vtkErrorCode::FileFormatError, fileName + ": " + e.what());
  }
  this->UpdateProgress(1.0);
  return 1;
}

//------------------------------------------------------------------------------
void vtkHDTReader::PrintSelf(ostream& os, vtkIndent indent)
{
  this->Superclass::PrintSelf(os, indent);
  os << indent << "FileName: " << (this->FileName ? this->FileName : "(none)") << "\n";
  os << indent << "MaxDepth: " << this->MaxDepth << "\n";
  os << indent << "MaskOutside: " << this->MaskOutside << "\n";
  os << indent << "Volume: " << (this->Internal->Volume ? "read" : "none") << "\n";
}
