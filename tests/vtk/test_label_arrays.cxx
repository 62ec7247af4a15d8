// Part labels on the hyper tree grid (vtkHDTLabelArrays): every cell's Label
// against a brute-force majority over hdt::labelAt, at full depth and cut.
#include "vtkHDTHyperTreeGridConversion.h"
#include "vtkHDTLabelArrays.h"

#include "hdt/builder.hpp"
#include "hdt/labels.hpp"
#include "support/shapes.hpp"

#include "vtkCellData.h"
#include "vtkFieldData.h"
#include "vtkHyperTreeGrid.h"
#include "vtkHyperTreeGridNonOrientedCursor.h"
#include "vtkNew.h"
#include "vtkStringArray.h"
#include "vtkUnsignedShortArray.h"

#include <gtest/gtest.h>

#include <map>

namespace
{

hdt::Volume twoSpheres()
{
  hdt::TriangleMesh mesh = hdt::test::icosphere(2, 1.0, { -0.5, 0, 0 });
  mesh.triangleLabels.assign(mesh.triangleCount(), 2);
  const hdt::TriangleMesh second = hdt::test::icosphere(2, 0.8, { 0.6, 0.1, 0 });
  hdt::test::append(mesh, second);
  mesh.triangleLabels.resize(mesh.triangleCount(), 5);
  mesh.labelNames = { { 2, "left" }, { 5, "right" } };
  hdt::BuildConfig c;
  c.resolution = 32;
  c.rootGrid = 2;
  c.leafSize = 8;
  hdt::BuildOptions o;
  o.backend = hdt::Backend::Cpu;
  return hdt::voxelizeLabelled(mesh, c, o);
}

// The majority of the non-Outside labels in the box, ties to the lowest.
hdt::Label bruteMajority(const hdt::Volume& v, int x0, int y0, int z0, int edge)
{
  std::map<hdt::Label, int> count;
  for (int z = z0; z < z0 + edge; ++z)
    for (int y = y0; y < y0 + edge; ++y)
      for (int x = x0; x < x0 + edge; ++x)
      {
        const hdt::Label l = hdt::labelAt(v, x, y, z);
        if (l)
        {
          ++count[l];
        }
      }
  hdt::Label best = 0;
  int most = 0;
  for (const auto& e : count)
  {
    if (e.second > most)
    {
      best = e.first;
      most = e.second;
    }
  }
  return best;
}

int checkCells(vtkHyperTreeGridNonOrientedCursor* cursor, const hdt::Volume& v,
  vtkUnsignedShortArray* labels, int x, int y, int z, int edge)
{
  int wrong = labels->GetValue(cursor->GetGlobalNodeIndex()) != bruteMajority(v, x, y, z, edge);
  if (!cursor->IsLeaf())
  {
    const int half = edge / 2;
    for (int c = 0; c < 8; ++c)
    {
      cursor->ToChild(c);
      wrong += checkCells(cursor, v, labels, x + (c & 1) * half, y + ((c >> 1) & 1) * half,
        z + (c >> 2) * half, half);
      cursor->ToParent();
    }
  }
  return wrong;
}

TEST(LabelArrays, EveryCellHasTheMajorityLabel)
{
  const hdt::Volume v = twoSpheres();
  for (int maxDepth : { -1, 1, 2 })
  {
    vtkNew<vtkHyperTreeGrid> htg;
    vtkHDTConversionOptions options;
    options.MaxDepth = maxDepth;
    options.MaskOutside = false;
    vtkHDTToHyperTreeGrid::Convert(v, options, htg);
    auto* labels = vtkUnsignedShortArray::SafeDownCast(htg->GetCellData()->GetArray("Label"));
    ASSERT_NE(labels, nullptr);
    ASSERT_EQ(labels->GetNumberOfTuples(), htg->GetNumberOfCells());
    const int R = v.grid.rootGrid, edge = v.grid.rootCellVoxels();
    int wrong = 0;
    vtkNew<vtkHyperTreeGridNonOrientedCursor> cursor;
    for (int t = 0; t < R * R * R; ++t)
    {
      htg->InitializeNonOrientedCursor(cursor, t);
      wrong += checkCells(cursor, v, labels, (t % R) * edge, ((t / R) % R) * edge, (t / (R * R)) * edge, edge);
    }
    EXPECT_EQ(wrong, 0) << "MaxDepth " << maxDepth;
  }
}

TEST(LabelArrays, FieldDataTable)
{
  const hdt::Volume v = twoSpheres();
  vtkNew<vtkHyperTreeGrid> htg;
  vtkHDTToHyperTreeGrid::Convert(v, vtkHDTConversionOptions{}, htg);
  vtkFieldData* fd = htg->GetFieldData();
  auto* names = vtkStringArray::SafeDownCast(fd->GetAbstractArray("LabelNames"));
  ASSERT_NE(names, nullptr);
  ASSERT_EQ(names->GetNumberOfTuples(), 2);
  EXPECT_EQ(names->GetValue(0), "left");
  EXPECT_EQ(names->GetValue(1), "right");
  double surface = 0, inside = 0;
  for (int i = 0; i < 2; ++i)
  {
    surface += fd->GetArray("LabelSurfaceVoxels")->GetTuple1(i);
    inside += fd->GetArray("LabelInsideVoxels")->GetTuple1(i);
  }
  EXPECT_EQ(surface, double(v.stats.activeVoxels));
  EXPECT_EQ(inside, double(v.stats.insideVoxels));
  // An unlabelled volume gets no Label array.
  hdt::Volume plain = v;
  plain.labels = hdt::LabelField{};
  vtkNew<vtkHyperTreeGrid> other;
  vtkHDTToHyperTreeGrid::Convert(plain, vtkHDTConversionOptions{}, other);
  EXPECT_EQ(other->GetCellData()->GetArray("Label"), nullptr);
}

} // namespace
