// hdt::Volume -> vtkHyperTreeGrid.
//
// How it is fast: one tree per root cell, each written once, breadth first, as a
// byte per vertex (state, refined, masked) by a per-tree walk that reads the HDT
// directly (element words, 2-bit leaf rows with popcounts); then one pass packs
// the bytes into the three output arrays, sized once; then VTK builds each tree
// from the "refined" bits with BuildFromBreadthFirstOrderDescriptor, using
// implicit global indices (SetGlobalIndexStart), so the cell data needs no
// index map and no cursor ever visits a vertex.
//
// The descriptor contract (VTK 9.2, vtkCompactHyperTree): one bit per vertex
// in breadth-first order, 1 = refined, starting at the root and covering every
// depth but the deepest (whose bits would all be 0 and would make VTK count one
// depth too many). Vertex j of a tree (breadth-first) gets global index
// start + j. Here the descriptor array is indexed by global index, so a tree's
// bits start at its own global offset.
#include "vtkHDTHyperTreeGridConversion.h"

#include "hdt/error.hpp"
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
#include "vtkStringArray.h"
#include "vtkTypeUInt64Array.h"
#include "vtkUnsignedCharArray.h"

#include <tbb/blocked_range.h>
#include <tbb/combinable.h>
#include <tbb/enumerable_thread_specific.h>
#include <tbb/parallel_for.h>
#include <tbb/task_arena.h>

#include <algorithm>
#include <atomic>
#include <chrono>
#include <cmath>
#include <mutex>
#include <string>

namespace
{
using Clock = std::chrono::steady_clock;
double msSince(Clock::time_point t0)
{
  return std::chrono::duration<double, std::milli>(Clock::now() - t0).count();
}

// Per-vertex code of the walk: bits 0-1 the state, then two flags.
constexpr uint8_t kStateBits = 3;
constexpr uint8_t kRefined = 4;
constexpr uint8_t kMasked = 8;

constexpr uint64_t kLowLanes = 0x5555555555555555ull; // bit 0 of every 2-bit voxel

int log2Exact(int v)
{
  int l = 0;
  while ((1 << l) < v)
  {
    ++l;
  }
  return l;
}

// Row (y, z) of an L^3 leaf as 2L bits, voxel x at bits 2x (inside) and 2x+1
// (surface); types.hpp's layout puts a row in half a word (L = 8), one word
// (16) or two words (32).
inline uint64_t leafRow(const uint32_t* words, int L, int y, int z)
{
  const uint32_t v = uint32_t(L) * uint32_t(y + L * z);
  switch (L)
  {
    case 8:
      return (words[v >> 4] >> (2 * (v & 15u))) & 0xFFFFu;
    case 16:
      return words[v >> 4];
    default:
      return uint64_t(words[v >> 4]) | (uint64_t(words[(v >> 4) + 1]) << 32);
  }
}

struct Tally
{
  uint64_t voxels = 0;
  uint64_t surface = 0; // only "any" matters for the state; counted where cheap
  uint64_t inside = 0;
  void add(const Tally& o)
  {
    voxels += o.voxels;
    surface += o.surface;
    inside += o.inside;
  }
};

// The k^3 octant of a leaf at (ox, oy, oz).
inline Tally octantTally(const uint32_t* words, int L, int ox, int oy, int oz, int k)
{
  const uint64_t lanes = (k == 32 ? ~0ull : ((1ull << (2 * k)) - 1)) & kLowLanes;
  uint64_t surface = 0;
  uint64_t inside = 0;
  for (int z = oz; z < oz + k; ++z)
  {
    for (int y = oy; y < oy + k; ++y)
    {
      const uint64_t r = leafRow(words, L, y, z) >> (2 * ox);
      surface |= (r >> 1) & lanes;
      inside += uint64_t(__builtin_popcountll(r & lanes));
    }
  }
  Tally t;
  t.voxels = uint64_t(k) * k * k;
  t.surface = surface ? 1 : 0;
  t.inside = inside;
  return t;
}

// A whole leaf, counted exactly (used only on the rare slow path).
Tally leafTally(const uint32_t* words, int L)
{
  Tally t;
  t.voxels = uint64_t(L) * L * L;
  for (uint32_t i = 0; i < hdt::leafWordCount(L); ++i)
  {
    t.surface += uint64_t(__builtin_popcount((words[i] >> 1) & 0x55555555u));
    t.inside += uint64_t(__builtin_popcount(words[i] & 0x55555555u));
  }
  return t;
}

// What every walker needs, computed once.
struct Context
{
  const hdt::Volume* volume = nullptr;
  int L = 0;
  int leafLevels = 0; // log2(L)
  int height = 0;
  int depthCut = 0; // deepest depth emitted
  bool mask = false;
  uint64_t leafCount = 0;
  // For Branch elements: does any voxel below it lie on the surface? For a
  // correct build always yes; computed so that the state is exact regardless.
  std::vector<uint8_t> elementSurface;

  // Exact tally of an element's voxels (slow path for Branch elements with no
  // surface voxel below them, which a correct build never has).
  Tally elementTally(uint64_t index, int level) const
  {
    const hdt::ElementWord w = this->volume->elements[index];
    const uint64_t edge = uint64_t(this->volume->grid.elementVoxels(level));
    Tally t;
    switch (hdt::elementState(w))
    {
      case hdt::ElementState::Empty:
        t.voxels = edge * edge * edge;
        break;
      case hdt::ElementState::Full:
        t.voxels = t.inside = edge * edge * edge;
        break;
      case hdt::ElementState::Boundary:
        t = leafTally(this->volume->leaf(hdt::elementPayload(w)), this->L);
        break;
      case hdt::ElementState::Branch:
        for (uint32_t c = 0; c < 8; ++c)
        {
          t.add(this->elementTally(uint64_t(hdt::elementPayload(w)) + c, level + 1));
        }
        break;
    }
    return t;
  }
};

// Checks the volume's structure (so the walk can trust every index) and fills
// Context::elementSurface bottom-up, level by level.
void prepareContext(const hdt::Volume& v, Context& ctx)
{
  const hdt::GridSpec& g = v.grid;
  auto bad = [](const std::string& what) {
    throw hdt::Error(hdt::ErrorKind::BadInput, "inconsistent HDT volume: " + what);
  };
  if (g.leafSize != 8 && g.leafSize != 16 && g.leafSize != 32)
  {
    bad("leaf size " + std::to_string(g.leafSize) + " is not 8, 16 or 32");
  }
  if (g.rootGrid < 1 || g.height < 0 || g.height > 16 ||
    int64_t(g.rootGrid) * (int64_t(1) << g.height) * g.leafSize != g.resolution)
  {
    bad("resolution " + std::to_string(g.resolution) + " is not R * 2^h * L");
  }
  if (!(g.voxelSize > 0) || !std::isfinite(g.voxelSize) || !std::isfinite(g.origin[0]) ||
    !std::isfinite(g.origin[1]) || !std::isfinite(g.origin[2]))
  {
    bad("voxel size or origin is not finite");
  }
  const uint64_t R = uint64_t(g.rootGrid);
  if (v.levelStart.size() != size_t(g.height) + 2 || v.levelStart[0] != 0 ||
    v.levelStart.back() != v.elements.size() || v.levelStart[1] != R * R * R)
  {
    bad("level table does not match the element array and the root grid");
  }
  for (size_t k = 0; k + 1 < v.levelStart.size(); ++k)
  {
    if (v.levelStart[k] > v.levelStart[k + 1])
    {
      bad("level table is not increasing");
    }
  }
  const uint32_t wordsPerLeaf = hdt::leafWordCount(g.leafSize);
  if (v.leafWords.size() % wordsPerLeaf != 0)
  {
    bad("leaf payload is not a whole number of leaf grids");
  }

  ctx.volume = &v;
  ctx.L = g.leafSize;
  ctx.leafLevels = log2Exact(g.leafSize);
  ctx.height = g.height;
  ctx.leafCount = v.leafCount();
  ctx.elementSurface.assign(v.elements.size(), 0);

  std::atomic<bool> failed{ false };
  std::string failure;
  std::mutex failureMutex;
  auto fail = [&](const std::string& what) {
    std::lock_guard<std::mutex> lock(failureMutex);
    if (!failed.exchange(true))
    {
      failure = what;
    }
  };

  for (int level = g.height; level >= 0; --level)
  {
    const uint64_t begin = v.levelStart[size_t(level)];
    const uint64_t end = v.levelStart[size_t(level) + 1];
    const uint64_t childBegin = level < g.height ? v.levelStart[size_t(level) + 1] : 0;
    const uint64_t childEnd = level < g.height ? v.levelStart[size_t(level) + 2] : 0;
    tbb::parallel_for(tbb::blocked_range<uint64_t>(begin, end, 4096),
      [&](const tbb::blocked_range<uint64_t>& r) {
        for (uint64_t e = r.begin(); e != r.end(); ++e)
        {
          const hdt::ElementWord w = v.elements[e];
          const uint64_t p = hdt::elementPayload(w);
          switch (hdt::elementState(w))
          {
            case hdt::ElementState::Empty:
            case hdt::ElementState::Full:
              break;
            case hdt::ElementState::Boundary:
            {
              if (level != g.height || p >= ctx.leafCount)
              {
                fail("element " + std::to_string(e) + " has a bad leaf reference");
                return;
              }
              const uint32_t* words = v.leaf(p);
              uint32_t any = 0;
              for (uint32_t i = 0; i < wordsPerLeaf; ++i)
              {
                any |= words[i];
              }
              ctx.elementSurface[e] = (any & 0xAAAAAAAAu) ? 1 : 0;
              break;
            }
            case hdt::ElementState::Branch:
            {
              if (level == g.height || p < childBegin || p + 8 > childEnd)
              {
                fail("element " + std::to_string(e) + " has a bad child reference");
                return;
              }
              uint8_t any = 0;
              for (uint64_t c = 0; c < 8; ++c)
              {
                any |= ctx.elementSurface[p + c];
              }
              ctx.elementSurface[e] = any;
              break;
            }
          }
        }
      });
    if (failed)
    {
      bad(failure);
    }
  }
}

// One vertex of the breadth-first walk: an octree element (sub == 0) or an
// octant of edge L >> sub at (x, y, z) of leaf grid `index` (sub >= 1).
struct Node
{
  uint32_t index;
  uint8_t sub;
  uint8_t x, y, z;
};

// Walks one tree breadth first and writes a code byte per vertex.
class TreeWalker
{
public:
  explicit TreeWalker(const Context& ctx)
    : Ctx(ctx)
    , DepthCounts(size_t(ctx.depthCut) + 1, 0)
  {
  }

  // Returns the number of described vertices (all but the deepest depth).
  uint64_t Walk(uint32_t root, std::vector<uint8_t>& codes)
  {
    const hdt::Volume& v = *this->Ctx.volume;
    const int L = this->Ctx.L;
    const int leafLevels = this->Ctx.leafLevels;
    const bool mask = this->Ctx.mask;
    codes.clear();
    this->Current.assign(1, Node{ root, 0, 0, 0, 0 });
    uint64_t described = 0;
    for (int depth = 0; !this->Current.empty(); ++depth)
    {
      const bool canRefine = depth < this->Ctx.depthCut;
      this->Next.clear();
      for (const Node& n : this->Current)
      {
        uint8_t state = 0;
        bool refine = false;
        if (n.sub == 0)
        {
          const hdt::ElementWord w = v.elements[n.index];
          const uint32_t p = hdt::elementPayload(w);
          switch (hdt::elementState(w))
          {
            case hdt::ElementState::Empty:
              state = 0;
              break;
            case hdt::ElementState::Full:
              state = 1;
              break;
            case hdt::ElementState::Branch:
            {
              if (this->Ctx.elementSurface[n.index])
              {
                state = 2;
              }
              else
              {
                const Tally t = this->Ctx.elementTally(n.index, depth);
                state = vtkHDTToHyperTreeGrid::AggregateState(t.voxels, t.surface, t.inside);
              }
              refine = canRefine;
              if (refine)
              {
                for (uint32_t c = 0; c < 8; ++c)
                {
                  this->Next.push_back(Node{ p + c, 0, 0, 0, 0 });
                }
              }
              break;
            }
            case hdt::ElementState::Boundary:
            {
              const Tally t = octantTally(v.leaf(p), L, 0, 0, 0, L);
              state = vtkHDTToHyperTreeGrid::AggregateState(t.voxels, t.surface, t.inside);
              refine = canRefine && (t.surface || (t.inside && t.inside < t.voxels));
              if (refine)
              {
                this->PushOctants(p, 1, 0, 0, 0, L / 2);
              }
              break;
            }
          }
        }
        else
        {
          const int k = L >> n.sub;
          const uint32_t* words = v.leaf(n.index);
          if (k == 1)
          {
            state = uint8_t(hdt::leafVoxel(words, L, n.x, n.y, n.z));
          }
          else
          {
            const Tally t = octantTally(words, L, n.x, n.y, n.z, k);
            state = vtkHDTToHyperTreeGrid::AggregateState(t.voxels, t.surface, t.inside);
            refine = canRefine && n.sub < leafLevels && (t.surface || (t.inside && t.inside < t.voxels));
            if (refine)
            {
              this->PushOctants(n.index, n.sub + 1, n.x, n.y, n.z, k / 2);
            }
          }
        }
        uint8_t code = state & kStateBits;
        if (refine)
        {
          code |= kRefined;
        }
        else if (mask && state == 0)
        {
          code |= kMasked;
        }
        codes.push_back(code);
      }
      this->DepthCounts[size_t(depth)] += vtkIdType(this->Current.size());
      if (!this->Next.empty())
      {
        described = codes.size();
      }
      this->Current.swap(this->Next);
    }
    return described;
  }

  std::vector<vtkIdType> DepthCounts;

private:
  void PushOctants(uint32_t leaf, int sub, int x, int y, int z, int half)
  {
    for (int c = 0; c < 8; ++c)
    {
      this->Next.push_back(Node{ leaf, uint8_t(sub), uint8_t(x + (c & 1) * half),
        uint8_t(y + ((c >> 1) & 1) * half), uint8_t(z + ((c >> 2) & 1) * half) });
    }
  }

  const Context& Ctx;
  std::vector<Node> Current;
  std::vector<Node> Next;
};

template <typename ArrayT, typename T>
void setSingle(vtkFieldData* fd, const char* name, T value)
{
  vtkNew<ArrayT> a;
  a->SetName(name);
  a->SetNumberOfTuples(1);
  a->SetValue(0, value);
  fd->AddArray(a); // replaces an array of the same name
}

} // namespace

//------------------------------------------------------------------------------
int vtkHDTToHyperTreeGrid::FullDepth(const hdt::Volume& volume)
{
  return volume.grid.height + log2Exact(volume.grid.leafSize);
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
  if (options.MaxDepth < -1)
  {
    throw hdt::Error(hdt::ErrorKind::InvalidArgument,
      "MaxDepth must be -1 (full depth) or at least 0 (got " + std::to_string(options.MaxDepth) +
        ")");
  }
  const int threads = options.Threads > 0 ? options.Threads : tbb::task_arena::automatic;
  tbb::task_arena arena(threads);

  Context ctx;
  arena.execute([&] { prepareContext(volume, ctx); });
  const int fullDepth = FullDepth(volume);
  ctx.depthCut = options.MaxDepth < 0 ? fullDepth : std::min(options.MaxDepth, fullDepth);
  ctx.mask = options.MaskOutside;

  const hdt::GridSpec& g = volume.grid;
  const uint64_t R = uint64_t(g.rootGrid);
  const uint64_t trees = R * R * R;

  // 1. Walk every tree (in parallel) into its own code vector.
  std::vector<std::vector<uint8_t>> codes(trees);
  std::vector<uint64_t> described(trees);
  tbb::enumerable_thread_specific<TreeWalker> walkers([&] { return TreeWalker(ctx); });
  arena.execute([&] {
    tbb::parallel_for(tbb::blocked_range<uint64_t>(0, trees, 8),
      [&](const tbb::blocked_range<uint64_t>& r) {
        TreeWalker& walker = walkers.local();
        for (uint64_t t = r.begin(); t != r.end(); ++t)
        {
          described[t] = walker.Walk(uint32_t(t), codes[t]);
        }
      });
  });

  vtkHDTConversionInfo info;
  info.Trees = vtkIdType(trees);
  info.CellsPerDepth.assign(size_t(ctx.depthCut) + 1, 0);
  for (const TreeWalker& w : walkers)
  {
    for (size_t d = 0; d < w.DepthCounts.size(); ++d)
    {
      info.CellsPerDepth[d] += w.DepthCounts[d];
    }
  }
  while (info.CellsPerDepth.size() > 1 && info.CellsPerDepth.back() == 0)
  {
    info.CellsPerDepth.pop_back();
  }
  info.Depth = int(info.CellsPerDepth.size()) - 1;

  std::vector<vtkIdType> offsets(trees + 1, 0);
  for (uint64_t t = 0; t < trees; ++t)
  {
    offsets[t + 1] = offsets[t] + vtkIdType(codes[t].size());
  }
  const vtkIdType total = offsets[trees];
  info.Cells = total;

  // 2. Output arrays, sized once, filled in byte-aligned chunks of the global
  // vertex range (a tree's bits need not start on a byte).
  vtkNew<vtkUnsignedCharArray> states;
  states->SetName("VoxelState");
  states->SetNumberOfTuples(total);
  vtkNew<vtkBitArray> descriptor;
  descriptor->SetNumberOfTuples(total);
  vtkNew<vtkBitArray> mask;
  if (options.MaskOutside)
  {
    mask->SetName("MaskOutside");
    mask->SetNumberOfTuples(total);
  }
  unsigned char* stateOut = states->GetPointer(0);
  unsigned char* descOut = descriptor->GetPointer(0);
  unsigned char* maskOut = options.MaskOutside ? mask->GetPointer(0) : nullptr;
  constexpr vtkIdType chunk = vtkIdType(1) << 16; // a multiple of 8
  tbb::combinable<vtkIdType> leafCells([] { return vtkIdType(0); });
  tbb::combinable<vtkIdType> maskedCells([] { return vtkIdType(0); });
  arena.execute([&] {
    tbb::parallel_for(tbb::blocked_range<vtkIdType>(0, (total + chunk - 1) / chunk, 1),
      [&](const tbb::blocked_range<vtkIdType>& r) {
        vtkIdType leaves = 0, masked = 0;
        for (vtkIdType c = r.begin(); c != r.end(); ++c)
        {
          const vtkIdType begin = c * chunk;
          const vtkIdType end = std::min(total, begin + chunk);
          // The tree holding `begin`: the last offset <= begin (trees are never empty).
          uint64_t t =
            uint64_t(std::upper_bound(offsets.begin(), offsets.end(), begin) - offsets.begin()) -
            1;
          const uint8_t* src = codes[t].data() + (begin - offsets[t]);
          const uint8_t* srcEnd = codes[t].data() + codes[t].size();
          for (vtkIdType i = begin; i < end; i += 8)
          {
            unsigned char d = 0, m = 0;
            const int n = int(std::min<vtkIdType>(8, end - i));
            for (int b = 0; b < n; ++b)
            {
              while (src == srcEnd)
              {
                ++t;
                src = codes[t].data();
                srcEnd = src + codes[t].size();
              }
              const uint8_t code = *src++;
              stateOut[i + b] = code & kStateBits;
              d |= ((code & kRefined) ? 0x80u : 0u) >> b;
              m |= ((code & kMasked) ? 0x80u : 0u) >> b;
            }
            descOut[i >> 3] = d;
            if (maskOut)
            {
              maskOut[i >> 3] = m;
            }
            leaves += n - __builtin_popcount(d);
            masked += __builtin_popcount(m);
          }
        }
        leafCells.local() += leaves;
        maskedCells.local() += masked;
      });
  });
  info.LeafCells = leafCells.combine(std::plus<vtkIdType>());
  info.MaskedCells = maskedCells.combine(std::plus<vtkIdType>());
  codes.clear();
  codes.shrink_to_fit();

  // 3. The grid and its trees. Trees are created one by one (the grid keeps
  // them in a std::map), then built from their descriptors in parallel: each
  // build touches only its own tree.
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

  const auto tBuild = Clock::now();
  std::vector<vtkHyperTree*> built(trees, nullptr);
  vtkNew<vtkHyperTreeGridNonOrientedCursor> cursor;
  for (uint64_t t = 0; t < trees; ++t)
  {
    output->InitializeNonOrientedCursor(cursor, vtkIdType(t), true);
    cursor->SetGlobalIndexStart(offsets[t]);
    built[t] = cursor->GetTree();
  }
  arena.execute([&] {
    tbb::parallel_for(tbb::blocked_range<uint64_t>(0, trees, 16),
      [&](const tbb::blocked_range<uint64_t>& r) {
        for (uint64_t t = r.begin(); t != r.end(); ++t)
        {
          built[t]->BuildFromBreadthFirstOrderDescriptor(
            descriptor, vtkIdType(described[t]), offsets[t]);
        }
      });
  });
  info.TreeBuildMilliseconds = msSince(tBuild);

  output->GetCellData()->SetScalars(states);
  output->SetMask(options.MaskOutside ? mask.Get() : nullptr);
  if (options.AddFieldData)
  {
    AddFieldData(volume, output->GetFieldData());
  }
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
  setSingle<vtkDoubleArray>(fd, "VoxelSize", volume.grid.voxelSize);
  vtkNew<vtkDoubleArray> origin;
  origin->SetName("Origin");
  origin->SetNumberOfComponents(3);
  origin->SetNumberOfTuples(1);
  origin->SetTypedTuple(0, volume.grid.origin.data());
  fd->AddArray(origin);
}
