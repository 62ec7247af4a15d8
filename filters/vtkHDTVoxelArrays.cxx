// Transferred arrays on a converted vtkHyperTreeGrid and on the voxel surface:
// every tree walked with a cursor (trees in parallel); a cell's value is the
// NaN-aware mean of its children's, down to the voxels (vtkHDTVoxelArrays.h).
#include "vtkHDTVoxelArrays.h"

#include "hdt/transfer.hpp"
#include "hdt/voxel_surface.hpp"
#include "hdt/volume_walk.hpp"

#include "vtkCellData.h"
#include "vtkFieldData.h"
#include "vtkFloatArray.h"
#include "vtkHyperTreeGrid.h"
#include "vtkHyperTreeGridNonOrientedCursor.h"
#include "vtkImageData.h"
#include "vtkPointData.h"
#include "vtkNew.h"
#include "vtkPolyData.h"
#include "vtkStringArray.h"

#include <tbb/blocked_range.h>
#include <tbb/enumerable_thread_specific.h>
#include <tbb/parallel_for.h>

#include <array>
#include <cmath>
#include <limits>
#include <vector>

namespace
{

using Box = std::array<int, 3>;
constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();

// Per component: the sum and count of the values that are not NaN.
struct Mean
{
  std::array<double, hdt::kMaxArrayComponents> Sum{};
  std::array<uint32_t, hdt::kMaxArrayComponents> Count{};
  void Add(const double* value, uint32_t components)
  {
    for (uint32_t j = 0; j < components; ++j)
    {
      if (!std::isnan(value[j]))
      {
        this->Sum[j] += value[j];
        ++this->Count[j];
      }
    }
  }
  void Write(double* out, uint32_t components) const
  {
    for (uint32_t j = 0; j < components; ++j)
    {
      out[j] = this->Count[j] ? this->Sum[j] / this->Count[j] : kNaN;
    }
  }
};

// The value of any aligned cell of the grid for one array.
class CellMeans
{
public:
  CellMeans(const hdt::Volume& v, const hdt::VoxelArray& a)
    : V(v)
    , A(a)
    , Start(hdt::surfaceVoxelStart(v))
  {
  }

  // Cell [o, o + edge)^3 (edge a power of two, o a multiple of it).
  void Cell(const Box& o, int edge, double* out) const
  {
    const hdt::GridSpec& g = this->V.grid;
    int level = 0;
    while (level < g.height && g.elementVoxels(level + 1) >= edge)
    {
      ++level;
    }
    const hdt::WalkedElement e = hdt::locateElement(this->V, o[0], o[1], o[2], level);
    if (e.state() == hdt::ElementState::Boundary)
    {
      this->LeafCell(e, { o[0] - e.origin[0], o[1] - e.origin[1], o[2] - e.origin[2] }, edge, out);
      return;
    }
    if (e.state() != hdt::ElementState::Branch)
    {
      std::fill(out, out + this->A.components, kNaN); // uniform: no surface voxel
      return;
    }
    this->Children(o, edge, out, [this](const Box& c, int half, double* v) { this->Cell(c, half, v); });
  }

private:
  template <class Child>
  void Children(const Box& o, int edge, double* out, const Child& child) const
  {
    const int half = edge / 2;
    Mean mean;
    std::array<double, hdt::kMaxArrayComponents> value;
    for (int c = 0; c < 8; ++c)
    {
      child({ o[0] + (c & 1) * half, o[1] + ((c >> 1) & 1) * half, o[2] + (c >> 2) * half }, half,
        value.data());
      mean.Add(value.data(), this->A.components);
    }
    mean.Write(out, this->A.components);
  }

  // A cell inside leaf e, at leaf coordinates l.
  void LeafCell(const hdt::WalkedElement& e, const Box& l, int edge, double* out) const
  {
    if (edge > 1)
    {
      this->Children(
        l, edge, out, [&](const Box& c, int half, double* v) { this->LeafCell(e, c, half, v); });
      return;
    }
    const int L = this->V.grid.leafSize;
    const uint32_t voxel = uint32_t(l[0] + L * (l[1] + L * l[2]));
    const uint32_t* words = this->V.leaf(e.payload());
    const uint32_t c = this->A.components;
    if (((words[voxel / hdt::kVoxelsPerWord] >> (2 * (voxel % hdt::kVoxelsPerWord))) & 3u) !=
      uint32_t(hdt::VoxelState::Surface))
    {
      std::fill(out, out + c, kNaN);
      return;
    }
    const uint64_t s = this->Start[e.payload()] + this->Rank(e.payload(), words, voxel);
    for (uint32_t j = 0; j < c; ++j)
    {
      out[j] = this->A.values[s * c + j];
    }
  }

  // The voxel's rank among its leaf's surface voxels, from per-word prefix
  // counts kept per thread for the last leaf seen.
  uint32_t Rank(uint64_t leaf, const uint32_t* words, uint32_t voxel) const
  {
    Prefix& p = this->Prefixes.local();
    if (p.Leaf != leaf)
    {
      const uint32_t n = hdt::leafWordCount(this->V.grid.leafSize);
      p.Counts.resize(n);
      uint32_t sum = 0;
      for (uint32_t w = 0; w < n; ++w)
      {
        p.Counts[w] = sum;
        sum += hdt::planeCount(words[w], hdt::kSurfacePlane);
      }
      p.Leaf = leaf;
    }
    const uint32_t w = voxel / hdt::kVoxelsPerWord, bits = 2 * (voxel % hdt::kVoxelsPerWord);
    const uint32_t below = bits ? (words[w] & ((1u << bits) - 1u)) : 0u;
    return p.Counts[w] + hdt::planeCount(below, hdt::kSurfacePlane);
  }

  struct Prefix
  {
    uint64_t Leaf = ~uint64_t(0);
    std::vector<uint32_t> Counts;
  };
  const hdt::Volume& V;
  const hdt::VoxelArray& A;
  std::vector<uint64_t> Start;
  mutable tbb::enumerable_thread_specific<Prefix> Prefixes;
};

// Writes every cell of one tree: leaves of the grid from the volume, refined
// cells the mean of their children.
class TreeMeans
{
public:
  TreeMeans(const CellMeans& means, uint32_t components, float* out)
    : Means(means)
    , Components(components)
    , Out(out)
  {
  }

  void Visit(vtkHyperTreeGridNonOrientedCursor* cursor, const Box& o, int edge, double* value) const
  {
    if (cursor->IsLeaf() || edge == 1)
    {
      this->Means.Cell(o, edge, value);
    }
    else
    {
      const int half = edge / 2;
      Mean mean;
      std::array<double, hdt::kMaxArrayComponents> child;
      for (int c = 0; c < 8; ++c)
      {
        cursor->ToChild(c);
        this->Visit(cursor, { o[0] + (c & 1) * half, o[1] + ((c >> 1) & 1) * half, o[2] + (c >> 2) * half },
          half, child.data());
        mean.Add(child.data(), this->Components);
        cursor->ToParent();
      }
      mean.Write(value, this->Components);
    }
    float* out = this->Out + size_t(cursor->GetGlobalNodeIndex()) * this->Components;
    for (uint32_t j = 0; j < this->Components; ++j)
    {
      out[j] = float(value[j]);
    }
  }

private:
  const CellMeans& Means;
  uint32_t Components;
  float* Out;
};

vtkNew<vtkFloatArray> newArray(const hdt::VoxelArray& a, vtkIdType tuples)
{
  vtkNew<vtkFloatArray> out;
  out->SetName(a.name.c_str());
  out->SetNumberOfComponents(int(a.components));
  out->SetNumberOfTuples(tuples);
  out->Fill(kNaN);
  return out;
}

void addNames(const hdt::Volume& volume, vtkFieldData* fd)
{
  vtkNew<vtkStringArray> names;
  names->SetName("TransferredArrays");
  for (const hdt::VoxelArray& a : volume.arrays)
  {
    names->InsertNextValue(a.name);
  }
  fd->AddArray(names);
}

} // namespace

//------------------------------------------------------------------------------
void vtkHDTAddVoxelArrays(const hdt::Volume& volume, vtkHyperTreeGrid* grid)
{
  if (volume.arrays.empty() || !grid)
  {
    return;
  }
  const uint64_t R = uint64_t(volume.grid.rootGrid);
  const int rootEdge = volume.grid.rootCellVoxels();
  for (const hdt::VoxelArray& a : volume.arrays)
  {
    vtkNew<vtkFloatArray> out = newArray(a, grid->GetNumberOfCells());
    const CellMeans means(volume, a);
    const TreeMeans walker(means, a.components, out->GetPointer(0));
    tbb::parallel_for(tbb::blocked_range<uint64_t>(0, R * R * R, 8),
      [&](const tbb::blocked_range<uint64_t>& r) {
        vtkNew<vtkHyperTreeGridNonOrientedCursor> cursor;
        std::array<double, hdt::kMaxArrayComponents> value;
        for (uint64_t t = r.begin(); t != r.end(); ++t)
        {
          if (!grid->GetTree(vtkIdType(t)))
          {
            continue;
          }
          grid->InitializeNonOrientedCursor(cursor, vtkIdType(t));
          const Box o = { int(t % R) * rootEdge, int((t / R) % R) * rootEdge, int(t / (R * R)) * rootEdge };
          walker.Visit(cursor, o, rootEdge, value.data());
        }
      });
    grid->GetCellData()->AddArray(out);
  }
  addNames(volume, grid->GetFieldData());
}

//------------------------------------------------------------------------------
void vtkHDTAddVoxelImageArrays(const hdt::Volume& volume, const long long lo[3], int level, vtkImageData* image)
{
  if (volume.arrays.empty() || !image)
  {
    return;
  }
  int dims[3];
  image->GetDimensions(dims);
  const int edge = 1 << level;
  const vtkIdType points = vtkIdType(dims[0]) * dims[1] * dims[2];
  for (const hdt::VoxelArray& a : volume.arrays)
  {
    vtkNew<vtkFloatArray> out = newArray(a, points);
    const CellMeans means(volume, a);
    float* dst = out->GetPointer(0);
    tbb::parallel_for(vtkIdType(0), points, [&](vtkIdType i) {
      const int x = int(i % dims[0]), y = int((i / dims[0]) % dims[1]), z = int(i / (vtkIdType(dims[0]) * dims[1]));
      std::array<double, hdt::kMaxArrayComponents> value;
      means.Cell({ int(lo[0]) + x * edge, int(lo[1]) + y * edge, int(lo[2]) + z * edge }, edge, value.data());
      for (uint32_t j = 0; j < a.components; ++j)
      {
        dst[i * a.components + j] = float(value[j]);
      }
    });
    image->GetPointData()->AddArray(out);
  }
}

//------------------------------------------------------------------------------
void vtkHDTAddVoxelSurfaceArrays(const hdt::Volume& volume, int maxDepth, vtkPolyData* surface,
  unsigned long long firstCell, unsigned long long endCell)
{
  if (volume.arrays.empty() || !surface)
  {
    return;
  }
  hdt::SurfaceOptions options;
  options.maxDepth = maxDepth;
  options.cellsFirst = firstCell;
  options.cellsEnd = endCell;
  // The same quads, in the same order, as vtkHDTFillVoxelSurface's.
  const std::vector<hdt::SurfaceQuad> quads = hdt::extractSurfaceQuads(volume, options);
  if (vtkIdType(quads.size()) != surface->GetNumberOfCells())
  {
    return; // not this volume's surface
  }
  const int c = hdt::surfaceCellEdge(volume.grid, maxDepth);
  for (const hdt::VoxelArray& a : volume.arrays)
  {
    vtkNew<vtkFloatArray> out = newArray(a, vtkIdType(quads.size()));
    const CellMeans means(volume, a);
    float* dst = out->GetPointer(0);
    tbb::parallel_for(size_t(0), quads.size(), [&](size_t i) {
      const hdt::SurfaceQuad& q = quads[i];
      const int axis = q.axis, ua = axis == 0 ? 1 : 0, va = axis == 2 ? 1 : 2;
      Mean mean;
      std::array<double, hdt::kMaxArrayComponents> value;
      for (int v = q.v; v < q.v + q.dv; v += c)
      {
        for (int u = q.u; u < q.u + q.du; u += c)
        {
          Box o;
          o[size_t(axis)] = q.outward > 0 ? q.plane - c : q.plane; // the occupied cell's side
          o[size_t(ua)] = u;
          o[size_t(va)] = v;
          means.Cell(o, c, value.data());
          mean.Add(value.data(), a.components);
        }
      }
      mean.Write(value.data(), a.components);
      for (uint32_t j = 0; j < a.components; ++j)
      {
        dst[i * a.components + j] = float(value[j]);
      }
    });
    surface->GetCellData()->AddArray(out);
  }
  addNames(volume, surface->GetFieldData());
}
