// Part labels on a converted vtkHyperTreeGrid: every tree walked with a
// cursor (trees in parallel), each leaf cell's label histogram read from the
// HDT (hdt::cellLabelHistogram), refined cells merging their children's.
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

using Box = std::array<int, 3>;

class TreeLabels
{
public:
  TreeLabels(const hdt::Volume& v, unsigned short* out)
    : V(v)
    , Out(out)
  {
  }

  hdt::LabelHistogram Visit(vtkHyperTreeGridNonOrientedCursor* cursor, const Box& o, int edge) const
  {
    hdt::LabelHistogram h;
    if (cursor->IsLeaf() || edge == 1)
    {
      h = hdt::cellLabelHistogram(this->V, o[0], o[1], o[2], edge);
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
          hdt::addToHistogram(h, entry.first, entry.second);
        }
        cursor->ToParent();
      }
    }
    this->Out[cursor->GetGlobalNodeIndex()] = hdt::majorityLabel(h);
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
