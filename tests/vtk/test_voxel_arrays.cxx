// Transferred arrays on the hyper tree grid and the voxel surface
// (vtkHDTVoxelArrays): every cell's value against a brute-force NaN-aware
// mean of children over hdt::voxelArrayValue, at full depth and cut; every
// quad against the same mean over the cells behind it; and the voxelizer's
// Arrays To Transfer end to end.
#include "vtkHDTHyperTreeGridConversion.h"
#include "vtkHDTVoxelArrays.h"
#include "vtkHDTVoxelSurface.h"
#include "vtkHDTToImage.h"
#include "vtkHDTVoxelizer.h"

#include "hdt/builder.hpp"
#include "hdt/transfer.hpp"
#include "hdt/voxel_surface.hpp"
#include "hdt_vtk_test_util.h"
#include "support/shapes.hpp"

#include "vtkCellData.h"
#include "vtkDataArraySelection.h"
#include "vtkElevationFilter.h"
#include "vtkFloatArray.h"
#include "vtkHyperTreeGrid.h"
#include "vtkHyperTreeGridNonOrientedCursor.h"
#include "vtkImageData.h"
#include "vtkPointData.h"
#include "vtkNew.h"
#include "vtkPolyData.h"
#include "vtkSphereSource.h"

#include <gtest/gtest.h>

#include <cmath>
#include <vector>

namespace
{

hdt::Volume transferredSphere(hdt::TriangleMesh& mesh)
{
  mesh = hdt::test::icosphere(2, 1.0, { 0.1, -0.2, 0 });
  hdt::BuildConfig c;
  c.resolution = 32;
  c.rootGrid = 2;
  c.leafSize = 8;
  hdt::BuildOptions o;
  o.backend = hdt::Backend::Cpu;
  hdt::Volume v = hdt::voxelize(mesh, c, o);
  hdt::MeshArray x{ "X", hdt::ArraySource::Point, 1, {} };
  hdt::MeshArray index{ "Index", hdt::ArraySource::Cell, 2, {} };
  for (size_t p = 0; p < mesh.pointCount(); ++p)
  {
    x.values.push_back(mesh.points[3 * p]);
  }
  for (size_t t = 0; t < mesh.triangleCount(); ++t)
  {
    index.values.insert(index.values.end(), { double(t), -double(t) });
  }
  hdt::transferArrays(mesh, { x, index }, v);
  return v;
}

// Independent of the filter's walk: recursion over the grid's cells by coordinates.
double bruteMean(const hdt::Volume& v, size_t array, uint32_t component, int x, int y, int z, int edge)
{
  if (edge == 1)
  {
    return hdt::voxelArrayValue(v, array, component, x, y, z);
  }
  const int h = edge / 2;
  double sum = 0;
  int count = 0;
  for (int c = 0; c < 8; ++c)
  {
    const double m = bruteMean(v, array, component, x + (c & 1) * h, y + ((c >> 1) & 1) * h, z + (c >> 2) * h, h);
    if (!std::isnan(m))
    {
      sum += m;
      ++count;
    }
  }
  return count ? sum / count : std::nan("");
}

bool same(float a, double b)
{
  return (std::isnan(a) && std::isnan(b)) || a == float(b);
}

TEST(VoxelArrays, HyperTreeGridCellsAreNaNAwareMeansOfChildren)
{
  hdt::TriangleMesh mesh;
  const hdt::Volume v = transferredSphere(mesh);
  for (int depth : { -1, 1, 2 })
  {
    vtkNew<vtkHyperTreeGrid> htg;
    vtkHDTConversionOptions o;
    o.MaxDepth = depth;
    vtkHDTToHyperTreeGrid::Convert(v, o, htg);
    for (size_t k = 0; k < v.arrays.size(); ++k)
    {
      auto* a = vtkFloatArray::SafeDownCast(htg->GetCellData()->GetArray(v.arrays[k].name.c_str()));
      ASSERT_TRUE(a) << v.arrays[k].name;
      ASSERT_EQ(a->GetNumberOfComponents(), int(v.arrays[k].components));
      ASSERT_EQ(a->GetNumberOfTuples(), htg->GetNumberOfCells());
      int wrong = 0, valid = 0;
      const vtkIdType visited = hdtvtk::ForEachCellBox(htg, v.grid, [&](vtkIdType cell, bool, int x, int y, int z, int edge) {
        for (uint32_t j = 0; j < uint32_t(a->GetNumberOfComponents()); ++j)
        {
          const float got = a->GetTypedComponent(cell, int(j));
          wrong += !same(got, bruteMean(v, k, j, x, y, z, edge));
          valid += edge == 1 && !std::isnan(got);
        }
      });
      ASSERT_EQ(visited, htg->GetNumberOfCells());
      EXPECT_EQ(wrong, 0) << "depth " << depth << " array " << k;
      if (depth == -1)
      {
        EXPECT_EQ(uint64_t(valid), v.stats.activeVoxels * v.arrays[k].components) << "a value on every surface voxel";
      }
    }
  }
}

TEST(VoxelArrays, SurfaceQuadsMeanTheCellsBehindThem)
{
  hdt::TriangleMesh mesh;
  const hdt::Volume v = transferredSphere(mesh);
  for (int depth : { -1, 2 })
  {
    vtkNew<vtkPolyData> surface;
    vtkHDTFillVoxelSurface(v, depth, surface);
    vtkHDTAddVoxelSurfaceArrays(v, depth, surface);
    auto* a = vtkFloatArray::SafeDownCast(surface->GetCellData()->GetArray("X"));
    ASSERT_TRUE(a);
    hdt::SurfaceOptions so;
    so.maxDepth = depth;
    const std::vector<hdt::SurfaceQuad> quads = hdt::extractSurfaceQuads(v, so);
    ASSERT_EQ(a->GetNumberOfTuples(), vtkIdType(quads.size()));
    const int c = hdt::surfaceCellEdge(v.grid, depth);
    int wrong = 0, surfaceQuads = 0;
    for (size_t i = 0; i < quads.size(); ++i)
    {
      const hdt::SurfaceQuad& q = quads[i];
      double sum = 0;
      int count = 0;
      for (int dv = 0; dv < q.dv; dv += c)
      {
        for (int du = 0; du < q.du; du += c)
        {
          int o[3];
          o[q.axis] = q.outward > 0 ? q.plane - c : q.plane;
          o[q.axis == 0 ? 1 : 0] = q.u + du;
          o[q.axis == 2 ? 1 : 2] = q.v + dv;
          const double m = bruteMean(v, 0, 0, o[0], o[1], o[2], c);
          if (!std::isnan(m))
          {
            sum += m;
            ++count;
          }
        }
      }
      wrong += !same(a->GetValue(vtkIdType(i)), count ? sum / count : std::nan(""));
      surfaceQuads += q.state == uint8_t(hdt::VoxelState::Surface);
      if (q.state == uint8_t(hdt::VoxelState::Surface))
      {
        wrong += std::isnan(a->GetValue(vtkIdType(i))); // a surface cell behind it has a value
      }
    }
    EXPECT_EQ(wrong, 0) << "depth " << depth;
    EXPECT_GT(surfaceQuads, 0);
  }
}

TEST(VoxelArrays, VoxelizerTransfersTheSelectedArrays)
{
  vtkNew<vtkSphereSource> sphere;
  sphere->SetThetaResolution(24);
  sphere->SetPhiResolution(24);
  vtkNew<vtkElevationFilter> elevation;
  elevation->SetInputConnection(sphere->GetOutputPort());
  elevation->SetLowPoint(0, 0, -0.5);
  elevation->SetHighPoint(0, 0, 0.5);
  vtkNew<vtkHDTVoxelizer> vox;
  vox->SetInputConnection(elevation->GetOutputPort());
  vox->SetResolution(32);
  vox->SetRootGridSize(2);
  vox->SetLeafGridSize(8);
  vox->SetBackend(vtkHDTVoxelizer::BACKEND_CPU);
  vox->SetMaxDepth(-1);
  vox->Update();
  EXPECT_FALSE(vox->GetOutput()->GetCellData()->GetArray("Elevation")) << "none by default";
  vox->GetPointDataArraySelection()->EnableArray("Elevation");
  vox->Update();
  EXPECT_FALSE(vox->GetLastRunReusedVolume()) << "a new selection is a new build";
  auto* a = vtkFloatArray::SafeDownCast(vox->GetOutput()->GetCellData()->GetArray("Elevation"));
  ASSERT_TRUE(a);
  const auto volume = vox->GetVolume();
  ASSERT_EQ(volume->arrays.size(), 1u);
  // The grid's voxel cells hold the volume's values: spot checks along a line
  // through the centre, where surface and inside voxels lie.
  vtkNew<vtkHyperTreeGridNonOrientedCursor> cursor;
  const int n = volume->grid.resolution, R = volume->grid.rootGrid, edge = volume->grid.rootCellVoxels();
  int checked = 0;
  for (int x = 0; x < n; ++x)
  {
    const int y = n / 2, z = n / 2;
    const int t = x / edge + R * (y / edge + R * (z / edge));
    vox->GetOutput()->InitializeNonOrientedCursor(cursor, t);
    int ox = (x / edge) * edge, oy = (y / edge) * edge, oz = (z / edge) * edge, e = edge;
    while (!cursor->IsLeaf())
    {
      e /= 2;
      const int c = int(x >= ox + e) | (int(y >= oy + e) << 1) | (int(z >= oz + e) << 2);
      ox += (c & 1) * e;
      oy += ((c >> 1) & 1) * e;
      oz += (c >> 2) * e;
      cursor->ToChild(c);
    }
    if (e == 1)
    {
      EXPECT_TRUE(same(a->GetValue(cursor->GetGlobalNodeIndex()), hdt::voxelArrayValue(*volume, 0, 0, x, y, z)));
      checked += !std::isnan(a->GetValue(cursor->GetGlobalNodeIndex()));
    }
  }
  EXPECT_EQ(checked, 2) << "the line crosses the sphere's surface twice";
  EXPECT_TRUE(vox->GetSurfaceOutput()->GetCellData()->GetArray("Elevation"));
  // HDT To Image: a point per block, the block's NaN-aware mean.
  for (int level : { 0, 1 })
  {
    vtkNew<vtkHDTToImage> image;
    image->SetInputConnection(vox->GetOutputPort(0));
    image->SetLevel(level);
    image->Update();
    auto* p = vtkFloatArray::SafeDownCast(image->GetOutput()->GetPointData()->GetArray("Elevation"));
    ASSERT_TRUE(p);
    int dims[3];
    image->GetOutput()->GetDimensions(dims);
    ASSERT_EQ(dims[0], n >> level);
    int wrong = 0, finite = 0;
    for (vtkIdType i = 0; i < p->GetNumberOfTuples(); ++i)
    {
      const int x = int(i % dims[0]), y = int((i / dims[0]) % dims[1]), z = int(i / (dims[0] * dims[1]));
      const int e = 1 << level;
      wrong += !same(p->GetValue(i), bruteMean(*volume, 0, 0, x * e, y * e, z * e, e));
      finite += !std::isnan(p->GetValue(i));
    }
    EXPECT_EQ(wrong, 0) << "level " << level;
    EXPECT_GT(finite, 0);
  }
  vox->GetCellDataArraySelection()->EnableArray("NoSuchArray");
  vox->Update();
  EXPECT_EQ(vox->GetOutput()->GetNumberOfCells(), 0) << "a missing array is an error";
}

} // namespace
