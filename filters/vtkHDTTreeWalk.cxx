#include "vtkHDTTreeWalk.h"

#include "vtkHDTHyperTreeGridConversion.h" // AggregateState

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include <algorithm>

namespace hdt_htg
{
namespace
{

constexpr uint64_t kLowLanes = 0x5555555555555555ull; // bit 0 of every 2-bit voxel

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
      inside += uint64_t(hdt::popcount32(uint32_t(r & lanes)) + hdt::popcount32(uint32_t((r & lanes) >> 32)));
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
    t.surface += hdt::planeCount(words[i], hdt::kSurfacePlane);
    t.inside += hdt::planeCount(words[i], hdt::kInsidePlane);
  }
  return t;
}

// State and refinement of a non-voxel cell from its flags; the exact count is
// needed only for the majority rule (inside and outside, no surface).
inline uint8_t stateFromFlags(unsigned flags, const uint32_t* words, int L, int x, int y, int z, int k)
{
  if (flags & LeafPyramid::kSurface)
  {
    return 2;
  }
  if (!(flags & LeafPyramid::kOutside))
  {
    return 1;
  }
  if (!(flags & LeafPyramid::kInside))
  {
    return 0;
  }
  const Tally t = octantTally(words, L, x, y, z, k);
  return vtkHDTToHyperTreeGrid::AggregateState(t.voxels, t.surface, t.inside);
}
inline bool mixed(unsigned flags)
{
  return (flags & LeafPyramid::kSurface) ||
    ((flags & LeafPyramid::kInside) && (flags & LeafPyramid::kOutside));
}

} // namespace

//------------------------------------------------------------------------------
// Exact tally of an element's voxels (slow path for Branch elements with no
// surface voxel below them, which a correct build never has).
Tally Context::elementTally(const hdt::WalkedElement& e) const
{
  Tally t;
  auto add = [&](const hdt::WalkedElement& below) {
    const uint64_t edge = uint64_t(below.edge);
    switch (below.state())
    {
      case hdt::ElementState::Empty:
        t.voxels += edge * edge * edge;
        break;
      case hdt::ElementState::Full:
        t.voxels += edge * edge * edge;
        t.inside += edge * edge * edge;
        break;
      case hdt::ElementState::Boundary:
        t.add(leafTally(this->volume->leaf(below.payload()), this->L));
        break;
      case hdt::ElementState::Branch: // not reached: the walk goes to the leaf level
        break;
    }
  };
  hdt::walkSubtree(*this->volume, e, this->height, add);
  return t;
}

//------------------------------------------------------------------------------
// Context::elementSurface is filled bottom-up, level by level.
void prepareContext(
  const hdt::Volume& v, int depthCut, bool mask, hdt::StatisticsOf statistics, Context& ctx)
{
  hdt::validateVolume(v, statistics);
  const hdt::GridSpec& g = v.grid;
  ctx.volume = &v;
  ctx.depthCut = depthCut;
  ctx.mask = mask;
  ctx.L = g.leafSize;
  ctx.leafLevels = log2Exact(g.leafSize);
  ctx.height = g.height;
  ctx.leafCount = v.leafCount();
  ctx.elementSurface.assign(v.elements.size(), 0);
  const uint32_t wordsPerLeaf = hdt::leafWordCount(g.leafSize);
  for (int level = g.height; level >= 0; --level)
  {
    tbb::parallel_for(tbb::blocked_range<uint64_t>(v.levelStart[size_t(level)], v.levelStart[size_t(level) + 1], 4096),
      [&](const tbb::blocked_range<uint64_t>& r) {
        for (uint64_t e = r.begin(); e != r.end(); ++e)
        {
          const hdt::ElementWord w = v.elements[e];
          const uint64_t p = hdt::elementPayload(w);
          uint32_t any = 0;
          switch (hdt::elementState(w))
          {
            case hdt::ElementState::Empty:
            case hdt::ElementState::Full:
              break;
            case hdt::ElementState::Boundary:
              for (uint32_t i = 0; i < wordsPerLeaf; ++i)
              {
                any |= v.leaf(p)[i] & hdt::kSurfacePlaneBits;
              }
              break;
            case hdt::ElementState::Branch:
              for (uint64_t c = 0; c < 8; ++c)
              {
                any |= ctx.elementSurface[p + c];
              }
              break;
          }
          ctx.elementSurface[e] = any ? 1 : 0;
        }
      });
  }
}

//------------------------------------------------------------------------------
void LeafPyramid::Build(const uint32_t* words, int L, int levels)
{
  this->Edge = L;
  this->Offset.assign(size_t(levels) + 1, 0);
  size_t rows = 0;
  for (int j = 1; j <= levels; ++j)
  {
    this->Offset[size_t(j)] = rows;
    rows += size_t(L >> j) * size_t(L >> j);
  }
  this->Rows.resize(rows);
  const uint64_t lanes0 = (L == 32 ? ~0ull : ((1ull << (2 * L)) - 1)) & kLowLanes;
  // Level 1 (k = 2) straight from the voxel rows.
  {
    const int n = L / 2;
    const uint64_t mask = lanes0 & 0x1111111111111111ull; // bits 4x
    Row* out = this->Rows.data() + this->Offset[1];
    for (int z = 0; z < n; ++z)
    {
      for (int y = 0; y < n; ++y)
      {
        uint64_t s = 0, i = 0, o = 0;
        for (int dz = 0; dz < 2; ++dz)
        {
          for (int dy = 0; dy < 2; ++dy)
          {
            const uint64_t r = leafRow(words, L, 2 * y + dy, 2 * z + dz);
            s |= r >> 1;
            i |= r;
            o |= ~(r | (r >> 1));
          }
        }
        s &= lanes0;
        i &= lanes0;
        o &= lanes0;
        Row& row = out[size_t(y) + size_t(n) * size_t(z)];
        row.S = (s | (s >> 2)) & mask;
        row.I = (i | (i >> 2)) & mask;
        row.O = (o | (o >> 2)) & mask;
      }
    }
  }
  // Level j (k = 2^j) from level j - 1.
  for (int j = 2; j <= levels; ++j)
  {
    const int k = 1 << j;
    const int n = L >> j;
    uint64_t mask = 0; // bits at multiples of 2k below 2L
    for (int x = 0; x < n; ++x)
    {
      mask |= 1ull << (2 * k * x);
    }
    const Row* fine = this->Rows.data() + this->Offset[size_t(j) - 1];
    Row* coarse = this->Rows.data() + this->Offset[size_t(j)];
    for (int z = 0; z < n; ++z)
    {
      for (int y = 0; y < n; ++y)
      {
        const size_t a = size_t(2 * y) + size_t(2 * n) * size_t(2 * z);
        const size_t b = a + 2 * size_t(n);
        const Row& f0 = fine[a];
        const Row& f1 = fine[a + 1];
        const Row& f2 = fine[b];
        const Row& f3 = fine[b + 1];
        const uint64_t s = f0.S | f1.S | f2.S | f3.S;
        const uint64_t i = f0.I | f1.I | f2.I | f3.I;
        const uint64_t o = f0.O | f1.O | f2.O | f3.O;
        Row& c = coarse[size_t(y) + size_t(n) * size_t(z)];
        c.S = (s | (s >> k)) & mask;
        c.I = (i | (i >> k)) & mask;
        c.O = (o | (o >> k)) & mask;
      }
    }
  }
}

//------------------------------------------------------------------------------
// Writes the tree's codes and returns its shape.
TreeShape TreeWalker::Walk(uint64_t root, std::vector<uint8_t>& codes)
{
  for (auto& d : this->Depths)
  {
    d.clear();
  }
  hdt::walkTreeBreadthFirst(*this->Ctx.volume, root, this->Ctx.depthCut,
    [this](const hdt::WalkedElement& e) { return this->Visit(e); }, this->Level, this->NextLevel);

  TreeShape shape;
  for (size_t d = 0; d < this->Depths.size(); ++d)
  {
    shape.Vertices += this->Depths[d].size();
    this->DepthCounts[d] += vtkIdType(this->Depths[d].size());
    if (!this->Depths[d].empty())
    {
      shape.Levels = uint32_t(d) + 1;
      shape.LastDepth = this->Depths[d].size();
    }
  }
  codes.resize(shape.Vertices);
  uint8_t* dst = codes.data();
  for (const auto& d : this->Depths)
  {
    dst = std::copy(d.begin(), d.end(), dst);
  }
  return shape;
}

//------------------------------------------------------------------------------
// Writes the code of one element (and, for a refined leaf grid, those of its
// octants below it) and says whether the walk descends into it.
bool TreeWalker::Visit(const hdt::WalkedElement& e)
{
  const bool canRefine = e.level < this->Ctx.depthCut;
  uint8_t state = 0;
  bool refine = false;
  switch (e.state())
  {
    case hdt::ElementState::Empty:
      state = 0;
      break;
    case hdt::ElementState::Full:
      state = 1;
      break;
    case hdt::ElementState::Branch:
      if (this->Ctx.elementSurface[e.index])
      {
        state = 2;
      }
      else
      {
        const Tally t = this->Ctx.elementTally(e);
        state = vtkHDTToHyperTreeGrid::AggregateState(t.voxels, t.surface, t.inside);
      }
      refine = canRefine;
      break;
    case hdt::ElementState::Boundary:
    {
      const int L = this->Ctx.L;
      const uint32_t* words = this->Ctx.volume->leaf(e.payload());
      this->Pyramid.Build(words, L, this->Ctx.leafLevels);
      const unsigned flags = this->Pyramid.Flags(this->Ctx.leafLevels, 0, 0, 0);
      state = stateFromFlags(flags, words, L, 0, 0, 0, L);
      refine = canRefine && mixed(flags);
      if (refine)
      {
        this->WalkLeaf(words, e.level);
      }
      break;
    }
  }
  this->Depths[size_t(e.level)].push_back(this->Code(state, refine));
  return refine;
}

//------------------------------------------------------------------------------
// The octants below a refined leaf root at depth `depth0`, breadth first.
void TreeWalker::WalkLeaf(const uint32_t* words, int depth0)
{
  const int L = this->Ctx.L;
  const int levels = this->Ctx.leafLevels;
  this->Octants.assign(1, pack(0, 0, 0)); // refined octants of the previous sub-level
  for (int sub = 1; sub <= levels && !this->Octants.empty(); ++sub)
  {
    const int depth = depth0 + sub;
    const int j = levels - sub; // octant edge 2^j
    const int k = 1 << j;
    const bool canRefine = depth < this->Ctx.depthCut && j > 0;
    std::vector<uint8_t>& out = this->Depths[size_t(depth)];
    if (j == 0)
    {
      this->WriteVoxels(words, out);
      break;
    }
    this->NextOctants.clear();
    for (const uint16_t parent : this->Octants)
    {
      const int px = parent & 31, py = (parent >> 5) & 31, pz = parent >> 10;
      unsigned childFlags[8];
      this->Pyramid.ChildFlags(j, px, py, pz, childFlags);
      for (int c = 0; c < 8; ++c)
      {
        const int x = px + (c & 1) * k, y = py + ((c >> 1) & 1) * k, z = pz + (c >> 2) * k;
        const unsigned flags = childFlags[c];
        const bool refine = canRefine && mixed(flags);
        out.push_back(this->Code(stateFromFlags(flags, words, L, x, y, z, k), refine));
        if (refine)
        {
          this->NextOctants.push_back(pack(x, y, z));
        }
      }
    }
    this->Octants.swap(this->NextOctants);
  }
}

//------------------------------------------------------------------------------
// The single voxels under every refined 2^3 octant of the previous
// sub-level (the most common cells): two rows of two voxels each from four
// leaf rows, written eight at a time.
void TreeWalker::WriteVoxels(const uint32_t* words, std::vector<uint8_t>& out)
{
  const int L = this->Ctx.L;
  const uint8_t maskBit = this->Ctx.mask ? kMasked : 0;
  const size_t base = out.size();
  out.resize(base + 8 * this->Octants.size());
  uint8_t* o = out.data() + base;
  vtkIdType masked = 0;
  for (const uint16_t parent : this->Octants)
  {
    const int px = parent & 31, py = (parent >> 5) & 31, pz = parent >> 10;
    for (int dz = 0; dz < 2; ++dz)
    {
      for (int dy = 0; dy < 2; ++dy)
      {
        const unsigned r = unsigned(leafRow(words, L, py + dy, pz + dz) >> (2 * px));
        for (int dx = 0; dx < 2; ++dx)
        {
          const unsigned state = (r >> (2 * dx)) & 3u; // never 3: validateVolume
          const uint8_t code = uint8_t(state | (state == 0 ? maskBit : 0));
          masked += (code & kMasked) ? 1 : 0;
          o[dx + 2 * dy + 4 * dz] = code;
        }
      }
    }
    o += 8;
  }
  this->LeafCells += vtkIdType(8 * this->Octants.size());
  this->MaskedCells += masked;
}

} // namespace hdt_htg
