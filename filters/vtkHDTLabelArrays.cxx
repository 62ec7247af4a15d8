// Part labels on a converted vtkHyperTreeGrid: every tree walked with a
// cursor (trees in parallel), each leaf cell's label histogram read from the
// HDT, refined cells merging their children's histograms.
#include "vtkHDTLabelArrays.h"

#include "hdt/labels.hpp"
#include "hdt/volume_walk.hpp"

#include "vtkCellData.h"
#include "vtkDoubleArray.h"
#include "vtkFieldData.h"
#include "vtkHyperTreeGrid.h"
#include "vtkHyperTreeGridNonOrientedCursor.h"
#include "vtkNew.h"
#include "vtkStringArray.h"
#include "vtkTypeUInt64Array.h"
#include "vtkUnsignedShortArray.h"

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include <algorithm>
#include <array>
#include <utility>
#include <vector>

namespace
{

// Voxel counts per label (> 0), sorted by label.
using Histogram = std::vector<std::pair<hdt::Label, uint64_t>>;

void add(Histogram& h, hdt::Label label, uint64_t count)
{
  if (label == hdt::kOutsideLabel || count == 0)
  {
    return;
  }
  auto it = std::lower_bound(h.begin(), h.end(), label,
    [](const std::pair<hdt::Label, uint64_t>& e, hdt::Label l) { return e.first < l; });
  if (it != h.end() && it->first == label)
  {
    it->second += count;
  }
  else
  {
    h.insert(it, { label, count });
  }
}

hdt::Label majority(const Histogram& h)
{
  hdt::Label best = hdt::kOutsideLabel;
  uint64_t most = 0;
  for (const auto& entry : h)
  {
    if (entry.second > most) // strictly: ties keep the lower label
    {
      best = entry.first;
      most = entry.second;
    }
  }
  return best;
}

using Box = std::array<int, 3>;

// The labels of the voxels of box [o, o + edge)^3 that lie in Boundary element e.
void addLeafVoxels(const hdt::Volume& v, const hdt::WalkedElement& e, const Box& o, int edge, Histogram& h)
{
  const hdt::LabelField& f = v.labels;
  const int L = v.grid.leafSize;
  const uint32_t* words = v.leaf(e.payload());
  const hdt::Label label = f.elementLabels[e.index];
  const hdt::Label* mixed = label == hdt::kOutsideLabel
    ? f.voxelLabels.data() + size_t(f.mixedBlock[e.payload()]) * size_t(L) * L * L
    : nullptr;
  Box lo, hi;
  for (int a = 0; a < 3; ++a)
  {
    lo[a] = std::max(o[a], e.origin[a]) - e.origin[a];
    hi[a] = std::min(o[a] + edge, e.origin[a] + L) - e.origin[a];
  }
  uint64_t occupied = 0;
  for (int z = lo[2]; z < hi[2]; ++z)
  {
    for (int y = lo[1]; y < hi[1]; ++y)
    {
      for (int x = lo[0]; x < hi[0]; ++x)
      {
        const int voxel = x + L * (y + L * z);
        if (mixed)
        {
          add(h, mixed[voxel], 1);
        }
        else
        {
          occupied += ((words[voxel / hdt::kVoxelsPerWord] >> (2 * (voxel % hdt::kVoxelsPerWord))) & 3u) != 0;
        }
      }
    }
  }
  add(h, label, occupied);
}

// The labels of the voxels of the cell [o, o + edge)^3 of the grid.
Histogram cellHistogram(const hdt::Volume& v, const Box& o, int edge)
{
  Histogram h;
  const int rootEdge = v.grid.rootCellVoxels();
  int level = 0;
  while ((rootEdge >> level) > edge && level < v.grid.height)
  {
    ++level;
  }
  const hdt::WalkedElement start = hdt::locateElement(v, o[0], o[1], o[2], level);
  auto visit = [&](const hdt::WalkedElement& e) {
    if (e.state() == hdt::ElementState::Boundary)
    {
      addLeafVoxels(v, e, o, edge, h);
    }
    else if (e.state() == hdt::ElementState::Full)
    {
      // A uniform element larger than the cell counts only the cell's voxels.
      const uint64_t side = uint64_t(std::min(edge, e.edge));
      add(h, v.labels.elementLabels[e.index], side * side * side);
    }
  };
  hdt::walkSubtree(v, start, v.grid.height, visit);
  return h;
}

class TreeLabels
{
public:
  TreeLabels(const hdt::Volume& v, unsigned short* out)
    : V(v)
    , Out(out)
  {
  }

  Histogram Visit(vtkHyperTreeGridNonOrientedCursor* cursor, const Box& o, int edge) const
  {
    Histogram h;
    if (cursor->IsLeaf() || edge == 1)
    {
      h = cellHistogram(this->V, o, edge);
    }
    else
    {
      const int half = edge / 2;
      for (int c = 0; c < 8; ++c)
      {
        cursor->ToChild(c);
        const Box child = { o[0] + (c & 1) * half, o[1] + ((c >> 1) & 1) * half, o[2] + (c >> 2) * half };
        for (const auto& entry : this->Visit(cursor, child, half))
        {
          add(h, entry.first, entry.second);
        }
        cursor->ToParent();
      }
    }
    this->Out[cursor->GetGlobalNodeIndex()] = majority(h);
    return h;
  }

private:
  const hdt::Volume& V;
  unsigned short* Out;
};

} // namespace

//------------------------------------------------------------------------------
void vtkHDTAddLabelArrays(const hdt::Volume& volume, vtkHyperTreeGrid* grid)
{
  if (volume.labels.empty() || !grid)
  {
    return;
  }
  vtkNew<vtkUnsignedShortArray> labels;
  labels->SetName("Label");
  labels->SetNumberOfTuples(grid->GetNumberOfCells());
  labels->FillValue(0);
  const TreeLabels walker(volume, labels->GetPointer(0));
  const uint64_t R = uint64_t(volume.grid.rootGrid);
  const int rootEdge = volume.grid.rootCellVoxels();
  tbb::parallel_for(tbb::blocked_range<uint64_t>(0, R * R * R, 8),
    [&](const tbb::blocked_range<uint64_t>& r) {
      vtkNew<vtkHyperTreeGridNonOrientedCursor> cursor;
      for (uint64_t t = r.begin(); t != r.end(); ++t)
      {
        if (!grid->GetTree(vtkIdType(t)))
        {
          continue;
        }
        grid->InitializeNonOrientedCursor(cursor, vtkIdType(t));
        const Box o = { int(t % R) * rootEdge, int((t / R) % R) * rootEdge, int(t / (R * R)) * rootEdge };
        walker.Visit(cursor, o, rootEdge);
      }
    });
  grid->GetCellData()->AddArray(labels);
  vtkHDTAddLabelFieldData(volume, grid->GetFieldData());
}

//------------------------------------------------------------------------------
void vtkHDTAddLabelFieldData(const hdt::Volume& volume, vtkFieldData* fd)
{
  if (volume.labels.empty() || !fd)
  {
    return;
  }
  const std::vector<hdt::LabelStatistics> table = hdt::labelStatistics(volume);
  vtkNew<vtkUnsignedShortArray> ids;
  vtkNew<vtkStringArray> names;
  vtkNew<vtkTypeUInt64Array> surface, inside;
  vtkNew<vtkDoubleArray> volumes, areas;
  ids->SetName("LabelIds");
  names->SetName("LabelNames");
  surface->SetName("LabelSurfaceVoxels");
  inside->SetName("LabelInsideVoxels");
  volumes->SetName("LabelVolume");
  areas->SetName("LabelSurfaceArea");
  for (const hdt::LabelStatistics& row : table)
  {
    ids->InsertNextValue(row.label);
    names->InsertNextValue(row.name);
    surface->InsertNextValue(row.surfaceVoxels);
    inside->InsertNextValue(row.insideVoxels);
    volumes->InsertNextValue(row.volume);
    areas->InsertNextValue(row.surfaceArea);
  }
  for (vtkAbstractArray* a : std::initializer_list<vtkAbstractArray*>{ ids, names, surface, inside, volumes, areas })
  {
    fd->AddArray(a);
  }
}
