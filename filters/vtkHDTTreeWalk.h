// The per-tree walk of vtkHDTToHyperTreeGrid::Convert (internal to HDT::Filters).
//
// It turns one root cell of an hdt::Volume into a byte per hyper-tree vertex
// (VoxelState in bits 0-1, kRefined, kMasked) in VTK's breadth-first order:
// the octree through the core's breadth-first walk (hdt/volume_walk.hpp), the
// octants of each leaf grid from its 2-bit rows. Nothing here depends on VTK
// but vtkIdType.
#pragma once

#include "hdt/volume.hpp"
#include "hdt/volume_walk.hpp"

#include "vtkType.h"

#include <cstdint>
#include <cstring>
#include <vector>

namespace hdt_htg
{

// Per-vertex code of the walk: bits 0-1 the state, then two flags.
constexpr uint8_t kStateBits = 3;
constexpr uint8_t kRefined = 4;
constexpr uint8_t kMasked = 8;

inline int log2Exact(int v)
{
  int l = 0;
  while ((1 << l) < v)
  {
    ++l;
  }
  return l;
}

// Voxel counts of a box: `voxels` in all, `surface` and `inside` of them.
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
  Tally elementTally(const hdt::WalkedElement& e) const;
};

// Checks the volume (hdt::validateVolume, so the walk can trust every index;
// throws hdt::Error(BadInput) otherwise) and fills the context for the given cut.
// `statistics`: WholeJob for one process's piece of a distributed volume.
void prepareContext(
  const hdt::Volume& v, int depthCut, bool mask, hdt::StatisticsOf statistics, Context& ctx);

// What VTK needs to know of a tree besides its descriptor bits.
struct TreeShape
{
  uint64_t Vertices = 0;  // all depths
  uint64_t LastDepth = 0; // vertices of the deepest depth
  uint32_t Levels = 0;    // number of depths
  // Vertices with a descriptor bit: all but the deepest depth.
  uint64_t Described() const { return this->Vertices - this->LastDepth; }
};

// Eight codes (bytes) -> one byte of a bit array, the first code in the high
// bit as vtkBitArray stores it: bit `bit` of every byte gathered with one
// multiplication.
inline uint8_t gatherBits(const uint8_t* codes8, int bit)
{
  uint64_t w;
  std::memcpy(&w, codes8, 8);
  return uint8_t((((w >> bit) & 0x0101010101010101ull) * 0x8040201008040201ull) >> 56);
}

// Flags of every octant of one leaf grid, at every edge k = 2, 4, ..., L: does it
// hold a surface voxel, an inside voxel, an outside voxel? Per level, one
// triple of 64-bit words per row of octants (y, z), octant x at bit 2x (its
// first voxel's lane), built bottom-up from the leaf rows with a handful of
// word operations per row: no per-node loops over voxels, no popcounts.
class LeafPyramid
{
public:
  enum : unsigned
  {
    kSurface = 1,
    kInside = 2,
    kOutside = 4
  };

  // Computes the flags of one L^3 leaf grid (levels = log2 L); the storage is
  // reused from leaf to leaf.
  void Build(const uint32_t* words, int L, int levels);

  // Flags of the octant of edge 2^j (1 <= j <= levels) at voxel (x, y, z).
  unsigned Flags(int j, int x, int y, int z) const
  {
    const int n = this->Edge >> j;
    return flagsAt(this->Rows[this->Offset[size_t(j)] + size_t(y >> j) + size_t(n) * size_t(z >> j)],
      2 * x);
  }

  // Flags of the 8 children (edge 2^j, VTK child order) of the octant of
  // edge 2^(j+1) at voxel (x, y, z): four rows, two bits each.
  void ChildFlags(int j, int x, int y, int z, unsigned (&flags)[8]) const
  {
    const int n = this->Edge >> j;
    const Row* rows = this->Rows.data() + this->Offset[size_t(j)];
    const size_t base = size_t(y >> j) + size_t(n) * size_t(z >> j);
    const int bit0 = 2 * x;
    const int bit1 = bit0 + (2 << j);
    for (int dz = 0; dz < 2; ++dz)
    {
      for (int dy = 0; dy < 2; ++dy)
      {
        const Row& r = rows[base + size_t(dy) + size_t(n) * size_t(dz)];
        flags[2 * dy + 4 * dz] = flagsAt(r, bit0);
        flags[1 + 2 * dy + 4 * dz] = flagsAt(r, bit1);
      }
    }
  }

private:
  struct Row
  {
    uint64_t S, I, O;
  };
  static unsigned flagsAt(const Row& r, int bit)
  {
    return unsigned((r.S >> bit) & 1) | (unsigned((r.I >> bit) & 1) << 1) |
      (unsigned((r.O >> bit) & 1) << 2);
  }

  int Edge = 0; // L
  std::vector<size_t> Offset;
  std::vector<Row> Rows;
};

// Walks one tree and writes a code byte per vertex in breadth-first order.
//
// Octree depths are walked breadth first. Below them, the vertices of depth
// h + s are, in breadth-first order, the concatenation over the leaf grids (in
// their depth-h order) of each leaf's own octants at sub-level s, in that leaf's
// breadth-first order. So each leaf is walked on its own, right when its
// element is met, appending its sub-levels to per-depth buffers; only one leaf's
// flags are alive at a time.
class TreeWalker
{
public:
  explicit TreeWalker(const Context& ctx)
    : DepthCounts(size_t(ctx.depthCut) + 1, 0)
    , Ctx(ctx)
    , Depths(size_t(ctx.depthCut) + 1)
  {
  }

  // Writes the tree's codes and returns its shape.
  TreeShape Walk(uint64_t root, std::vector<uint8_t>& codes);

  std::vector<vtkIdType> DepthCounts;
  vtkIdType LeafCells = 0;
  vtkIdType MaskedCells = 0;

private:
  uint8_t Code(uint8_t state, bool refine)
  {
    const bool masked = !refine && this->Ctx.mask && state == 0;
    this->LeafCells += refine ? 0 : 1;
    this->MaskedCells += masked ? 1 : 0;
    return uint8_t(state | (refine ? kRefined : 0) | (masked ? kMasked : 0));
  }

  static uint16_t pack(int x, int y, int z) { return uint16_t(x | (y << 5) | (z << 10)); }

  // Writes the code of one element (and, for a refined leaf grid, those of its
  // octants below it) and says whether the walk descends into it.
  bool Visit(const hdt::WalkedElement& e);

  // The octants below a refined leaf root at depth `depth0`, breadth first.
  void WalkLeaf(const uint32_t* words, int depth0);

  // The single voxels under every refined 2^3 octant of the previous
  // sub-level (the most common cells): two rows of two voxels each from four
  // leaf rows, written eight at a time.
  void WriteVoxels(const uint32_t* words, std::vector<uint8_t>& out);

  const Context& Ctx;
  std::vector<std::vector<uint8_t>> Depths;
  std::vector<hdt::WalkedElement> Level, NextLevel; // the core walk's scratch
  std::vector<uint16_t> Octants, NextOctants;
  LeafPyramid Pyramid;
};

} // namespace hdt_htg
