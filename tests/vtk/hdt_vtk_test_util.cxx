#include "hdt_vtk_test_util.h"

#include "vtkBitArray.h"
#include "vtkCellData.h"
#include "vtkHyperTreeGrid.h"
#include "vtkHyperTreeGridNonOrientedCursor.h"
#include "vtkHyperTreeGridNonOrientedGeometryCursor.h"
#include "vtkNew.h"
#include "vtkParametricFunctionSource.h"
#include "vtkParametricTorus.h"
#include "vtkPolyData.h"
#include "vtkSphereSource.h"
#include "vtkTriangleFilter.h"
#include "vtkUnsignedCharArray.h"

#include <cmath>
#include <functional>
#include <sstream>

namespace hdtvtk
{

vtkSmartPointer<vtkPolyData> MakeSphere(int resolution, double radius, double cx, double cy, double cz)
{
  vtkNew<vtkSphereSource> sphere;
  sphere->SetThetaResolution(resolution);
  sphere->SetPhiResolution(resolution);
  sphere->SetRadius(radius);
  sphere->SetCenter(cx, cy, cz);
  sphere->Update();
  return sphere->GetOutput();
}

vtkSmartPointer<vtkPolyData> MakeTorus(double ring, double cross)
{
  vtkNew<vtkParametricTorus> torus;
  torus->SetRingRadius(ring);
  torus->SetCrossSectionRadius(cross);
  vtkNew<vtkParametricFunctionSource> source;
  source->SetParametricFunction(torus);
  source->SetUResolution(72);
  source->SetVResolution(36);
  // Plain triangles whatever the source emits.
  vtkNew<vtkTriangleFilter> triangles;
  triangles->SetInputConnection(source->GetOutputPort());
  triangles->Update();
  return triangles->GetOutput();
}

std::vector<uint8_t> DenseStates(const hdt::Volume& volume)
{
  const int n = volume.grid.resolution;
  std::vector<uint8_t> dense(size_t(n) * n * n);
  for (int z = 0; z < n; ++z)
  {
    for (int y = 0; y < n; ++y)
    {
      for (int x = 0; x < n; ++x)
      {
        dense[size_t(x) + size_t(n) * (size_t(y) + size_t(n) * size_t(z))] =
          uint8_t(hdt::voxelAt(volume, x, y, z));
      }
    }
  }
  return dense;
}

BoxTally TallyBox(const std::vector<uint8_t>& dense, int n, int x0, int y0, int z0, int k)
{
  BoxTally t;
  t.voxels = uint64_t(k) * k * k;
  for (int z = z0; z < z0 + k; ++z)
  {
    for (int y = y0; y < y0 + k; ++y)
    {
      const uint8_t* row = dense.data() + size_t(n) * (size_t(y) + size_t(n) * size_t(z));
      for (int x = x0; x < x0 + k; ++x)
      {
        t.surface += row[x] == 2;
        t.inside += row[x] == 1;
      }
    }
  }
  return t;
}

std::vector<int64_t> ReferenceCellsPerDepth(
  const hdt::Volume& volume, const std::vector<uint8_t>& dense, int depthCut)
{
  const hdt::GridSpec& g = volume.grid;
  const int n = g.resolution;
  std::vector<int64_t> counts(size_t(depthCut) + 1, 0);
  // Voxel boxes below the octree: refine while not uniform.
  std::function<void(int, int, int, int, int)> box = [&](int depth, int x, int y, int z, int k) {
    ++counts[size_t(depth)];
    if (depth == depthCut || k == 1 || TallyBox(dense, n, x, y, z, k).Uniform())
    {
      return;
    }
    const int h = k / 2;
    for (int c = 0; c < 8; ++c)
    {
      box(depth + 1, x + (c & 1) * h, y + ((c >> 1) & 1) * h, z + ((c >> 2) & 1) * h, h);
    }
  };
  // Octree elements: follow the HDT's own structure.
  std::function<void(uint64_t, int, int, int, int)> element = [&](uint64_t e, int level, int x,
                                                                  int y, int z) {
    const hdt::ElementWord w = volume.elements[e];
    const int k = g.elementVoxels(level);
    switch (hdt::elementState(w))
    {
      case hdt::ElementState::Empty:
      case hdt::ElementState::Full:
        ++counts[size_t(level)];
        return;
      case hdt::ElementState::Boundary:
        box(level, x, y, z, k);
        return;
      case hdt::ElementState::Branch:
        ++counts[size_t(level)];
        if (level == depthCut)
        {
          return;
        }
        for (int c = 0; c < 8; ++c)
        {
          element(uint64_t(hdt::elementPayload(w)) + uint64_t(c), level + 1,
            x + (c & 1) * (k / 2), y + ((c >> 1) & 1) * (k / 2), z + ((c >> 2) & 1) * (k / 2));
        }
        return;
    }
  };
  const int R = g.rootGrid;
  const int edge = g.rootCellVoxels();
  for (int k = 0; k < R; ++k)
  {
    for (int j = 0; j < R; ++j)
    {
      for (int i = 0; i < R; ++i)
      {
        element(uint64_t(i) + uint64_t(R) * (uint64_t(j) + uint64_t(R) * uint64_t(k)), 0, i * edge,
          j * edge, k * edge);
      }
    }
  }
  (void)n;
  while (counts.size() > 1 && counts.back() == 0)
  {
    counts.pop_back();
  }
  return counts;
}

WalkResult WalkAndCheck(vtkHyperTreeGrid* htg, const hdt::Volume& volume,
  const std::vector<uint8_t>& dense, int depthCut, bool expectMask)
{
  WalkResult r;
  const hdt::GridSpec& g = volume.grid;
  const int n = g.resolution;
  auto problem = [&](const std::string& what) {
    if (r.Problems.size() < 10)
    {
      r.Problems.push_back(what);
    }
  };
  auto* states = vtkUnsignedCharArray::SafeDownCast(htg->GetCellData()->GetArray("VoxelState"));
  if (!states)
  {
    problem("no VoxelState array");
    return r;
  }
  vtkBitArray* mask = htg->HasMask() ? htg->GetMask() : nullptr;
  if (!expectMask && mask)
  {
    problem("a mask is set although MaskOutside is off");
  }
  if (expectMask && !mask)
  {
    problem("no mask although MaskOutside is on");
  }
  if (states->GetNumberOfTuples() != htg->GetNumberOfCells())
  {
    problem("VoxelState has " + std::to_string(states->GetNumberOfTuples()) + " values for " +
      std::to_string(htg->GetNumberOfCells()) + " cells");
  }

  auto toVoxel = [&](double coord, int axis, int& voxel) {
    const double v = (coord - g.origin[size_t(axis)]) / g.voxelSize;
    voxel = int(std::lround(v));
    return std::fabs(v - voxel) < 1e-6;
  };

  vtkNew<vtkHyperTreeGridNonOrientedGeometryCursor> cursor;
  std::function<void()> visit = [&]() {
    const int depth = int(cursor->GetLevel());
    if (r.CellsPerDepth.size() <= size_t(depth))
    {
      r.CellsPerDepth.resize(size_t(depth) + 1, 0);
    }
    ++r.CellsPerDepth[size_t(depth)];
    const vtkIdType id = cursor->GetGlobalNodeIndex();
    const double* origin = cursor->GetOrigin();
    const double* size = cursor->GetSize();
    int v[3], k = 0;
    bool onLattice = true;
    for (int a = 0; a < 3; ++a)
    {
      onLattice &= toVoxel(origin[a], a, v[a]);
    }
    const double kd = size[0] / g.voxelSize;
    k = int(std::lround(kd));
    onLattice &= std::fabs(kd - k) < 1e-6 && std::fabs(size[1] - size[0]) < 1e-9 * size[0] &&
      std::fabs(size[2] - size[0]) < 1e-9 * size[0];
    std::ostringstream where;
    where << "cell " << id << " depth " << depth << " voxels (" << v[0] << "," << v[1] << ","
          << v[2] << ")+" << k;
    if (!onLattice || k < 1 || v[0] < 0 || v[1] < 0 || v[2] < 0 || v[0] + k > n ||
      v[1] + k > n || v[2] + k > n)
    {
      problem(where.str() + ": box not on the voxel lattice");
      return;
    }
    if (id < 0 || id >= states->GetNumberOfTuples())
    {
      problem(where.str() + ": global index out of range");
      return;
    }
    const BoxTally t = TallyBox(dense, n, v[0], v[1], v[2], k);
    const int state = states->GetValue(id);
    if (state != t.State())
    {
      problem(where.str() + ": VoxelState " + std::to_string(state) + ", expected " +
        std::to_string(t.State()));
    }
    const bool leaf = cursor->IsLeaf();
    const bool shouldRefine = depth < depthCut && k > 1 && !t.Uniform();
    if (leaf == shouldRefine)
    {
      problem(where.str() + (leaf ? ": leaf, expected refined" : ": refined, expected leaf"));
    }
    const bool masked = mask && mask->GetValue(id);
    const bool shouldMask = expectMask && leaf && state == 0;
    if (masked != shouldMask)
    {
      problem(where.str() + (masked ? ": masked, expected visible" : ": visible, expected masked"));
    }
    r.Masked += masked;
    if (leaf)
    {
      ++r.Leaves;
      r.LeafVoxels += t.voxels;
      return;
    }
    for (unsigned char c = 0; c < 8; ++c)
    {
      cursor->ToChild(c);
      visit();
      cursor->ToParent();
    }
  };

  vtkHyperTreeGrid::vtkHyperTreeGridIterator it;
  it.Initialize(htg);
  vtkIdType index = 0;
  while (it.GetNextTree(index))
  {
    htg->InitializeNonOrientedGeometryCursor(cursor, index);
    visit();
  }
  if (r.LeafVoxels != uint64_t(n) * n * n)
  {
    problem("leaves cover " + std::to_string(r.LeafVoxels) + " voxels, expected " +
      std::to_string(uint64_t(n) * n * n));
  }
  return r;
}

namespace
{

vtkIdType VisitCellBoxes(vtkHyperTreeGridNonOrientedCursor* cursor, int x, int y, int z, int edge,
  const CellBoxVisitor& visit)
{
  const bool leaf = cursor->IsLeaf();
  visit(cursor->GetGlobalNodeIndex(), leaf, x, y, z, edge);
  if (leaf)
  {
    return 1;
  }
  vtkIdType cells = 1;
  const int half = edge / 2;
  for (int c = 0; c < 8; ++c)
  {
    cursor->ToChild(c);
    cells += VisitCellBoxes(cursor, x + (c & 1) * half, y + ((c >> 1) & 1) * half, z + (c >> 2) * half, half, visit);
    cursor->ToParent();
  }
  return cells;
}

} // namespace

vtkIdType ForEachCellBox(vtkHyperTreeGrid* htg, const hdt::GridSpec& grid, const CellBoxVisitor& visit)
{
  const int R = grid.rootGrid, edge = grid.rootCellVoxels();
  vtkIdType cells = 0;
  vtkNew<vtkHyperTreeGridNonOrientedCursor> cursor;
  for (int t = 0; t < R * R * R; ++t)
  {
    htg->InitializeNonOrientedCursor(cursor, t);
    cells += VisitCellBoxes(cursor, (t % R) * edge, ((t / R) % R) * edge, (t / (R * R)) * edge, edge, visit);
  }
  return cells;
}

} // namespace hdtvtk
