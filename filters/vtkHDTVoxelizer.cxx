#include "vtkHDTVoxelizer.h"

#include "vtkHDTCudaWarmUp.h"
#include "vtkHDTDistributedBuild.h"
#include "vtkHDTHyperTreeGridConversion.h"
#include "vtkHDTLabelledMesh.h"
#include "vtkHDTMeshArrays.h"
#include "vtkHDTMeshConversion.h"
#include "vtkHDTVolumeHandle.h"
#include "vtkHDTVoxelSurface.h"
#include "vtkHDTVoxelArrays.h"

#include "hdt/builder.hpp"
#include "hdt/config.hpp"
#include "hdt/error.hpp"
#include "hdt/labels.hpp"
#include "hdt/mesh.hpp"
#include "hdt/range_exchange.hpp"
#include "hdt/transfer.hpp"
#include "hdt/volume.hpp"
#include "hdt/winding_tree.hpp"

#include "vtkCommand.h"
#include "vtkCompositeDataIterator.h"
#include "vtkDataArraySelection.h"
#include "vtkCompositeDataSet.h"
#include "vtkDataObject.h"
#include "vtkDemandDrivenPipeline.h"
#include "vtkDoubleArray.h"
#include "vtkFieldData.h"
#include "vtkHyperTreeGrid.h"
#include "vtkInformation.h"
#include "vtkInformationVector.h"
#include "vtkMultiProcessController.h"
#include "vtkNew.h"
#include "vtkObjectFactory.h"
#include "vtkPolyData.h"
#include "vtkSmartPointer.h"
#include "vtkStringArray.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <new>
#include <sstream>

vtkStandardNewMacro(vtkHDTVoxelizer);

namespace
{

// The hyper tree grid the conversion will make of `mesh`, for the memory
// check before the build (vtkHDTToHyperTreeGrid's model).
uint64_t EstimateHyperTreeGridBytes(const hdt::PreparedMesh& mesh, int maxDepth)
{
  const double cells =
    vtkHDTToHyperTreeGrid::EstimatedCells(mesh.grid, hdt::estimateHostMemory(mesh).leafGrids, maxDepth);
  return vtkHDTToHyperTreeGrid::EstimatedGridBytes(uint64_t(cells));
}
// FNV-1a over the mesh's bytes: equal on every rank for the gathered mesh.
uint64_t MeshHash(const hdt::TriangleMesh& mesh)
{
  uint64_t h = 1469598103934665603ull;
  auto add = [&h](const void* data, size_t bytes) {
    const unsigned char* p = static_cast<const unsigned char*>(data);
    for (size_t i = 0; i < bytes; ++i)
    {
      h = (h ^ p[i]) * 1099511628211ull;
    }
  };
  add(mesh.points.data(), mesh.points.size() * sizeof(double));
  add(mesh.triangles.data(), mesh.triangles.size() * sizeof(uint32_t));
  return h ^ mesh.triangles.size();
}

// The enabled arrays of a selection, in its order.
std::vector<std::string> EnabledArrays(vtkDataArraySelection* selection)
{
  std::vector<std::string> names;
  for (int i = 0; i < selection->GetNumberOfArrays(); ++i)
  {
    if (selection->GetArraySetting(i))
    {
      names.emplace_back(selection->GetArrayName(i));
    }
  }
  return names;
}

std::string JoinNames(const std::vector<std::string>& names)
{
  std::string joined;
  for (const std::string& n : names)
  {
    joined += n + '\n';
  }
  return joined;
}

using Clock = std::chrono::steady_clock;
double msSince(Clock::time_point t0)
{
  return std::chrono::duration<double, std::milli>(Clock::now() - t0).count();
}

// The modification time of the input's contents: for a composite dataset the
// newest of its leaves (the composite's own MTime does not follow them).
vtkMTimeType contentMTime(vtkDataObject* input)
{
  vtkMTimeType t = input ? input->GetMTime() : 0;
  if (auto* composite = vtkCompositeDataSet::SafeDownCast(input))
  {
    vtkSmartPointer<vtkCompositeDataIterator> it;
    it.TakeReference(composite->NewIterator());
    it->SkipEmptyNodesOn();
    for (it->InitTraversal(); !it->IsDoneWithTraversal(); it->GoToNextItem())
    {
      t = std::max(t, it->GetCurrentDataObject()->GetMTime());
    }
  }
  return t;
}
} // namespace

// What decides whether the kept volume can be reused.
struct BuildKey
{
  vtkDataObject* Input = nullptr;
  vtkMTimeType InputMTime = 0;
  int Resolution = 0, RootGridSize = 0, LeafGridSize = 0, Backend = 0, Threads = 0;
  bool SurfaceOnly = false;
  int LabelBy = 0, OverlapPolicy = 0, InsideTest = 0;
  std::string LabelArrayName, LabelPriority;
  std::string PointArrays, CellArrays; // Arrays To Transfer, one name a line
  // Across MPI ranks: the gathered mesh's contents instead of the input's
  // identity (ParaView re-executes pieces upstream between output ports).
  uint64_t MeshHash = 0;
  bool SameBuild(const BuildKey& o) const
  {
    return Resolution == o.Resolution && RootGridSize == o.RootGridSize &&
      LeafGridSize == o.LeafGridSize && Backend == o.Backend && Threads == o.Threads &&
      SurfaceOnly == o.SurfaceOnly && LabelBy == o.LabelBy &&
      OverlapPolicy == o.OverlapPolicy && LabelArrayName == o.LabelArrayName &&
      LabelPriority == o.LabelPriority && InsideTest == o.InsideTest &&
      PointArrays == o.PointArrays && CellArrays == o.CellArrays;
  }
  bool operator==(const BuildKey& o) const
  {
    return Input == o.Input && InputMTime == o.InputMTime && SameBuild(o);
  }
};

struct vtkHDTVoxelizer::Internals
{
  std::shared_ptr<const hdt::Volume> Volume;
  BuildKey Key;
  // Across MPI ranks: the split and this rank's share (Volume is its piece).
  vtkHDTDistributedPiece Piece;
  bool Distributed = false;
  vtkNew<vtkDataArraySelection> PointArrays, CellArrays; // Arrays To Transfer

  bool Transfers() const
  {
    return !EnabledArrays(this->PointArrays).empty() || !EnabledArrays(this->CellArrays).empty();
  }

  static BuildKey MakeKey(vtkHDTVoxelizer* self, vtkDataObject* input);
  static hdt::BuildOptions MakeBuildOptions(vtkHDTVoxelizer* self);
  static hdt::LabelOptions MakeLabelOptions(vtkHDTVoxelizer* self);
  static bool ToMesh(vtkHDTVoxelizer* self, vtkDataObject* input, hdt::TriangleMesh& mesh,
    vtkHyperTreeGrid* output, vtkMultiProcessController* ranks);
  static void Convert(vtkHDTVoxelizer* self, const std::shared_ptr<const hdt::Volume>& volume,
    vtkHyperTreeGrid* output);
};

//------------------------------------------------------------------------------
// What decides whether the kept volume can be reused.
BuildKey vtkHDTVoxelizer::Internals::MakeKey(vtkHDTVoxelizer* self, vtkDataObject* input)
{
  BuildKey key;
  key.Input = input;
  key.InputMTime = contentMTime(input);
  key.Resolution = self->Resolution;
  key.RootGridSize = self->RootGridSize;
  key.LeafGridSize = self->LeafGridSize;
  key.Backend = self->Backend;
  key.Threads = self->Threads;
  key.SurfaceOnly = self->SurfaceOnly != 0;
  key.LabelBy = self->LabelBy;
  key.OverlapPolicy = self->OverlapPolicy;
  key.LabelArrayName = self->LabelArrayName ? self->LabelArrayName : "";
  key.LabelPriority = self->LabelPriority ? self->LabelPriority : "";
  key.InsideTest = self->InsideTest;
  key.PointArrays = JoinNames(EnabledArrays(self->Internal->PointArrays));
  key.CellArrays = JoinNames(EnabledArrays(self->Internal->CellArrays));
  return key;
}

//------------------------------------------------------------------------------
// Every option of the build, in one place. The backend choice (Auto: CUDA when
// usable, else the CPU; fallback on device failure) is the core's (hdt::build).
hdt::BuildOptions vtkHDTVoxelizer::Internals::MakeBuildOptions(vtkHDTVoxelizer* self)
{
  hdt::BuildOptions options;
  switch (self->Backend)
  {
    case BACKEND_CPU:
      options.backend = hdt::Backend::Cpu;
      break;
    case BACKEND_CUDA:
      options.backend = hdt::Backend::Cuda;
      break;
    default:
      options.backend = hdt::Backend::Auto;
      break;
  }
  options.threads = self->Threads;
  // Called by the drivers on this thread only (hdt/builder.hpp), between
  // phases and inside long ones: the abort flag is read at every call.
  options.progress = [self](double fraction, const char* phase) {
    self->SetProgressText(phase);
    self->UpdateProgress(0.85 * fraction);
    return !self->CheckAbort();
  };
  // The path a build took and its times (Auto on a machine without a
  // usable GPU among them: the normal case) are for debugging; a device that
  // failed and was replaced by the CPU deserves a warning.
  options.log = [self](const std::string& message) { vtkDebugWithObjectMacro(self, << message); };
  options.warn = [self](const std::string& message) { vtkWarningWithObjectMacro(self, << message); };
  return options;
}

//------------------------------------------------------------------------------
// The overlap policy; a priority list, when given, wins over Lowest / Highest.
hdt::LabelOptions vtkHDTVoxelizer::Internals::MakeLabelOptions(vtkHDTVoxelizer* self)
{
  hdt::LabelOptions o;
  o.overlap = self->OverlapPolicy == OVERLAP_HIGHEST ? hdt::OverlapPolicy::Highest : hdt::OverlapPolicy::Lowest;
  const std::string list = self->LabelPriority ? self->LabelPriority : "";
  size_t at = 0;
  while (at < list.size())
  {
    const size_t end = std::min(list.find_first_of(", ", at), list.size());
    const std::string item = list.substr(at, end - at);
    at = end + 1;
    if (item.empty())
    {
      continue;
    }
    char* stop = nullptr;
    const long label = std::strtol(item.c_str(), &stop, 10);
    if (label < 1 || label > 65535 || *stop != '\0')
    {
      throw hdt::Error(hdt::ErrorKind::InvalidArgument,
        "Label Priority: '" + item + "' is not a label from 1 to 65535");
    }
    o.priority.push_back(hdt::Label(label));
  }
  if (!o.priority.empty())
  {
    o.overlap = hdt::OverlapPolicy::Priority;
  }
  return o;
}

//------------------------------------------------------------------------------
// The input as one triangle mesh; warns about what it ignores. False when
// there is nothing to voxelize (the output is then set: empty, or an error).
// Across ranks (`ranks` not null) the mesh is every rank's triangles, and an
// empty mesh is said once, by rank 0.
bool vtkHDTVoxelizer::Internals::ToMesh(vtkHDTVoxelizer* self, vtkDataObject* input,
  hdt::TriangleMesh& mesh, vtkHyperTreeGrid* output, vtkMultiProcessController* ranks)
{
  vtkHDTMeshConversionInfo meshInfo;
  if (ranks && self->LabelBy != LABEL_NONE)
  {
    // The same property on every rank, so every rank stops here alike.
    self->Fail(output, "Label By is not available across MPI ranks yet: set it to None, "
                       "or run the labelled build in one process");
    return false;
  }
  if (ranks && self->Internal->Transfers())
  {
    self->Fail(output, "Arrays To Transfer is not available across MPI ranks yet: select none, "
                       "or run the build in one process");
    return false;
  }
  if (self->LabelBy == LABEL_NONE)
  {
    vtkHDTMeshConversion::AppendDataObject(input, mesh, meshInfo);
  }
  else
  {
    vtkHDTAppendLabelledMesh(input, self->LabelBy == LABEL_BLOCK,
      self->LabelArrayName ? self->LabelArrayName : "", mesh, meshInfo);
  }
  if (ranks)
  {
    vtkHDTDistributed::GatherMesh(ranks, mesh);
    meshInfo.Triangles = vtkIdType(mesh.triangleCount());
    if (meshInfo.Triangles == 0 && ranks->GetLocalProcessId() != 0)
    {
      output->Initialize(); // rank 0 says why
      self->Internal->Volume.reset();
      self->Internal->Key = BuildKey();
      return false;
    }
  }
  if (meshInfo.VertexCells || meshInfo.LineCells)
  {
    vtkWarningWithObjectMacro(self, << "ignored " << meshInfo.VertexCells << " vertex and "
                                    << meshInfo.LineCells
                                    << " line cells: they have no area to voxelize"
                                    << (meshInfo.Triangles
                                           ? ""
                                           : "; the input has no polygons, so the output is empty"));
  }
  if (meshInfo.OtherBlocks)
  {
    vtkWarningWithObjectMacro(self, << "ignored " << meshInfo.OtherBlocks
                                    << " block(s) that are not vtkPolyData (the first is a "
                                    << meshInfo.FirstOtherBlockType
                                    << "); apply Extract Surface to voxelize their boundary");
  }
  if (meshInfo.Triangles > 0)
  {
    return true;
  }
  if (meshInfo.VertexCells || meshInfo.LineCells)
  {
    // Already said by the warning above: nothing with area, empty result.
    output->Initialize();
    self->Internal->Key = BuildKey();
    return false;
  }
  self->Fail(output,
    meshInfo.OtherBlocks
      ? "the input has no vtkPolyData with polygons or triangle strips to voxelize"
      : "the input is empty: no polygons or triangle strips to voxelize");
  return false;
}

//------------------------------------------------------------------------------
// The hyper tree grid of the volume at the display options, with its field
// data (statistics, conversion time, depth used, the volume handle).
void vtkHDTVoxelizer::Internals::Convert(
  vtkHDTVoxelizer* self, const std::shared_ptr<const hdt::Volume>& volume, vtkHyperTreeGrid* output)
{
  self->SetProgressText("building hyper tree grid");
  self->UpdateProgress(0.85);
  vtkHDTConversionOptions conversion;
  conversion.MaxDepth = self->MaxDepth;
  conversion.MaskOutside = self->MaskOutside != 0;
  conversion.Threads = self->Threads;
  if (self->Internal->Distributed)
  {
    conversion.FirstTree = self->Internal->Piece.Cells.first;
    conversion.EndTree = self->Internal->Piece.Cells.end;
  }
  const vtkHDTConversionInfo info = vtkHDTToHyperTreeGrid::Convert(*volume, conversion, output);
  self->LastConversionTime = info.Milliseconds;
  vtkNew<vtkDoubleArray> conversionTime;
  conversionTime->SetName("TimeConversion");
  conversionTime->InsertNextValue(info.Milliseconds);
  output->GetFieldData()->AddArray(conversionTime);
  if (self->Internal->Distributed)
  {
    vtkHDTDistributed::AddFieldData(self->Internal->Piece, output->GetFieldData());
  }
  vtkNew<vtkStringArray> reason; // why the inside test that ran (field InsideTest) was chosen
  reason->SetName("InsideTestReason");
  reason->InsertNextValue(volume->surfaceOnly ? std::string("surface-only build: no inside test")
                                              : hdt::insideTestReason(static_cast<hdt::InsideTest>(self->InsideTest),
                                                  volume->insideTest, volume->closedMesh));
  output->GetFieldData()->AddArray(reason);
  vtkHDTVolumeHandle::Attach(volume, output);
  const std::string warning = vtkHDTToHyperTreeGrid::DrawingWarning(info);
  if (!warning.empty())
  {
    vtkWarningWithObjectMacro(self, << warning);
  }
}

//------------------------------------------------------------------------------
vtkHDTVoxelizer::vtkHDTVoxelizer()
  : Internal(new Internals)
{
  this->SetNumberOfInputPorts(1);
  this->SetNumberOfOutputPorts(2); // the hyper tree grid, the voxel surface
  // A changed selection is a changed filter (as vtkPassSelectedArrays does).
  for (vtkDataArraySelection* s : { this->Internal->PointArrays.GetPointer(), this->Internal->CellArrays.GetPointer() })
  {
    s->AddObserver(vtkCommand::ModifiedEvent, static_cast<vtkObject*>(this), &vtkObject::Modified);
  }
  vtkHDTCudaWarmUp::Start(); // while the user sets the properties
}

//------------------------------------------------------------------------------
vtkDataArraySelection* vtkHDTVoxelizer::GetPointDataArraySelection()
{
  return this->Internal->PointArrays;
}

//------------------------------------------------------------------------------
vtkDataArraySelection* vtkHDTVoxelizer::GetCellDataArraySelection()
{
  return this->Internal->CellArrays;
}

//------------------------------------------------------------------------------
vtkHDTVoxelizer::~vtkHDTVoxelizer()
{
  // A process may end right after its last filter goes: the set-up must not
  // still be using CUDA while CUDA tears itself down at exit.
  vtkHDTCudaWarmUp::Wait();
  this->SetLabelArrayName(nullptr);
  this->SetLabelPriority(nullptr);
  delete this->Internal;
}

//------------------------------------------------------------------------------
std::shared_ptr<const hdt::Volume> vtkHDTVoxelizer::GetVolume() const
{
  return this->Internal->Volume;
}

//------------------------------------------------------------------------------
vtkHyperTreeGrid* vtkHDTVoxelizer::GetOutput()
{
  return this->GetOutput(0);
}

//------------------------------------------------------------------------------
vtkHyperTreeGrid* vtkHDTVoxelizer::GetOutput(int port)
{
  return vtkHyperTreeGrid::SafeDownCast(this->GetOutputDataObject(port));
}

//------------------------------------------------------------------------------
vtkPolyData* vtkHDTVoxelizer::GetSurfaceOutput()
{
  return vtkPolyData::SafeDownCast(this->GetOutputDataObject(1));
}

//------------------------------------------------------------------------------
int vtkHDTVoxelizer::FillInputPortInformation(int, vtkInformation* info)
{
  info->Set(vtkAlgorithm::INPUT_REQUIRED_DATA_TYPE(), "vtkPolyData");
  info->Append(vtkAlgorithm::INPUT_REQUIRED_DATA_TYPE(), "vtkCompositeDataSet");
  return 1;
}

//------------------------------------------------------------------------------
int vtkHDTVoxelizer::FillOutputPortInformation(int port, vtkInformation* info)
{
  info->Set(vtkDataObject::DATA_TYPE_NAME(), port == 0 ? "vtkHyperTreeGrid" : "vtkPolyData");
  return 1;
}

//------------------------------------------------------------------------------
vtkTypeBool vtkHDTVoxelizer::ProcessRequest(
  vtkInformation* request, vtkInformationVector** inInfo, vtkInformationVector* outInfo)
{
  if (request->Has(vtkDemandDrivenPipeline::REQUEST_DATA()))
  {
    return this->RequestData(request, inInfo, outInfo);
  }
  return this->Superclass::ProcessRequest(request, inInfo, outInfo);
}

//------------------------------------------------------------------------------
void vtkHDTVoxelizer::Fail(vtkHyperTreeGrid* output, const char* message)
{
  vtkErrorMacro(<< message);
  this->Internal->Volume.reset();
  this->Internal->Key = BuildKey();
  if (output)
  {
    output->Initialize();
  }
  if (vtkPolyData* surface = this->GetSurfaceOutput())
  {
    surface->Initialize();
  }
}

//------------------------------------------------------------------------------
void vtkHDTVoxelizer::FillSurface(const hdt::Volume& volume, vtkInformationVector* outputVector)
{
  vtkPolyData* surface = vtkPolyData::GetData(outputVector, 1);
  if (surface)
  {
    this->SetProgressText("extracting voxel surface");
    // The same level of detail as the hyper tree grid (Max Depth, Auto included).
    const int depth = vtkHDTToHyperTreeGrid::DepthCut(volume, this->MaxDepth);
    const bool piece = this->Internal->Distributed;
    this->LastSurfaceTime = vtkHDTFillVoxelSurface(volume, depth, surface,
      piece ? this->Internal->Piece.Cells.first : 0, piece ? this->Internal->Piece.Cells.end : ~0ull)
                              .Milliseconds;
    // The build statistics travel with the surface too (Information panel).
    vtkHDTCopyFieldData(vtkHyperTreeGrid::GetData(outputVector, 0), surface, this->LastSurfaceTime);
    vtkHDTAddVoxelSurfaceArrays(volume, depth, surface, piece ? this->Internal->Piece.Cells.first : 0,
      piece ? this->Internal->Piece.Cells.end : ~0ull);
  }
}

//------------------------------------------------------------------------------
int vtkHDTVoxelizer::RequestData(
  vtkInformation*, vtkInformationVector** inputVector, vtkInformationVector* outputVector)
{
  vtkDataObject* input = vtkDataObject::GetData(inputVector[0], 0);
  vtkHyperTreeGrid* output = vtkHyperTreeGrid::GetData(outputVector, 0);
  if (!output)
  {
    vtkErrorMacro(<< "no vtkHyperTreeGrid output");
    return 0;
  }
  this->LastVoxelizationTime = 0;
  this->LastConversionTime = 0;
  this->LastSurfaceTime = 0;
  this->LastRunReusedVolume = false;
  if (vtkPolyData* surface = vtkPolyData::GetData(outputVector, 1))
  {
    surface->Initialize(); // empty unless this run succeeds
  }

  hdt::BuildConfig config;
  config.resolution = this->Resolution;
  config.rootGrid = this->RootGridSize;
  config.leafSize = this->LeafGridSize;
  config.surfaceOnly = this->SurfaceOnly != 0;
  config.insideTest = static_cast<hdt::InsideTest>(this->InsideTest); // same values
  BuildKey key = Internals::MakeKey(this, input);

  try
  {
    std::shared_ptr<const hdt::Volume> volume;
    // Across MPI ranks every rank takes the same path (the build is
    // collective): the mesh is gathered first, and the kept volume is reused
    // when the gathered mesh and the build options are the same everywhere.
    vtkMultiProcessController* ranks = vtkHDTDistributed::Controller();
    hdt::TriangleMesh mesh;
    bool reuse = this->Internal->Volume && this->Internal->Key == key;
    if (ranks)
    {
      hdt::validateConfig(config);
      if (!Internals::ToMesh(this, input, mesh, output, ranks))
      {
        return 1;
      }
      key.MeshHash = MeshHash(mesh);
      reuse = this->Internal->Volume && this->Internal->Key.SameBuild(key) &&
        this->Internal->Key.MeshHash == key.MeshHash;
      reuse = !vtkHDTDistributed::Any(ranks, !reuse);
    }
    if (reuse)
    {
      volume = this->Internal->Volume;
      this->LastRunReusedVolume = true;
    }
    else
    {
      this->Internal->Volume.reset();
      // Configuration first: it is the user's and cheap to check.
      hdt::validateConfig(config);
      if (!ranks && !Internals::ToMesh(this, input, mesh, output, nullptr))
      {
        return 1;
      }
      const auto t0 = Clock::now();
      this->SetProgressText("preparing mesh");
      this->UpdateProgress(0.0);
      hdt::PreparedMesh prepared = hdt::prepareMesh(mesh, config);
      const bool transfers = this->Internal->Transfers();
      if (this->LabelBy == LABEL_NONE && !transfers)
      {
        mesh = hdt::TriangleMesh(); // free the copy before the build
      }
      hdt::BuildOptions options = Internals::MakeBuildOptions(this);
      options.extraHostBytes = EstimateHyperTreeGridBytes(prepared, this->MaxDepth);
      this->Internal->Distributed = ranks != nullptr;
      if (ranks)
      {
        this->Internal->Piece = vtkHDTDistributed::Build(ranks, prepared, options);
        volume = this->Internal->Piece.Volume;
        this->Internal->Piece.Volume.reset(); // kept in Internal->Volume only
      }
      else
      {
        vtkHDTCudaWarmUp::Wait();
        auto built = std::make_shared<hdt::Volume>(this->LabelBy == LABEL_NONE
            ? hdt::build(prepared, options)
            : hdt::voxelizeLabelled(mesh, config, options, Internals::MakeLabelOptions(this)));
        if (transfers)
        {
          this->SetProgressText("transferring arrays");
          hdt::transferArrays(mesh,
            vtkHDTGatherMeshArrays(input, EnabledArrays(this->Internal->PointArrays),
              EnabledArrays(this->Internal->CellArrays), mesh),
            *built);
        }
        volume = built;
      }
      for (const std::string& warning : hdt::buildWarnings(prepared, *volume))
      {
        vtkWarningMacro(<< warning);
      }
      this->LastVoxelizationTime = msSince(t0);
      this->Internal->Volume = volume;
      this->Internal->Key = key;
    }
    Internals::Convert(this, volume, output);
    this->UpdateProgress(0.95);
    this->FillSurface(*volume, outputVector);
    this->UpdateProgress(1.0);
  }
  catch (const hdt::Error& e)
  {
    if (e.kind() == hdt::ErrorKind::Aborted)
    {
      // The user stopped it: no error, empty outputs. They stand as this
      // run's result (AbortOutput cleared): VTK would otherwise flag them
      // ABORTED and run the filter again at the next request (the next output
      // port ParaView updates, the next render), the whole build over.
      this->Internal->Volume.reset();
      this->Internal->Key = BuildKey();
      output->Initialize();
      this->SetAbortOutput(false);
      vtkWarningMacro(<< "build aborted: the outputs stay empty until a property changes");
      return 1;
    }
    this->Fail(output,
      (e.kind() == hdt::ErrorKind::InvalidArgument && this->Backend == BACKEND_CUDA
          ? std::string(e.what()) + ". Choose Backend Auto or CPU."
          : std::string(e.what()))
        .c_str());
  }
  catch (const std::bad_alloc&)
  {
    std::ostringstream msg;
    msg << "out of memory at resolution " << this->Resolution
        << "; lower the Resolution (or MaxDepth for the display)";
    this->Fail(output, msg.str().c_str());
  }
  catch (const std::exception& e)
  {
    this->Fail(output, (std::string("voxelization failed: ") + e.what()).c_str());
  }
  return 1;
}

//------------------------------------------------------------------------------
void vtkHDTVoxelizer::PrintSelf(ostream& os, vtkIndent indent)
{
  this->Superclass::PrintSelf(os, indent);
  os << indent << "Resolution: " << this->Resolution << "\n";
  os << indent << "RootGridSize: " << this->RootGridSize << "\n";
  os << indent << "LeafGridSize: " << this->LeafGridSize << "\n";
  os << indent << "Backend: " << this->Backend << "\n";
  os << indent << "SurfaceOnly: " << this->SurfaceOnly << "\n";
  os << indent << "InsideTest: " << this->InsideTest << "\n";
  os << indent << "MaxDepth: " << this->MaxDepth << "\n";
  os << indent << "MaskOutside: " << this->MaskOutside << "\n";
  os << indent << "Threads: " << this->Threads << "\n";
  os << indent << "Volume: " << (this->Internal->Volume ? "kept" : "none") << "\n";
}
