#include "vtkHDTVoxelizer.h"

#include "vtkHDTHyperTreeGridConversion.h"
#include "vtkHDTMeshConversion.h"

#include "hdt/builder.hpp"
#include "hdt/config.hpp"
#include "hdt/error.hpp"
#include "hdt/mesh.hpp"
#include "hdt/volume.hpp"

#include "vtkCompositeDataIterator.h"
#include "vtkCompositeDataSet.h"
#include "vtkDataObject.h"
#include "vtkDemandDrivenPipeline.h"
#include "vtkDoubleArray.h"
#include "vtkFieldData.h"
#include "vtkHyperTreeGrid.h"
#include "vtkInformation.h"
#include "vtkInformationVector.h"
#include "vtkNew.h"
#include "vtkObjectFactory.h"
#include "vtkSmartPointer.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <new>
#include <sstream>
#include <thread>

vtkStandardNewMacro(vtkHDTVoxelizer);

namespace
{

// Upper bound of the hyper tree grid the conversion makes from a build of
// `mesh`, for the memory check before the build: every tree element and, in
// each expected leaf grid, a full pyramid of L^3 * 8/7 vertices (fewer when
// MaxDepth cuts it), at about 8 bytes a vertex (state byte, mask and
// descriptor bits, VTK's 4-byte child index, the walk's byte).
uint64_t EstimateHyperTreeGridBytes(const hdt::PreparedMesh& mesh, int maxDepth)
{
  const hdt::HostMemoryEstimate e = hdt::estimateHostMemory(mesh);
  const int L = mesh.grid.leafSize;
  const int leafDepths = L == 8 ? 3 : L == 16 ? 4 : 5;
  const int keptDepths = maxDepth < 0 ? leafDepths
                                      : std::max(0, std::min(leafDepths, maxDepth - mesh.grid.height));
  const double perLeaf = (std::pow(8.0, keptDepths + 1) - 1) / 7;
  const double vertices = std::pow(double(mesh.grid.rootGrid), 3) + 2.7 * e.leafGrids + e.leafGrids * perLeaf;
  return uint64_t(8 * vertices);
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
  bool operator==(const BuildKey& o) const
  {
    return Input == o.Input && InputMTime == o.InputMTime && Resolution == o.Resolution &&
      RootGridSize == o.RootGridSize && LeafGridSize == o.LeafGridSize && Backend == o.Backend &&
      Threads == o.Threads && SurfaceOnly == o.SurfaceOnly;
  }
};

struct vtkHDTVoxelizer::Internals
{
  std::shared_ptr<const hdt::Volume> Volume;
  BuildKey Key;
};

//------------------------------------------------------------------------------
vtkHDTVoxelizer::vtkHDTVoxelizer()
  : Internal(new Internals)
{
  this->SetNumberOfInputPorts(1);
  this->SetNumberOfOutputPorts(1);
}

//------------------------------------------------------------------------------
vtkHDTVoxelizer::~vtkHDTVoxelizer()
{
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
int vtkHDTVoxelizer::FillInputPortInformation(int, vtkInformation* info)
{
  info->Set(vtkAlgorithm::INPUT_REQUIRED_DATA_TYPE(), "vtkPolyData");
  info->Append(vtkAlgorithm::INPUT_REQUIRED_DATA_TYPE(), "vtkCompositeDataSet");
  return 1;
}

//------------------------------------------------------------------------------
int vtkHDTVoxelizer::FillOutputPortInformation(int, vtkInformation* info)
{
  info->Set(vtkDataObject::DATA_TYPE_NAME(), "vtkHyperTreeGrid");
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
  this->LastRunReusedVolume = false;

  hdt::BuildConfig config;
  config.resolution = this->Resolution;
  config.rootGrid = this->RootGridSize;
  config.leafSize = this->LeafGridSize;
  config.surfaceOnly = this->SurfaceOnly != 0;

  BuildKey key;
  key.Input = input;
  key.InputMTime = contentMTime(input);
  key.Resolution = this->Resolution;
  key.RootGridSize = this->RootGridSize;
  key.LeafGridSize = this->LeafGridSize;
  key.Backend = this->Backend;
  key.Threads = this->Threads;
  key.SurfaceOnly = config.surfaceOnly;

  try
  {
    std::shared_ptr<const hdt::Volume> volume;
    if (this->Internal->Volume && this->Internal->Key == key)
    {
      volume = this->Internal->Volume;
      this->LastRunReusedVolume = true;
    }
    else
    {
      this->Internal->Volume.reset();
      // Configuration first: it is the user's and cheap to check.
      hdt::validateConfig(config);

      hdt::TriangleMesh mesh;
      vtkHDTMeshConversionInfo meshInfo;
      vtkHDTMeshConversion::AppendDataObject(input, mesh, meshInfo);
      if (meshInfo.VertexCells || meshInfo.LineCells)
      {
        vtkWarningMacro(<< "ignored " << meshInfo.VertexCells << " vertex and "
                        << meshInfo.LineCells
                        << " line cells: they have no area to voxelize"
                        << (meshInfo.Triangles ? "" : "; the input has no polygons, so the output is empty"));
      }
      if (meshInfo.OtherBlocks)
      {
        vtkWarningMacro(<< "ignored " << meshInfo.OtherBlocks
                        << " block(s) that are not vtkPolyData (the first is a "
                        << meshInfo.FirstOtherBlockType
                        << "); apply Extract Surface to voxelize their boundary");
      }
      if (meshInfo.Triangles == 0)
      {
        if (meshInfo.VertexCells || meshInfo.LineCells)
        {
          // Already said by the warning above: nothing with area, empty result.
          output->Initialize();
          this->Internal->Key = BuildKey();
          return 1;
        }
        this->Fail(output,
          meshInfo.OtherBlocks
            ? "the input has no vtkPolyData with polygons or triangle strips to voxelize"
            : "the input is empty: no polygons or triangle strips to voxelize");
        return 1;
      }

      const std::thread::id caller = std::this_thread::get_id();
      hdt::BuildOptions options;
      options.threads = this->Threads;
      options.progress = [this, caller](double fraction, const char* phase) {
        if (std::this_thread::get_id() != caller)
        {
          return !this->GetAbortExecute();
        }
        this->SetProgressText(phase);
        this->UpdateProgress(0.85 * fraction);
        return !this->CheckAbort();
      };
      options.log = [this](const std::string& message) {
        vtkWarningMacro(<< message);
      };
      std::string why;
      switch (this->Backend)
      {
        case BACKEND_CPU:
          options.backend = hdt::Backend::Cpu;
          break;
        case BACKEND_CUDA:
          if (!hdt::cudaAvailable(&why))
          {
            this->Fail(output, ("Backend is CUDA but the CUDA driver cannot be used: " + why +
                                 ". Choose Auto or CPU.")
                                 .c_str());
            return 1;
          }
          options.backend = hdt::Backend::Cuda;
          break;
        default:
          // Auto: without a usable device go straight to the CPU driver (that
          // is the normal case on machines without a GPU, not worth a
          // warning); with one, hdt::build falls back on device failure and
          // says so through options.log.
          options.backend = hdt::cudaAvailable(&why) ? hdt::Backend::Auto : hdt::Backend::Cpu;
          if (options.backend == hdt::Backend::Cpu)
          {
            vtkDebugMacro(<< "Backend Auto: using the CPU driver (" << why << ")");
          }
          break;
      }

      const auto t0 = Clock::now();
      this->SetProgressText("preparing mesh");
      this->UpdateProgress(0.0);
      const hdt::PreparedMesh prepared = hdt::prepareMesh(mesh, config);
      mesh = hdt::TriangleMesh(); // free the copy before the build
      options.extraHostBytes = EstimateHyperTreeGridBytes(prepared, this->MaxDepth);
      auto built = std::make_shared<hdt::Volume>(hdt::build(prepared, options));
      for (const std::string& warning : hdt::buildWarnings(prepared, *built))
      {
        vtkWarningMacro(<< warning);
      }
      this->LastVoxelizationTime = msSince(t0);
      volume = built;
      this->Internal->Volume = volume;
      this->Internal->Key = key;
    }

    this->SetProgressText("building hyper tree grid");
    this->UpdateProgress(0.85);
    vtkHDTConversionOptions conversion;
    conversion.MaxDepth = this->MaxDepth;
    conversion.MaskOutside = this->MaskOutside != 0;
    conversion.Threads = this->Threads;
    const vtkHDTConversionInfo info = vtkHDTToHyperTreeGrid::Convert(*volume, conversion, output);
    this->LastConversionTime = info.Milliseconds;
    vtkNew<vtkDoubleArray> conversionTime;
    conversionTime->SetName("TimeConversion");
    conversionTime->InsertNextValue(info.Milliseconds);
    output->GetFieldData()->AddArray(conversionTime);
    this->UpdateProgress(1.0);
  }
  catch (const hdt::Error& e)
  {
    if (e.kind() == hdt::ErrorKind::Aborted)
    {
      // The user stopped it: no error, no output.
      this->Internal->Volume.reset();
      this->Internal->Key = BuildKey();
      output->Initialize();
      return 1;
    }
    this->Fail(output, e.what());
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
  os << indent << "MaxDepth: " << this->MaxDepth << "\n";
  os << indent << "MaskOutside: " << this->MaskOutside << "\n";
  os << indent << "Threads: " << this->Threads << "\n";
  os << indent << "Volume: " << (this->Internal->Volume ? "kept" : "none") << "\n";
}
