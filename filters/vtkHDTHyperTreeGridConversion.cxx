// hdt::Volume -> vtkHyperTreeGrid.
//
// How it is fast:
//  1. one tree per root cell, each walked once (trees in parallel) into a byte
//     per vertex (state, refined, masked) in breadth-first order, reading the
//     HDT directly: element words for the octree, and per leaf grid a small
//     pyramid of octant flags built from its 2-bit rows;
//  2. one pass packs the bytes into the output arrays, each sized once:
//     VoxelState and the mask indexed by global vertex, and the descriptor
//     ("refined" bits) per tree, starting on a byte;
//  3. VTK builds each tree from its bits (trees in parallel; only their
//     creation in the grid's std::map is sequential), with implicit global
//     indices (SetGlobalIndexStart): no index map, no cursor visits a vertex.
//
// The descriptor contract (VTK 9.2, vtkCompactHyperTree, checked in its
// source): one bit per vertex in breadth-first order, 1 = refined, from the
// root through every depth but the deepest (whose bits would all be 0, and
// BuildFromBreadthFirstOrderDescriptor would count one depth too many).
// Vertex j of a tree (breadth-first) gets global index start + j, so cell
// data filled in this order needs no mapping. InitializeForReader takes the
// same bits (from index 0) plus the depth count, the vertex count and the
// size of the deepest depth, and sizes its child table once instead of
// growing it bit by bit: about twice as fast, and the default.
#include "vtkHDTHyperTreeGridConversion.h"
#include "vtkHDTLabelArrays.h"
#include "vtkHDTVoxelArrays.h"

#include "vtkHDTTreeWalk.h"

#include "hdt/error.hpp"
#include "hdt/host_memory.hpp"
#include "hdt/region.hpp"
#include "hdt/volume.hpp"

#include "vtkBitArray.h"
#include "vtkCellData.h"
#include "vtkDoubleArray.h"
#include "vtkFieldData.h"
#include "vtkHyperTree.h"
#include "vtkHyperTreeGrid.h"
#include "vtkHyperTreeGridNonOrientedCursor.h"
#include "vtkIntArray.h"
#include "vtkNew.h"
#include "vtkSmartPointer.h"
#include "vtkStringArray.h"
#include "vtkTypeUInt64Array.h"
#include "vtkUnsignedCharArray.h"

#include <tbb/blocked_range.h>
#include <tbb/enumerable_thread_specific.h>
#include <tbb/parallel_for.h>
#include <tbb/task_arena.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstring>
#include <limits>
#include <string>

using namespace hdt_htg; // the walk's internals (vtkHDTTreeWalk.h)

namespace
{
using Clock = std::chrono::steady_clock;
double msSince(Clock::time_point t0)
{
  return std::chrono::duration<double, std::milli>(Clock::now() - t0).count();
}

template <typename ArrayT, typename T>
void setSingle(vtkFieldData* fd, const char* name, T value)
{
  vtkNew<ArrayT> a;
  a->SetName(name);
  a->SetNumberOfTuples(1);
  a->SetValue(0, value);
  fd->AddArray(a); // replaces an array of the same name
}


// Stage 1's result: each tree's codes (breadth-first), its shape, and where
// its vertices (global index) and descriptor bytes start; one extra entry at
// the end holds the totals.
struct WalkedTrees
{
  std::vector<std::vector<uint8_t>> Codes;
  std::vector<TreeShape> Shapes;
  std::vector<vtkIdType> Offsets;
  std::vector<vtkIdType> DescBytes;
  vtkIdType Total() const { return this->Offsets.back(); }
};

// Stage 2's result: VoxelState, the mask (null without MaskOutside) and the
// trees' "refined" bits, each tree starting on a byte.
struct PackedArrays
{
  vtkSmartPointer<vtkUnsignedCharArray> States;
  vtkSmartPointer<vtkBitArray> Mask;
  vtkSmartPointer<vtkBitArray> Descriptor;
};

//------------------------------------------------------------------------------
// Stage 1 of Convert: every tree walked (trees in parallel) into its own code
// vector, one byte per vertex in breadth-first order (state, refined, masked),
// then where each tree's vertices and descriptor bytes start.
WalkedTrees walkTrees(const Context& ctx, uint64_t first, uint64_t trees, tbb::task_arena& arena,
  vtkHDTConversionInfo& info)
{
  const auto tWalk = Clock::now();
  WalkedTrees w;
  w.Codes.resize(trees);
  w.Shapes.resize(trees);
  tbb::enumerable_thread_specific<TreeWalker> walkers([&] { return TreeWalker(ctx); });
  arena.execute([&] {
    tbb::parallel_for(tbb::blocked_range<uint64_t>(0, trees, 8),
      [&](const tbb::blocked_range<uint64_t>& r) {
        TreeWalker& walker = walkers.local();
        for (uint64_t t = r.begin(); t != r.end(); ++t)
        {
          w.Shapes[t] = walker.Walk(uint32_t(first + t), w.Codes[t]);
        }
      });
  });

  info.WalkMilliseconds = msSince(tWalk);
  info.Trees = vtkIdType(trees);
  info.CellsPerDepth.assign(size_t(ctx.depthCut) + 1, 0);
  for (const TreeWalker& walker : walkers)
  {
    for (size_t d = 0; d < walker.DepthCounts.size(); ++d)
    {
      info.CellsPerDepth[d] += walker.DepthCounts[d];
    }
    info.LeafCells += walker.LeafCells;
    info.MaskedCells += walker.MaskedCells;
  }
  while (info.CellsPerDepth.size() > 1 && info.CellsPerDepth.back() == 0)
  {
    info.CellsPerDepth.pop_back();
  }
  info.Depth = int(info.CellsPerDepth.size()) - 1;

  // Global index of each tree's first vertex, and where each tree's
  // descriptor starts (in bytes: every tree's bits start on a byte, so trees
  // can be packed and built independently).
  w.Offsets.assign(trees + 1, 0);
  w.DescBytes.assign(trees + 1, 0);
  for (uint64_t t = 0; t < trees; ++t)
  {
    // VTK's compact trees index their vertices with 32-bit integers.
    if (w.Shapes[t].Vertices >= uint64_t(std::numeric_limits<unsigned int>::max()))
    {
      throw hdt::Error(hdt::ErrorKind::OutOfResources,
        "root cell " + std::to_string(first + t) + " would become a hyper tree of " +
          std::to_string(w.Shapes[t].Vertices) +
          " cells, more than VTK's limit of 2^32 - 1 per tree; use a larger RootGridSize or a "
          "MaxDepth");
    }
    w.Offsets[t + 1] = w.Offsets[t] + vtkIdType(w.Shapes[t].Vertices);
    w.DescBytes[t + 1] = w.DescBytes[t] + vtkIdType((w.Shapes[t].Described() + 7) / 8);
  }
  info.Cells = w.Offsets[trees];
  return w;
}

//------------------------------------------------------------------------------
// Stage 2: the output arrays, each sized once and filled in parallel from the
// codes (which it frees).
PackedArrays packArrays(WalkedTrees& w, bool maskOutside, tbb::task_arena& arena)
{
  // VoxelState and the mask are indexed by
  // global vertex and filled in byte-aligned chunks of that range (a tree
  // need not start on a byte there); the descriptor is per tree.
  const uint64_t trees = w.Shapes.size();
  const vtkIdType total = w.Total();
  PackedArrays packed;
  vtkNew<vtkUnsignedCharArray> states;
  states->SetName("VoxelState");
  states->SetNumberOfTuples(total);
  vtkNew<vtkBitArray> mask;
  if (maskOutside)
  {
    mask->SetName("MaskOutside");
    mask->SetNumberOfTuples(total);
  }
  vtkNew<vtkBitArray> descriptor;
  descriptor->SetNumberOfTuples(std::max<vtkIdType>(1, 8 * w.DescBytes[trees]));
  unsigned char* stateOut = states->GetPointer(0);
  unsigned char* maskOut = maskOutside ? mask->GetPointer(0) : nullptr;
  unsigned char* descOut = descriptor->GetPointer(0);
  constexpr vtkIdType chunk = vtkIdType(1) << 16; // a multiple of 8
  const vtkIdType chunks = (total + chunk - 1) / chunk;
  tbb::enumerable_thread_specific<std::vector<uint8_t>> buffers(size_t(chunk) + 8);
  arena.execute([&] {
    // Work items [0, chunks): state and mask chunks; [chunks, chunks + trees): descriptors.
    tbb::parallel_for(tbb::blocked_range<vtkIdType>(0, chunks + vtkIdType(trees), 1),
      [&](const tbb::blocked_range<vtkIdType>& r) {
        uint8_t* buf = buffers.local().data();
        for (vtkIdType c = r.begin(); c != r.end(); ++c)
        {
          if (c >= chunks)
          {
            const uint64_t t = uint64_t(c - chunks);
            const uint64_t n = w.Shapes[t].Described();
            const uint8_t* src = w.Codes[t].data();
            unsigned char* out = descOut + w.DescBytes[t];
            for (uint64_t i = 0; i + 8 <= n; i += 8)
            {
              *out++ = gatherBits(src + i, 2);
            }
            if (n % 8)
            {
              uint8_t tail[8] = { 0, 0, 0, 0, 0, 0, 0, 0 };
              std::memcpy(tail, src + (n & ~uint64_t(7)), n % 8);
              *out = gatherBits(tail, 2);
            }
            continue;
          }
          const vtkIdType begin = c * chunk;
          const size_t n = size_t(std::min(total, begin + chunk) - begin);
          // Gather the chunk's w.Codes from the trees that overlap it; the tree
          // holding `begin` is the last one whose offset is <= begin.
          uint64_t t =
            uint64_t(std::upper_bound(w.Offsets.begin(), w.Offsets.end(), begin) - w.Offsets.begin()) -
            1;
          size_t pos = size_t(begin - w.Offsets[t]);
          for (size_t filled = 0; filled < n; ++t, pos = 0)
          {
            const size_t take = std::min(n - filled, w.Codes[t].size() - pos);
            std::memcpy(buf + filled, w.Codes[t].data() + pos, take);
            filled += take;
          }
          std::memset(buf + n, 0, 8);
          unsigned char* st = stateOut + begin;
          for (size_t i = 0; i < n; ++i)
          {
            st[i] = buf[i] & kStateBits;
          }
          if (maskOut)
          {
            unsigned char* mOut = maskOut + begin / 8;
            for (size_t g8 = 0; g8 < (n + 7) / 8; ++g8)
            {
              mOut[g8] = gatherBits(buf + 8 * g8, 3);
            }
          }
        }
      });
  });
  w.Codes.clear();
  w.Codes.shrink_to_fit();
  packed.States = states;
  packed.Mask = maskOutside ? mask.Get() : nullptr;
  packed.Descriptor = descriptor;
  return packed;

}

//------------------------------------------------------------------------------
// Stage 3: the grid and its trees, VTK building each tree from its bits.
void buildGrid(const hdt::Volume& volume, uint64_t first, const WalkedTrees& w, const PackedArrays& packed,
  vtkHDTConversionOptions::TreeBuildMethod method, tbb::task_arena& arena, vtkHyperTreeGrid* output)
{
  // Trees are created one by one (the grid keeps
  // them in a std::map), then built from their descriptors in parallel: each
  // build touches only its own tree.
  const hdt::GridSpec& g = volume.grid;
  const uint64_t R = uint64_t(g.rootGrid);
  const uint64_t trees = w.Shapes.size();
  unsigned char* descOut = packed.Descriptor->GetPointer(0);
  vtkBitArray* descriptor = packed.Descriptor;
  output->Initialize();
  output->SetDimensions(int(R) + 1, int(R) + 1, int(R) + 1);
  output->SetBranchFactor(2);
  output->SetTransposedRootIndexing(false); // tree index i + R (j + R k), as HDT's root grid
  vtkNew<vtkDoubleArray> coords[3];
  const double rootEdge = g.voxelSize * double(g.rootCellVoxels());
  for (int a = 0; a < 3; ++a)
  {
    coords[a]->SetNumberOfTuples(vtkIdType(R) + 1);
    for (uint64_t i = 0; i <= R; ++i)
    {
      coords[a]->SetValue(vtkIdType(i), g.origin[size_t(a)] + double(i) * rootEdge);
    }
  }
  output->SetXCoordinates(coords[0]);
  output->SetYCoordinates(coords[1]);
  output->SetZCoordinates(coords[2]);

  std::vector<vtkHyperTree*> built(trees, nullptr);
  vtkNew<vtkHyperTreeGridNonOrientedCursor> cursor;
  for (uint64_t t = 0; t < trees; ++t)
  {
    output->InitializeNonOrientedCursor(cursor, vtkIdType(first + t), true);
    cursor->SetGlobalIndexStart(w.Offsets[t]);
    built[t] = cursor->GetTree();
  }
  const bool forReader = method == vtkHDTConversionOptions::INITIALIZE_FOR_READER;
  // InitializeForReader reads its bits from index 0: a per-thread bit array
  // pointed at the tree's bytes (no copy; `save` = 1, so never freed by it).
  tbb::enumerable_thread_specific<vtkSmartPointer<vtkBitArray>> views(
    [] { return vtkSmartPointer<vtkBitArray>::New(); });
  arena.execute([&] {
    tbb::parallel_for(tbb::blocked_range<uint64_t>(0, trees, 16),
      [&](const tbb::blocked_range<uint64_t>& r) {
        for (uint64_t t = r.begin(); t != r.end(); ++t)
        {
          const TreeShape& shape = w.Shapes[t];
          const vtkIdType bits = vtkIdType(shape.Described());
          if (!forReader)
          {
            built[t]->BuildFromBreadthFirstOrderDescriptor(descriptor, bits, 8 * w.DescBytes[t]);
          }
          else if (bits == 0)
          {
            // A single leaf: a new tree already is one.
            built[t]->InitializeForReader(1, 1, 1, nullptr, nullptr, nullptr);
          }
          else
          {
            vtkBitArray* view = views.local();
            view->SetArray(descOut + w.DescBytes[t], bits, 1);
            built[t]->InitializeForReader(vtkIdType(shape.Levels), vtkIdType(shape.Vertices),
              vtkIdType(shape.LastDepth), view, nullptr, nullptr);
          }
        }
      });
  });
  for (auto& view : views)
  {
    view->SetArray(nullptr, 0, 1); // let go of the borrowed bytes
  }

}

} // namespace

//------------------------------------------------------------------------------
int vtkHDTToHyperTreeGrid::FullDepth(const hdt::GridSpec& grid)
{
  return grid.height + log2Exact(grid.leafSize);
}

int vtkHDTToHyperTreeGrid::FullDepth(const hdt::Volume& volume)
{
  return FullDepth(volume.grid);
}

//------------------------------------------------------------------------------
int vtkHDTToHyperTreeGrid::DepthCut(const hdt::Volume& volume, int maxDepth)
{
  return DepthCut(volume.grid, maxDepth);
}

int vtkHDTToHyperTreeGrid::DepthCut(const hdt::GridSpec& grid, int maxDepth)
{
  const int fullDepth = FullDepth(grid);
  if (maxDepth == AUTO_DEPTH)
  {
    int depth = 0;
    while (depth < fullDepth &&
      (int64_t(grid.rootGrid) << (depth + 1)) <= int64_t(AutoDisplayResolution))
    {
      ++depth;
    }
    return depth;
  }
  return maxDepth < 0 ? fullDepth : std::min(maxDepth, fullDepth);
}

//------------------------------------------------------------------------------
double vtkHDTToHyperTreeGrid::EstimatedCells(const hdt::GridSpec& grid, double leafGrids, int maxDepth)
{
  const int leafDepths = log2Exact(grid.leafSize);
  const int keptDepths = std::max(0, std::min(leafDepths, DepthCut(grid, maxDepth) - grid.height));
  const double perLeaf = (std::pow(8.0, keptDepths + 1) - 1) / 7;
  return std::pow(double(grid.rootGrid), 3) + 2.7 * leafGrids + leafGrids * perLeaf;
}

uint64_t vtkHDTToHyperTreeGrid::EstimatedGridBytes(uint64_t cells)
{
  // Per cell: VoxelState 1 byte, the mask and descriptor bits, the tree's
  // 4-byte child table and the walk's code byte: about 8 bytes.
  return cells * 8;
}

uint64_t vtkHDTToHyperTreeGrid::EstimatedDisplayBytes(uint64_t cells)
{
  // The grid, and: ParaView keeps two shallow copies (no new arrays) and
  // vtkHyperTreeGridGeometry emits up to one quad (4 points of 24 bytes
  // shared, 5 cell ids of 8 bytes, a state) per leaf cell: ~40 bytes.
  return EstimatedGridBytes(cells) + cells * 40;
}

//------------------------------------------------------------------------------
std::string vtkHDTToHyperTreeGrid::DrawingWarning(const vtkHDTConversionInfo& info)
{
  // vtkHyperTreeGridGeometry extracts about 0.16 M polygons a second on one
  // core (bench/results/pvui.md): 10 M leaf cells is a minute or more.
  constexpr vtkIdType drawable = 10000000;
  if (info.LeafCells <= drawable)
  {
    return std::string();
  }
  return "the hyper tree grid has " + std::to_string(info.LeafCells) + " leaf cells at depth " +
    std::to_string(info.Depth) +
    ": drawing it as a surface in ParaView can take minutes. Use Max Depth Auto, the voxel "
    "surface output, or HDT To Image instead";
}

//------------------------------------------------------------------------------
unsigned char vtkHDTToHyperTreeGrid::AggregateState(uint64_t voxels, uint64_t surface, uint64_t inside)
{
  return static_cast<unsigned char>(hdt::aggregateState(voxels, surface, inside));
}

//------------------------------------------------------------------------------
vtkHDTConversionInfo vtkHDTToHyperTreeGrid::Convert(
  const hdt::Volume& volume, const vtkHDTConversionOptions& options, vtkHyperTreeGrid* output)
{
  const auto t0 = Clock::now();
  if (!output)
  {
    throw hdt::Error(hdt::ErrorKind::InvalidArgument, "no output vtkHyperTreeGrid given");
  }
  if (options.MaxDepth < AUTO_DEPTH)
  {
    throw hdt::Error(hdt::ErrorKind::InvalidArgument,
      "MaxDepth must be -2 (automatic), -1 (full depth) or at least 0 (got " +
        std::to_string(options.MaxDepth) + ")");
  }
  const int threads = options.Threads > 0 ? options.Threads : tbb::task_arena::automatic;
  tbb::task_arena arena(threads);

  vtkHDTConversionInfo info;
  const int fullDepth = FullDepth(volume);
  const int depthCut = DepthCut(volume, options.MaxDepth);
  const uint64_t R = uint64_t(volume.grid.rootGrid);
  const uint64_t first = std::min(options.FirstTree, R * R * R);
  const uint64_t trees = std::max(first, std::min(options.EndTree, R * R * R)) - first;
  // A process's share of a distributed volume carries the job's statistics
  // (vtkHDTDistributedBuild); a share of every tree holds the whole volume.
  const hdt::StatisticsOf statistics =
    trees == R * R * R ? hdt::StatisticsOf::Contents : hdt::StatisticsOf::WholeJob;
  Context ctx;
  arena.execute([&] { prepareContext(volume, depthCut, options.MaskOutside, statistics, ctx); });

  info.ContextMilliseconds = msSince(t0);

  // 1. Walk the trees; refuse a grid too large to show before allocating it.
  WalkedTrees walked = walkTrees(ctx, first, trees, arena, info);
  const vtkIdType total = walked.Total();
  const uint64_t limit = options.MemoryLimitBytes ? options.MemoryLimitBytes : hdt::availableHostBytes();
  if (limit && EstimatedDisplayBytes(uint64_t(total)) > limit)
  {
    throw hdt::Error(hdt::ErrorKind::OutOfResources,
      "the hyper tree grid would have " + std::to_string(total) + " cells (depth " +
        std::to_string(depthCut) + "), about " +
        std::to_string(EstimatedDisplayBytes(uint64_t(total)) >> 20) +
        " MiB once shown, more than the " + std::to_string(limit >> 20) +
        " MiB available: choose a smaller Max Depth (Auto shows at most " +
        std::to_string(AutoDisplayResolution) + " cells per axis)");
  }

  // 2. Pack the output arrays; 3. build the grid.
  const auto tPack = Clock::now();
  const PackedArrays packed = packArrays(walked, options.MaskOutside, arena);
  info.PackMilliseconds = msSince(tPack);

  const auto tBuild = Clock::now();
  buildGrid(volume, first, walked, packed, options.TreeBuild, arena, output);
  info.TreeBuildMilliseconds = msSince(tBuild);

  output->GetCellData()->SetScalars(packed.States);
  output->SetMask(packed.Mask);
  if (options.AddFieldData)
  {
    AddFieldData(volume, output->GetFieldData());
    setSingle<vtkIntArray>(output->GetFieldData(), "DisplayDepth", depthCut);
    setSingle<vtkIntArray>(output->GetFieldData(), "FullDepth", fullDepth);
  }
  vtkHDTAddLabelArrays(volume, output); // part labels, when the volume has them
  vtkHDTAddVoxelArrays(volume, output); // transferred mesh data, when the volume has them
  info.Milliseconds = msSince(t0);
  return info;
}

//------------------------------------------------------------------------------
void vtkHDTToHyperTreeGrid::AddFieldData(const hdt::Volume& volume, vtkFieldData* fd)
{
  if (!fd)
  {
    return;
  }
  const hdt::Statistics& s = volume.stats;
  setSingle<vtkTypeUInt64Array>(fd, "TreeElements", s.treeElements);
  setSingle<vtkTypeUInt64Array>(fd, "LeafGrids", s.leafGrids);
  setSingle<vtkTypeUInt64Array>(fd, "LeafVoxels", s.leafVoxels);
  setSingle<vtkTypeUInt64Array>(fd, "ActiveVoxels", s.activeVoxels);
  setSingle<vtkTypeUInt64Array>(fd, "InsideVoxels", s.insideVoxels);
  setSingle<vtkDoubleArray>(fd, "PaperBitsPerActiveVoxel", s.paperBitsPerActiveVoxel);
  setSingle<vtkTypeUInt64Array>(fd, "TopologyBytes", s.topologyBytes);
  setSingle<vtkTypeUInt64Array>(fd, "LeafBytes", s.leafBytes);
  setSingle<vtkTypeUInt64Array>(fd, "Triangles", s.triangles);
  setSingle<vtkTypeUInt64Array>(fd, "DegenerateTriangles", s.degenerateTriangles);
  setSingle<vtkDoubleArray>(fd, "TimeMapping", s.time.mapping);
  setSingle<vtkDoubleArray>(fd, "TimeBranching", s.time.branching);
  setSingle<vtkDoubleArray>(fd, "TimeLeaf", s.time.leaf);
  setSingle<vtkDoubleArray>(fd, "TimeClassify", s.time.classify);
  setSingle<vtkDoubleArray>(fd, "TimeTotal", s.time.total);
  setSingle<vtkStringArray>(fd, "Backend", s.backend);
  setSingle<vtkIntArray>(fd, "Threads", s.threads);
  setSingle<vtkIntArray>(fd, "Resolution", volume.grid.resolution);
  setSingle<vtkIntArray>(fd, "Height", volume.grid.height);
  setSingle<vtkIntArray>(fd, "RootGridSize", volume.grid.rootGrid);
  setSingle<vtkIntArray>(fd, "LeafGridSize", volume.grid.leafSize);
  setSingle<vtkIntArray>(fd, "SurfaceOnly", volume.surfaceOnly ? 1 : 0);
  setSingle<vtkIntArray>(fd, "ClosedMesh", volume.closedMesh ? 1 : 0);
  setSingle<vtkStringArray>(fd, "InsideTest",
    volume.surfaceOnly ? std::string("none")
                       : std::string(volume.insideTest == hdt::InsideTest::WindingNumber ? "winding" : "parity"));
  setSingle<vtkTypeUInt64Array>(fd, "WindingRefinedElements", s.windingRefinedElements);
  setSingle<vtkDoubleArray>(fd, "VoxelSize", volume.grid.voxelSize);
  vtkNew<vtkDoubleArray> origin;
  origin->SetName("Origin");
  origin->SetNumberOfComponents(3);
  origin->SetNumberOfTuples(1);
  origin->SetTypedTuple(0, volume.grid.origin.data());
  fd->AddArray(origin);
}
