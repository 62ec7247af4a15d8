// hdt::Volume -> vtkHyperTreeGrid, shared by vtkHDTVoxelizer and the .hdt reader.
//
// Mapping (see docs in the .cxx for the reasons):
//   * the HDT root grid (R^3 elements, x fastest) is the HTG level-0 grid: tree
//     index i + R (j + R k), coordinates origin + i * voxelSize * N / R, so R + 1
//     coordinates per axis; branch factor 2, dimension 3;
//   * octree level k is HTG depth k; HDT's Morton child c (bit 0 = +x, bit 1 = +y,
//     bit 2 = +z) is VTK's child c (VTK puts child c at x = c & 1, y = (c >> 1) & 1,
//     z = c >> 2 for branch factor 2 in 3D);
//   * a Boundary element (depth h, one L^3 leaf grid) continues for log2(L)
//     depths as an octree over the leaf grid, refined only where an octant holds
//     a surface voxel (or, in a damaged volume only, a mix of inside and outside);
//     uniform octants stay coarse HTG leaves. Full depth = h + log2(L).
//
// Cell data "VoxelState" (unsigned char), for every cell, refined or not, from the
// voxels below it: 2 (surface) if any is surface, else 1 (inside) if more than
// half of them are inside, else 0 (outside). For uniform cells that is simply
// their state; the majority rule only decides cells that MaxDepth cuts and that
// mix inside and outside without a surface voxel, which a correct build does not
// produce (inside and outside voxels are always separated by surface voxels).
#pragma once

#include "HDTFiltersModule.h" // export macro
#include "vtkType.h"

#include <cstdint>
#include <string>
#include <vector>

class vtkFieldData;
class vtkHyperTreeGrid;
namespace hdt
{
struct GridSpec;
struct Volume;
}

struct vtkHDTConversionOptions
{
  // -1: full depth. k >= 0: no cell deeper than k; cells at depth k take the
  // aggregated state of the voxels below them. -2 (AUTO_DEPTH): the deepest
  // depth whose cells are no smaller than 1/AutoDisplayResolution of the grid
  // (DepthCut), which keeps the first picture to a few million polygons.
  int MaxDepth = -1;
  // Refuse (hdt::Error OutOfResources) a grid estimated to need more than this
  // many bytes once ParaView holds and draws it; 0 = what the host has available.
  uint64_t MemoryLimitBytes = 0;
  // Mask (hide) every leaf cell whose state is 0 (outside). Refined cells are
  // never masked. With the mask, vtkHyperTreeGridGeometry draws the voxel surface.
  bool MaskOutside = true;
  // Add the build statistics and grid description as field data.
  bool AddFieldData = true;
  // Worker threads: 0 = all cores, 1 = sequential (the benchmark's "one core").
  int Threads = 0;
  // How VTK builds each tree from its breadth-first "refined" bits. Both give
  // the same trees (tested). vtkHyperTree::InitializeForReader sizes the
  // tree's child table once and measured about twice as fast as
  // BuildFromBreadthFirstOrderDescriptor, which grows it bit by bit.
  enum TreeBuildMethod
  {
    INITIALIZE_FOR_READER,
    BREADTH_FIRST_DESCRIPTOR
  };
  TreeBuildMethod TreeBuild = INITIALIZE_FOR_READER;
  // Only the trees of root cells [FirstTree, EndTree) (x fastest): a process's
  // share of a distributed grid, which keeps the whole root grid and holds
  // only its own trees (vtkHDTDistributedBuild.h). Default: every tree.
  uint64_t FirstTree = 0;
  uint64_t EndTree = UINT64_MAX;
};

struct vtkHDTConversionInfo
{
  vtkIdType Cells = 0;       // all HTG vertices (coarse and leaf cells)
  vtkIdType LeafCells = 0;   // unrefined cells
  vtkIdType MaskedCells = 0; // leaves hidden by MaskOutside
  vtkIdType Trees = 0;       // = R^3, or EndTree - FirstTree
  int Depth = 0;             // deepest depth present
  std::vector<vtkIdType> CellsPerDepth;
  // Wall-clock milliseconds: the whole conversion and its parts.
  double Milliseconds = 0;
  double ContextMilliseconds = 0;   // checking the volume, surface flags of elements
  double WalkMilliseconds = 0;      // the per-tree breadth-first walks
  double PackMilliseconds = 0;      // codes -> VoxelState, descriptor and mask arrays
  double TreeBuildMilliseconds = 0; // VTK's tree creation and BuildFromBreadthFirstOrderDescriptor
};

class HDTFILTERS_EXPORT vtkHDTToHyperTreeGrid
{
public:
  // Depth of single-voxel cells: height + log2(L).
  static int FullDepth(const hdt::GridSpec& grid);
  static int FullDepth(const hdt::Volume& volume);

  // MaxDepth value meaning "automatic", and the finest resolution (cells per
  // axis) it shows: at 1024 the dragon's hyper tree grid surface is about 2.7
  // million polygons (bench/results/pvui.md).
  static constexpr int AUTO_DEPTH = -2;
  static constexpr int AutoDisplayResolution = 1024;

  // The depth the conversion cuts at for a MaxDepth value: full depth for -1
  // (and values past it), the largest depth with at most AutoDisplayResolution
  // cells per axis for AUTO_DEPTH (at least 0).
  static int DepthCut(const hdt::GridSpec& grid, int maxDepth);
  static int DepthCut(const hdt::Volume& volume, int maxDepth);

  // A warning when the grid has more leaf cells than ParaView draws in about
  // a minute (its hyper tree grid surface extraction), else empty.
  static std::string DrawingWarning(const vtkHDTConversionInfo& info);

  // The memory model of a converted grid, in one place. EstimatedCells: the
  // cells expected before a build from the expected leaf grids: every tree
  // element and, in each leaf grid, a full pyramid of L^3 * 8/7 cells (fewer
  // when the depth cut of `maxDepth` removes levels). EstimatedGridBytes: the
  // grid itself. EstimatedDisplayBytes: the grid once ParaView shows it (its
  // copies through the pipeline, the drawn surface).
  static double EstimatedCells(const hdt::GridSpec& grid, double leafGrids, int maxDepth);
  static uint64_t EstimatedGridBytes(uint64_t cells);
  static uint64_t EstimatedDisplayBytes(uint64_t cells);

  // Replaces the contents of `output` with the volume. Throws hdt::Error
  // (InvalidArgument for MaxDepth < -1, BadInput for an inconsistent volume:
  // child or leaf indices out of range, wrong level sizes) before touching
  // `output`; std::bad_alloc if memory runs out. Safe on any Volume.
  static vtkHDTConversionInfo Convert(
    const hdt::Volume& volume, const vtkHDTConversionOptions& options, vtkHyperTreeGrid* output);

  // Field data: the paper's Table 1 (TreeElements, LeafGrids, LeafVoxels,
  // ActiveVoxels, InsideVoxels, PaperBitsPerActiveVoxel, TopologyBytes,
  // LeafBytes), phase times in ms (TimeMapping, TimeBranching, TimeLeaf,
  // TimeClassify, TimeTotal), Backend, Resolution, Height, RootGridSize,
  // LeafGridSize, VoxelSize, Origin, SurfaceOnly, ClosedMesh, Triangles,
  // DegenerateTriangles, Threads. Replaces arrays of the same names. Convert
  // adds DisplayDepth (the depth cut used) and FullDepth.
  static void AddFieldData(const hdt::Volume& volume, vtkFieldData* fieldData);

  // The state rule above: `voxels` voxels of which `surface` are surface and
  // `inside` inside.
  // (hdt::aggregateState, shared with the coarsened image of vtkHDTToImage.)
  static unsigned char AggregateState(uint64_t voxels, uint64_t surface, uint64_t inside);
};
