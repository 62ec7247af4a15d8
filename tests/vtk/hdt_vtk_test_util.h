// Helpers for the VTK-side tests: generated meshes, an independent reference
// built from the core's voxelAt, a geometric walk of the output hyper tree grid,
// and a recorder of error / warning events.
#pragma once

#include "hdt/volume.hpp"

#include "vtkCommand.h"
#include "vtkSmartPointer.h"
#include "vtkType.h"

#include <cstdint>
#include <functional>
#include <string>
#include <vector>

class vtkHyperTreeGrid;
class vtkPolyData;

namespace hdtvtk
{

// Closed triangle meshes made by VTK sources (no files needed).
vtkSmartPointer<vtkPolyData> MakeSphere(int resolution = 48, double radius = 0.5,
  double cx = 0.1, double cy = -0.2, double cz = 0.3);
vtkSmartPointer<vtkPolyData> MakeTorus(double ring = 1.0, double cross = 0.35);

// N^3 voxel states, x fastest, from hdt::voxelAt (the core's own tree walk).
std::vector<uint8_t> DenseStates(const hdt::Volume& volume);

// The state rule for a box of voxels (see vtkHDTHyperTreeGridConversion.h).
struct BoxTally
{
  uint64_t voxels = 0, surface = 0, inside = 0;
  uint8_t State() const { return surface ? 2 : (2 * inside > voxels ? 1 : 0); }
  bool Uniform() const { return surface == 0 && (inside == 0 || inside == voxels); }
};
BoxTally TallyBox(const std::vector<uint8_t>& dense, int n, int x0, int y0, int z0, int k);

// Expected cells per depth, by a depth-first recursion over the HDT and the
// dense states (independent of the converter's breadth-first walk).
std::vector<int64_t> ReferenceCellsPerDepth(
  const hdt::Volume& volume, const std::vector<uint8_t>& dense, int depthCut);

// Walks every cell of `htg` with a geometric cursor and checks it against
// the dense states: its box lies on the voxel lattice, its VoxelState follows
// the state rule, it is refined exactly when depth < depthCut and its voxels
// are not uniform (or hold surface), it is masked exactly when it is an
// outside leaf (expectMask) or never (!expectMask), and the leaves tile the
// N^3 cube. Returns a description of the first few problems (empty: all good).
struct WalkResult
{
  std::vector<int64_t> CellsPerDepth;
  int64_t Leaves = 0;
  int64_t Masked = 0;
  uint64_t LeafVoxels = 0;
  std::vector<std::string> Problems;
};
WalkResult WalkAndCheck(vtkHyperTreeGrid* htg, const hdt::Volume& volume,
  const std::vector<uint8_t>& dense, int depthCut, bool expectMask);

// Calls visit(cell, leaf, x, y, z, edge) for every cell of `htg` that the
// converter made from a volume with `grid`: its global index, whether it is a
// leaf, and the lattice box of voxels it covers (low corner, edge in voxels).
// Depth first by child index, independent of the converter's breadth-first walk.
// Returns the cells visited (a caller checks it against GetNumberOfCells()).
using CellBoxVisitor = std::function<void(vtkIdType cell, bool leaf, int x, int y, int z, int edge)>;
vtkIdType ForEachCellBox(vtkHyperTreeGrid* htg, const hdt::GridSpec& grid, const CellBoxVisitor& visit);

// Records ErrorEvent and WarningEvent messages of an object.
class MessageLog : public vtkCommand
{
public:
  static MessageLog* New() { return new MessageLog; }
  void Execute(vtkObject*, unsigned long event, void* data) override
  {
    const std::string text = data ? static_cast<const char*>(data) : "";
    if (event == vtkCommand::ErrorEvent)
    {
      this->Errors.push_back(text);
    }
    else if (event == vtkCommand::WarningEvent)
    {
      this->Warnings.push_back(text);
    }
  }
  void Clear()
  {
    this->Errors.clear();
    this->Warnings.clear();
  }
  std::vector<std::string> Errors;
  std::vector<std::string> Warnings;
};

} // namespace hdtvtk
