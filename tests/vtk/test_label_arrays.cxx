// Part labels on the hyper tree grid (vtkHDTLabelArrays): every cell's Label
// against a brute-force majority over hdt::labelAt, at full depth and cut.
#include "vtkHDTHyperTreeGridConversion.h"
#include "vtkHDTLabelArrays.h"

#include "hdt/builder.hpp"
#include "hdt/labels.hpp"
#include "support/shapes.hpp"

#include "hdt_vtk_test_util.h"

#include "vtkCellData.h"
#include "vtkFieldData.h"
#include "vtkHyperTreeGrid.h"
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
    int wrong = 0;
    const vtkIdType visited = hdtvtk::ForEachCellBox(htg, v.grid, [&](vtkIdType cell, bool, int x, int y, int z, int edge) {
      wrong += labels->GetValue(cell) != bruteMajority(v, x, y, z, edge);
    });
    ASSERT_EQ(visited, htg->GetNumberOfCells());
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

// ---- vtkHDTVoxelizer's Label By --------------------------------------------------------

#include "vtkCellArray.h"
#include "vtkHDTVoxelizer.h"
#include "vtkIdList.h"
#include "vtkInformation.h"
#include "vtkIntArray.h"
#include "vtkMultiBlockDataSet.h"
#include "vtkPoints.h"
#include "vtkPolyData.h"
#include "vtkSphereSource.h"

namespace
{

vtkSmartPointer<vtkPolyData> sphere(double x, double r)
{
  vtkNew<vtkSphereSource> s;
  s->SetCenter(x, 0, 0);
  s->SetRadius(r);
  s->SetThetaResolution(24);
  s->SetPhiResolution(24);
  s->Update();
  return s->GetOutput();
}

// The same mesh with per-triangle labels, for the core's own labelled build.
void appendLabelled(hdt::TriangleMesh& mesh, vtkPolyData* pd, hdt::Label label)
{
  const size_t base = mesh.pointCount();
  for (vtkIdType i = 0; i < pd->GetNumberOfPoints(); ++i)
  {
    double p[3];
    pd->GetPoint(i, p);
    mesh.points.insert(mesh.points.end(), { p[0], p[1], p[2] });
  }
  vtkCellArray* polys = pd->GetPolys();
  vtkNew<vtkIdList> ids;
  for (vtkIdType c = 0; c < polys->GetNumberOfCells(); ++c)
  {
    polys->GetCellAtId(c, ids);
    for (vtkIdType k = 1; k + 1 < ids->GetNumberOfIds(); ++k)
    {
      mesh.triangles.insert(mesh.triangles.end(),
        { uint32_t(base + ids->GetId(0)), uint32_t(base + ids->GetId(k)), uint32_t(base + ids->GetId(k + 1)) });
      mesh.triangleLabels.push_back(label);
    }
  }
}

// The label of the voxel containing point (x, y, z).
hdt::Label labelAtPoint(const hdt::Volume& v, double x, double y, double z)
{
  const double p[3] = { x, y, z };
  int i[3];
  for (int a = 0; a < 3; ++a)
  {
    i[a] = int((p[a] - v.grid.origin[size_t(a)]) / v.grid.voxelSize);
  }
  return hdt::labelAt(v, i[0], i[1], i[2]);
}

TEST(LabelBy, MultiblockOfThreeNamedBlocks)
{
  vtkNew<vtkMultiBlockDataSet> mb;
  const char* names[] = { "housing", "shaft", "cap" };
  hdt::TriangleMesh reference;
  for (int b = 0; b < 3; ++b)
  {
    vtkSmartPointer<vtkPolyData> pd = sphere(0.7 * b, b == 1 ? 0.3 : 0.5);
    mb->SetBlock(unsigned(b), pd);
    mb->GetMetaData(unsigned(b))->Set(vtkCompositeDataSet::NAME(), names[b]);
    appendLabelled(reference, pd, hdt::Label(b + 1)); // flat indices 1, 2, 3
  }
  vtkNew<vtkHDTVoxelizer> filter;
  filter->SetInputData(mb);
  filter->SetResolution(64);
  filter->SetRootGridSize(2);
  filter->SetLeafGridSize(8);
  filter->SetBackend(vtkHDTVoxelizer::BACKEND_CPU);
  filter->SetLabelBy(vtkHDTVoxelizer::LABEL_BLOCK);
  filter->SetOverlapPolicy(vtkHDTVoxelizer::OVERLAP_HIGHEST);
  filter->Update();
  const std::shared_ptr<const hdt::Volume> v = filter->GetVolume();
  ASSERT_TRUE(v);
  auto* htg = vtkHyperTreeGrid::SafeDownCast(filter->GetOutputDataObject(0));
  ASSERT_NE(htg->GetCellData()->GetArray("Label"), nullptr);
  auto* labelNames = vtkStringArray::SafeDownCast(htg->GetFieldData()->GetAbstractArray("LabelNames"));
  ASSERT_NE(labelNames, nullptr);
  ASSERT_EQ(labelNames->GetNumberOfTuples(), 3);
  for (int b = 0; b < 3; ++b)
  {
    EXPECT_EQ(labelNames->GetValue(b), names[b]);
  }
  // The same labels as the core's labelled build of the same triangles.
  hdt::BuildConfig c;
  c.resolution = 64;
  c.rootGrid = 2;
  c.leafSize = 8;
  hdt::BuildOptions o;
  o.backend = hdt::Backend::Cpu;
  hdt::LabelOptions highest;
  highest.overlap = hdt::OverlapPolicy::Highest;
  const hdt::Volume expected = hdt::voxelizeLabelled(reference, c, o, highest);
  EXPECT_EQ(v->elements, expected.elements);
  EXPECT_EQ(v->labels.elementLabels, expected.labels.elementLabels);
  EXPECT_EQ(hdt::unpackVoxelLabels(*v), hdt::unpackVoxelLabels(expected));
  EXPECT_EQ(labelAtPoint(*v, 0.45, 0.01, 0.01), 2); // in blocks 1 and 2: the highest
  EXPECT_EQ(labelAtPoint(*v, 0.0, 0.01, 0.01), 1);
  EXPECT_EQ(labelAtPoint(*v, 1.6, 0.01, 0.01), 3);

  // Cell Array: the same parts from an integer cell array of one polydata.
  vtkNew<vtkPolyData> all;
  {
    vtkNew<vtkPoints> points;
    vtkNew<vtkCellArray> polys;
    vtkNew<vtkIntArray> part;
    part->SetName("part");
    for (int b = 0; b < 3; ++b)
    {
      vtkPolyData* pd = vtkPolyData::SafeDownCast(mb->GetBlock(unsigned(b)));
      const vtkIdType base = points->GetNumberOfPoints();
      for (vtkIdType i = 0; i < pd->GetNumberOfPoints(); ++i)
      {
        points->InsertNextPoint(pd->GetPoint(i));
      }
      vtkNew<vtkIdList> ids;
      for (vtkIdType cell = 0; cell < pd->GetPolys()->GetNumberOfCells(); ++cell)
      {
        pd->GetPolys()->GetCellAtId(cell, ids);
        for (vtkIdType k = 0; k < ids->GetNumberOfIds(); ++k)
        {
          ids->SetId(k, ids->GetId(k) + base);
        }
        polys->InsertNextCell(ids);
        part->InsertNextValue(b + 1);
      }
    }
    all->SetPoints(points);
    all->SetPolys(polys);
    all->GetCellData()->AddArray(part);
  }
  filter->SetInputData(all);
  filter->SetLabelBy(vtkHDTVoxelizer::LABEL_CELL_ARRAY);
  filter->SetLabelArrayName("part");
  filter->Update();
  ASSERT_TRUE(filter->GetVolume());
  EXPECT_EQ(filter->GetVolume()->labels.elementLabels, expected.labels.elementLabels);
  EXPECT_EQ(hdt::unpackVoxelLabels(*filter->GetVolume()), hdt::unpackVoxelLabels(expected));
  filter->SetLabelPriority("3, 1");
  filter->Update();
  EXPECT_EQ(labelAtPoint(*filter->GetVolume(), 0.45, 0.01, 0.01), 1); // 1 listed before 2
}

} // namespace
