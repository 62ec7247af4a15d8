#include "vtkHDTVolumeHandle.h"

#include "hdt/volume.hpp"

#include "vtkDataArray.h"
#include "vtkFieldData.h"
#include "vtkHyperTreeGrid.h"
#include "vtkNew.h"
#include "vtkTypeUInt64Array.h"

#include <cmath>
#include <mutex>
#include <random>
#include <unordered_map>

namespace
{
struct Registry
{
  std::mutex Mutex;
  std::unordered_map<vtkTypeUInt64, std::weak_ptr<const hdt::Volume>> Volumes;
  vtkTypeUInt64 Salt = (vtkTypeUInt64(std::random_device{}()) << 32) ^ std::random_device{}();
  vtkTypeUInt64 Next = 0;

  static Registry& Instance()
  {
    static Registry registry;
    return registry;
  }
};

// The grid's coordinates are the volume's placement: R + 1 planes per axis
// from origin to origin + N * voxelSize (relative tolerance for the floats).
bool samePlacement(const hdt::Volume& v, vtkHyperTreeGrid* grid)
{
  vtkDataArray* coords[3] = { grid->GetXCoordinates(), grid->GetYCoordinates(),
    grid->GetZCoordinates() };
  const double extent = double(v.grid.resolution) * v.grid.voxelSize;
  for (int a = 0; a < 3; ++a)
  {
    if (!coords[a] || coords[a]->GetNumberOfTuples() != v.grid.rootGrid + 1)
    {
      return false;
    }
    const double first = coords[a]->GetTuple1(0);
    const double last = coords[a]->GetTuple1(v.grid.rootGrid);
    const double tolerance = 1e-9 * (std::abs(v.grid.origin[a]) + extent);
    if (std::abs(first - v.grid.origin[a]) > tolerance ||
      std::abs(last - (v.grid.origin[a] + extent)) > tolerance)
    {
      return false;
    }
  }
  return true;
}
} // namespace

void vtkHDTVolumeHandle::Attach(
  const std::shared_ptr<const hdt::Volume>& volume, vtkDataObject* data)
{
  Registry& registry = Registry::Instance();
  vtkTypeUInt64 id;
  {
    std::lock_guard<std::mutex> lock(registry.Mutex);
    for (auto it = registry.Volumes.begin(); it != registry.Volumes.end();)
    {
      it = it->second.expired() ? registry.Volumes.erase(it) : std::next(it);
    }
    id = registry.Salt ^ ++registry.Next;
    registry.Volumes[id] = volume;
  }
  vtkNew<vtkTypeUInt64Array> array;
  array->SetName(ArrayName());
  array->InsertNextValue(id);
  data->GetFieldData()->AddArray(array);
}

std::shared_ptr<const hdt::Volume> vtkHDTVolumeHandle::Find(vtkHyperTreeGrid* grid, std::string& why)
{
  auto* array = grid ? vtkTypeUInt64Array::SafeDownCast(
                         grid->GetFieldData()->GetAbstractArray(ArrayName()))
                     : nullptr;
  if (!array || array->GetNumberOfValues() != 1)
  {
    why = "the input carries no HDT volume (no HDTVolumeId field array): it does not come from "
          "the HDT Voxelizer or the HDT Reader";
    return nullptr;
  }
  std::shared_ptr<const hdt::Volume> volume;
  {
    Registry& registry = Registry::Instance();
    std::lock_guard<std::mutex> lock(registry.Mutex);
    auto it = registry.Volumes.find(array->GetValue(0));
    if (it != registry.Volumes.end())
    {
      volume = it->second.lock();
    }
  }
  if (!volume)
  {
    why = "the HDT volume behind the input no longer exists (its HDT Voxelizer or HDT Reader "
          "re-ran, failed or was deleted, or the grid was read back from a file): update it";
    return nullptr;
  }
  if (!samePlacement(*volume, grid))
  {
    why = "the input's grid was moved or changed by a filter after the HDT Voxelizer or HDT "
          "Reader: use their own output";
    return nullptr;
  }
  return volume;
}
