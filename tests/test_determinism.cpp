// The CPU driver's bytes must not depend on the thread count or on the run:
// the CUDA driver is compared against them byte for byte, and files written
// twice must be identical.
#include "hdt/builder.hpp"
#include "hdt/mesh.hpp"
#include "hdt/volume.hpp"
#include "support/shapes.hpp"

#include <gtest/gtest.h>

#include <algorithm>
#include <thread>

namespace hdt {
namespace test {
namespace {

class Determinism : public ::testing::TestWithParam<ShapeCase> {};

TEST_P(Determinism, SameBytesForAnyThreadCountAndRun) {
  const ShapeCase& c = GetParam();
  const PreparedMesh mesh = prepareShapeCase(c);

  BuildOptions options;
  options.backend = Backend::Cpu;
  options.threads = 1;
  const Volume serial = buildCpu(mesh, options);
  ASSERT_GT(serial.stats.activeVoxels, 0u);
  ASSERT_GT(serial.leafCount(), 1u) << "too small to have anything to schedule";
  EXPECT_EQ(serial.stats.threads, 1);

  const int hw = int(std::max(1u, std::thread::hardware_concurrency()));
  // (More threads than cores would only make oneTBB print a warning: its
  // worker count is capped at the core count.)
  for (int threads : {2, hw}) {
    options.threads = threads;
    for (int run = 0; run < 2; ++run) {
      const Volume v = buildCpu(mesh, options);
      EXPECT_EQ(v.stats.threads, threads);
      const std::string diff = firstDifference(serial, v);
      EXPECT_TRUE(diff.empty()) << c.shape << " N=" << c.n << ": threads=" << threads << " run " << run
                                << " differs from threads=1: " << diff;
    }
  }
  // threads = 0 means "all cores".
  options.threads = 0;
  const Volume all = buildCpu(mesh, options);
  EXPECT_EQ(all.stats.threads, hw);
  EXPECT_EQ(firstDifference(serial, all), "");
}

INSTANTIATE_TEST_SUITE_P(Cpu, Determinism,
                         ::testing::Values(ShapeCase{"sphere", 128, 4, 8, false},
                                           ShapeCase{"hollow_sphere", 128, 2, 16, false},
                                           ShapeCase{"open_hemisphere", 128, 1, 16, false}, // 3-axis vote
                                           ShapeCase{"two_bodies", 256, 16, 8, false},
                                           ShapeCase{"degenerate_mix", 128, 4, 32, false},
                                           ShapeCase{"torus", 256, 8, 16, true}),
                         [](const ::testing::TestParamInfo<ShapeCase>& info) { return shapeCaseName(info.param); });

// Preparing twice gives the same lattice mesh (the input to both drivers).
TEST(PrepareDeterminism, SameLatticeMeshTwice) {
  const Shape shape = twoBodiesShape();
  const BuildConfig config = shape.config(256, 16, 16, false);
  const PreparedMesh a = prepareMesh(shape.mesh, config);
  const PreparedMesh b = prepareMesh(shape.mesh, config);
  ASSERT_EQ(a.triangles.size(), b.triangles.size());
  for (size_t t = 0; t < a.triangles.size(); ++t)
    for (int j = 0; j < 3; ++j)
      for (int k = 0; k < 3; ++k) ASSERT_EQ(a.triangles[t].v[j][k], b.triangles[t].v[j][k]) << "triangle " << t;
  EXPECT_EQ(a.closed, b.closed);
  EXPECT_EQ(a.grid.origin, b.grid.origin);
  EXPECT_EQ(a.grid.voxelSize, b.grid.voxelSize);
}

} // namespace
} // namespace test
} // namespace hdt
