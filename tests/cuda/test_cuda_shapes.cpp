// The CUDA driver against the CPU driver, byte for byte, on the generated
// test shapes (tests/support/shapes.hpp: spheres, torus, boxes with faces on
// voxel planes and through voxel centres, thin plates, open meshes, two
// bodies, degenerate triangles), solid and surface-only, for four (R, L)
// combinations including both non-default leaf sizes.
#include "cuda_compare.hpp"

#include "hdt/builder.hpp"
#include "hdt/mesh.hpp"
#include "support/shapes.hpp"

#include <gtest/gtest.h>

#include <string>
#include <tuple>

namespace hdt {
namespace test {
namespace {

struct GridCase {
  int r, l, n;
};

// n = R * 2^h * L with h = 1 or 2: several octree levels, small enough for
// the CPU reference build to stay quick.
const GridCase kGrids[] = {{16, 16, 512}, {16, 8, 512}, {4, 8, 128}, {8, 32, 512}};

using Param = std::tuple<std::string, GridCase, bool>;

class CudaShapes : public ::testing::TestWithParam<Param> {};

TEST_P(CudaShapes, SameBytesAsCpu) {
  HDT_REQUIRE_CUDA();
  const std::string& name = std::get<0>(GetParam());
  const GridCase g = std::get<1>(GetParam());
  const bool surfaceOnly = std::get<2>(GetParam());
  const Shape shape = makeShape(name, g.n);
  const PreparedMesh mesh = prepareMesh(shape.mesh, shape.config(g.n, g.r, g.l, surfaceOnly));
  const Volume cpu = build(mesh, cpuOptions());
  const Volume gpu = build(mesh, cudaOptions());
  EXPECT_TRUE(sameVolume(gpu, cpu));
  EXPECT_GT(gpu.stats.peakDeviceBytes, 0u);
  EXPECT_GE(gpu.stats.time.total, 0.0);
}

// Dense clusters: thousands of tiny triangles per leaf, so that the driver
// splits leaves over several warps (LeafTask) and merges their results.
struct DenseCase {
  bool open;
  int l;
  bool surfaceOnly;
};

class CudaDense : public ::testing::TestWithParam<DenseCase> {};

TEST_P(CudaDense, SameBytesAsCpu) {
  HDT_REQUIRE_CUDA();
  const DenseCase c = GetParam();
  TriangleMesh mesh = c.open ? uvHemisphere(120, 240, 1.0) : icosphere(6, 1.0, {0.01, -0.02, 0.03});
  append(mesh, box({-3, -3, -3}, {-2.9, -2.9, -2.9})); // spreads the grid: the cluster fits a few leaves
  BuildConfig config;
  config.resolution = 4 * 2 * c.l * 4; // R = 4, height 2
  config.rootGrid = 4;
  config.leafSize = c.l;
  config.surfaceOnly = c.surfaceOnly;
  config.insideTest = InsideTest::Parity; // the parity build's bytes (the winding pass: test_cuda_winding.cpp)
  const PreparedMesh prepared = prepareMesh(mesh, config);
  EXPECT_TRUE(sameVolume(build(prepared, cudaOptions()), build(prepared, cpuOptions())));
}

INSTANTIATE_TEST_SUITE_P(Clusters, CudaDense,
                         ::testing::Values(DenseCase{false, 16, false}, DenseCase{true, 16, false},
                                           DenseCase{true, 8, false}, DenseCase{false, 32, true},
                                           DenseCase{true, 32, false}),
                         [](const ::testing::TestParamInfo<DenseCase>& i) {
                           return std::string(i.param.open ? "open" : "closed") + "_L" + std::to_string(i.param.l) +
                                  (i.param.surfaceOnly ? "_surface" : "_solid");
                         });

std::vector<std::string> shapeNames() {
  std::vector<std::string> names;
  for (const ShapeFactory& f : standardShapes()) names.push_back(f.name);
  return names;
}

INSTANTIATE_TEST_SUITE_P(All, CudaShapes,
                         ::testing::Combine(::testing::ValuesIn(shapeNames()), ::testing::ValuesIn(kGrids),
                                            ::testing::Bool()),
                         [](const ::testing::TestParamInfo<Param>& info) {
                           const GridCase g = std::get<1>(info.param);
                           return std::get<0>(info.param) + "_R" + std::to_string(g.r) + "_L" +
                                  std::to_string(g.l) + "_N" + std::to_string(g.n) +
                                  (std::get<2>(info.param) ? "_surface" : "_solid");
                         });

} // namespace
} // namespace test
} // namespace hdt
