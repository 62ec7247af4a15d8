// T2's (leaf, triangle) pairs on the device (cuda/src/branching.cu) against a
// brute force on the host: every leaf's triangles are exactly those that meet
// the leaf and each of its ancestors (the drivers' shared exact test,
// triangleOverlapsElement), in increasing triangle order. The leaf grids'
// bytes do not show that order (T3 merges a leaf's pairs with OR and XOR),
// so the CPU == CUDA byte tests cannot catch a T2 that misorders them.
#include "cuda_compare.hpp"

#include "phases.hpp"
#include "session.hpp"

#include "hdt/build_steps.hpp"
#include "hdt/mesh.hpp"
#include "support/shapes.hpp"

#include <gtest/gtest.h>

#include <map>
#include <string>
#include <vector>

namespace hdt {
namespace test {
namespace {

template <class T>
std::vector<T> toHost(const cuda::DeviceBuffer<T>& d, size_t count, cudaStream_t s) {
  std::vector<T> h(count);
  if (count) EXPECT_EQ(cudaMemcpyAsync(h.data(), d.data(), count * sizeof(T), cudaMemcpyDeviceToHost, s), cudaSuccess);
  EXPECT_EQ(cudaStreamSynchronize(s), cudaSuccess);
  return h;
}

// Per leaf cell (packed leaf coordinate) that some triangle meets, its
// triangles ascending: those that meet the cell and each of its ancestors.
std::map<uint64_t, std::vector<uint32_t>> bruteForceLeaves(const PreparedMesh& mesh) {
  const GridSpec& g = mesh.grid;
  const int64_t perAxis = g.resolution / g.leafSize;
  const uint64_t leafCells = uint64_t(perAxis) * perAxis * perAxis;
  std::map<uint64_t, std::vector<uint32_t>> out;
  for (uint32_t t = 0; t < mesh.triangles.size(); ++t) {
    const LatticeTriangle& tri = mesh.triangles[t];
    forEachRootCell(tri, int64_t(g.leafSize) * kLatticePerVoxel, perAxis, 0, leafCells, [&](uint32_t cell) {
      const uint32_t x = uint32_t(cell % perAxis), y = uint32_t(cell / perAxis % perAxis),
                     z = uint32_t(cell / perAxis / perAxis);
      bool meets = true;
      for (int level = 0; level < g.height && meets; ++level) {
        const int shift = g.height - level;
        meets = triangleOverlapsElement(tri, packCoord(x >> shift, y >> shift, z >> shift),
                                        int64_t(g.elementVoxels(level)) * kLatticePerVoxel);
      }
      if (meets) out[packCoord(x, y, z)].push_back(t);
    });
  }
  return out;
}

struct TreeCase {
  std::string shape;
  int n, r, l;
};

class CudaTreePairs : public ::testing::TestWithParam<TreeCase> {};

TEST_P(CudaTreePairs, EveryLeafHoldsItsTrianglesInOrder) {
  HDT_REQUIRE_CUDA();
  const TreeCase& c = GetParam();
  Shape shape;
  if (c.shape == "fine_sphere") { // 81,920 triangles: more than the segmented scan's 16-bit counters allow
    shape.name = c.shape;
    shape.mesh = icosphere(6, 1.0, {0.1, -0.2, 0.3});
  } else {
    shape = makeShape(c.shape, c.n);
  }
  const PreparedMesh mesh = prepareMesh(shape.mesh, shape.config(c.n, c.r, c.l, true));
  const BuildOptions options = cudaOptions();
  cuda::Session s(mesh, options);
  cuda::uploadTriangles(s);
  const GridSpec& g = s.grid;
  const uint64_t cells = uint64_t(g.rootGrid) * g.rootGrid * g.rootGrid;
  cuda::RootMapping root = cuda::mapTrianglesToRootCells(s.memory, s.scalars, s.deviceMesh, g, 0, cells, false);
  const cuda::Tree tree =
      cuda::buildTree(s.memory, s.scalars, s.deviceMesh, g, 0, cells, std::move(root.pairs), true, {});
  const cuda::Leaves& lf = tree.leaves;
  const cudaStream_t st = s.stream.get();
  const std::vector<uint64_t> coord = toHost(lf.coord, lf.count, st);
  const std::vector<uint32_t> start = toHost(lf.pairStart, size_t(lf.count) + 1, st);
  const std::vector<uint32_t> tri = toHost(lf.triangle, lf.pairCount, st);

  const std::map<uint64_t, std::vector<uint32_t>> want = bruteForceLeaves(mesh);
  ASSERT_GT(lf.count, 0u);
  EXPECT_EQ(lf.count, want.size()); // every leaf cell that some triangle meets, once
  EXPECT_EQ(start.front(), 0u);
  EXPECT_EQ(start.back(), lf.pairCount);
  uint64_t wrong = 0;
  for (uint32_t i = 0; i < lf.count; ++i) {
    const std::vector<uint32_t> got(tri.begin() + start[i], tri.begin() + start[i + 1]);
    const auto it = want.find(coord[i]);
    const std::vector<uint32_t> expected = it == want.end() ? std::vector<uint32_t>{} : it->second;
    if (got != expected && wrong++ == 0) {
      ADD_FAILURE() << "leaf " << i << " (" << unpackCoord(coord[i], 0) << "," << unpackCoord(coord[i], 1) << ","
                    << unpackCoord(coord[i], 2) << "): " << got.size() << " triangles, " << expected.size()
                    << " expected (first " << (got.empty() ? -1 : int64_t(got[0])) << " vs "
                    << (expected.empty() ? -1 : int64_t(expected[0])) << ")";
    }
  }
  EXPECT_EQ(wrong, 0u) << "leaves with wrong triangles";
}

// Three octree levels below the root grid (n / r / l = 8: an odd count, so
// that an order reversed at every level does not come back to the right
// one), small and large segments (a root cell of the sphere holds hundreds
// of pairs); both scans of branching.cu (the segmented one below 65,536
// triangles, fine_sphere above).
INSTANTIATE_TEST_SUITE_P(Cuda, CudaTreePairs,
                         ::testing::Values(TreeCase{"sphere", 128, 2, 8}, TreeCase{"torus", 256, 4, 8},
                                           TreeCase{"two_bodies", 128, 2, 8}, TreeCase{"degenerate_mix", 64, 1, 8},
                                           TreeCase{"fine_sphere", 128, 2, 8}),
                         [](const ::testing::TestParamInfo<TreeCase>& i) {
                           return i.param.shape + "_N" + std::to_string(i.param.n);
                         });

} // namespace
} // namespace test
} // namespace hdt
