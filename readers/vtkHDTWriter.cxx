#include "vtkHDTWriter.h"

#include "vtkHDTReader.h"
#include "vtkHDTVoxelizer.h" // HDT::Filters

#include "hdt/error.hpp"
#include "hdt/hdt_file.hpp"
#include "hdt/volume.hpp"

#include "vtkAlgorithm.h"
#include "vtkCellData.h"
#include "vtkDataArray.h"
#include "vtkErrorCode.h"
#include "vtkHyperTreeGrid.h"
#include "vtkInformation.h"
#include "vtkObjectFactory.h"

#include <memory>
#include <new>
#include <string>
#include <vector>

vtkStandardNewMacro(vtkHDTWriter);

namespace
{
bool sameCoordinates(vtkDataArray* a, vtkDataArray* b)
{
  if (a == b)
  {
    return true;
  }
  if (!a || !b || a->GetNumberOfTuples() != b->GetNumberOfTuples())
  {
    return false;
  }
  for (vtkIdType i = 0; i < a->GetNumberOfTuples(); ++i)
  {
    if (a->GetTuple1(i) != b->GetTuple1(i))
    {
      return false;
    }
  }
  return true;
}

// The same hyper tree grid, or a shallow copy of it: a pass-through filter such
// as the vtkPVPostFilter that ParaView puts after every source shares the cell
// arrays (vtkHyperTreeGrid::ShallowCopy copies only the small coordinate
// arrays), whereas a filter that changes the grid makes new ones.
bool sameView(vtkHyperTreeGrid* a, vtkHyperTreeGrid* b)
{
  if (!a || !b)
  {
    return false;
  }
  if (a == b)
  {
    return true;
  }
  vtkDataArray* stateA = a->GetCellData()->GetArray("VoxelState");
  return stateA && stateA == b->GetCellData()->GetArray("VoxelState") &&
    a->GetNumberOfCells() == b->GetNumberOfCells() &&
    sameCoordinates(a->GetXCoordinates(), b->GetXCoordinates()) &&
    sameCoordinates(a->GetYCoordinates(), b->GetYCoordinates()) &&
    sameCoordinates(a->GetZCoordinates(), b->GetZCoordinates());
}
} // namespace

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
bool vtkHDTWriter::FindVolume(std::shared_ptr<const hdt::Volume>& volume, std::string& why)
{
  // An .hdt file stores the HDT volume, of which the input hyper tree grid is
  // only a view; the volume is kept by the algorithm that made the grid. Walk
  // up single-input algorithms to it, then make sure the input still is its
  // output (possibly passed through shallow copies).
  struct Step
  {
    vtkAlgorithm* Algorithm;
    int Port;
    vtkHyperTreeGrid* Output() const
    {
      return vtkHyperTreeGrid::SafeDownCast(this->Algorithm->GetOutputDataObject(this->Port));
    }
  };
  std::vector<Step> chain; // from the writer's producer upwards
  int port = 0;
  vtkAlgorithm* algorithm =
    this->GetNumberOfInputConnections(0) == 1 ? this->GetInputAlgorithm(0, 0, port) : nullptr;
  while (algorithm && chain.size() < 64)
  {
    chain.push_back(Step{ algorithm, port });
    std::shared_ptr<const hdt::Volume> found;
    std::string name;
    if (auto* voxelizer = vtkHDTVoxelizer::SafeDownCast(algorithm))
    {
      found = voxelizer->GetVolume();
      name = "HDT Voxelizer";
    }
    else if (auto* reader = vtkHDTReader::SafeDownCast(algorithm))
    {
      found = reader->GetVolume();
      name = "HDT Reader";
    }
    if (!name.empty())
    {
      if (!sameView(this->GetInput(), chain.back().Output()))
      {
        // Name the first algorithm below the producer that changed the grid
        // (pass-through steps such as ParaView's vtkPVPostFilter do not count).
        std::string changer = "a filter";
        for (size_t i = chain.size() - 1; i-- > 0;)
        {
          if (!sameView(chain[i].Output(), chain[i + 1].Output()))
          {
            changer = chain[i].Algorithm->GetClassName();
            break;
          }
        }
        why = "the input is the " + name + "'s output changed by " + changer +
          "; an .hdt file stores the " + name + "'s volume as it is: save the " + name +
          "'s own output";
        return false;
      }
      if (!found)
      {
        why = "the " + name + " upstream has no volume (its last run failed)";
        return false;
      }
      volume = found;
      return true;
    }
    if (algorithm->GetNumberOfInputPorts() < 1 || algorithm->GetNumberOfInputConnections(0) != 1)
    {
      break;
    }
    algorithm = algorithm->GetInputAlgorithm(0, 0, port);
  }
  std::string from;
  if (algorithm && algorithm->IsA("vtkTrivialProducer"))
  {
    from = " (it was handed over with SetInputData: connect the writer with SetInputConnection)";
  }
  else if (algorithm)
  {
    from = std::string(" (it comes from ") + algorithm->GetClassName() + ")";
  }
  why = "the input does not come from the HDT Voxelizer or the HDT Reader" + from +
    ". An .hdt file stores the HDT volume those two keep behind their hyper tree grid; "
    "other hyper tree grids have none.";
  return false;
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

  std::shared_ptr<const hdt::Volume> volume;
  std::string why;
  if (!this->FindVolume(volume, why))
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
