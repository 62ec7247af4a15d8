#include "vtkHDTWriter.h"

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
  const std::shared_ptr<const hdt::Volume> volume = vtkHDTVolumeHandle::Find(this->GetInput(), why);
  if (!volume)
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
