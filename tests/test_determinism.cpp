// The CPU driver's bytes must not depend on the thread count or on the run:
// the CUDA driver is compared against them byte for byte, and files written
// twice must be identical.
#include "hdt/builder.hpp"
#include "hdt/mesh.hpp"
#include "hdt/volume.hpp"
#include "support/shapes.hpp"

#include <gtest/gtest.h>

#include <algorithm>
#include <sstream>
#include <thread>

namespace hdt {
namespace test {
namespace {

struct DeterminismCase {
  std::string shape;
  int n, r, l;
  bool surfaceOnly;
};

void PrintTo(const DeterminismCase& c, std::ostream* os) {
  *os << c.shape << " N=" << c.n << " R=" << c.r << " L=" << c.l << (c.surfaceOnly ? " surface-only" : " solid");
}

// Where two volumes first differ, or "" when they are the same bytes.
std::string firstDifference(const Volume& a, const Volume& b) {
  std::ostringstream s;
  if (a.levelStart != b.levelStart) {
    s << "levelStart differs (" << a.levelStart.size() << " vs " << b.levelStart.size() << " entries)";
    return s.str();
  }
  if (a.elements.size() != b.elements.size()) {
    s << "element count " << a.elements.size() << " vs " << b.elements.size();
    return s.str();
  }
  auto e = std::mismatch(a.elements.begin(), a.elements.end(), b.elements.begin());
  if (e.first != a.elements.end()) {
    s << "element #" << (e.first - a.elements.begin()) << ": 0x" << std::hex << *e.first << " vs 0x" << *e.second;
    return s.str();
  }
  if (a.leafWords.size() != b.leafWords.size()) {
    s << "leaf word count " << a.leafWords.size() << " vs " << b.leafWords.size();
    return s.str();
  }
  auto w = std::mismatch(a.leafWords.begin(), a.leafWords.end(), b.leafWords.begin());
  if (w.first != a.leafWords.end()) {
    const size_t i = size_t(w.first - a.leafWords.begin());
    s << "leaf word #" << i << " (leaf " << i / leafWordCount(a.grid.leafSize) << "): 0x" << std::hex << *w.first
      << " vs 0x" << *w.second;
    return s.str();
  }
  const Statistics &sa = a.stats, &sb = b.stats;
  if (sa.activeVoxels != sb.activeVoxels || sa.insideVoxels != sb.insideVoxels || sa.leafGrids != sb.leafGrids ||
      sa.treeElements != sb.treeElements)
    return "structural statistics differ";
  return "";
}

class Determinism : public ::testing::TestWithParam<DeterminismCase> {};

TEST_P(Determinism, SameBytesForAnyThreadCountAndRun) {
  const DeterminismCase& c = GetParam();
  const Shape shape = makeShape(c.shape, c.n);
  const PreparedMesh mesh = prepareMesh(shape.mesh, shape.config(c.n, c.r, c.l, c.surfaceOnly));

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
                         ::testing::Values(DeterminismCase{"sphere", 128, 4, 8, false},
                                           DeterminismCase{"hollow_sphere", 128, 2, 16, false},
                                           DeterminismCase{"open_hemisphere", 128, 1, 16, false}, // 3-axis vote
                                           DeterminismCase{"two_bodies", 256, 16, 8, false},
                                           DeterminismCase{"degenerate_mix", 128, 4, 32, false},
                                           DeterminismCase{"torus", 256, 8, 16, true}),
                         [](const ::testing::TestParamInfo<DeterminismCase>& info) {
                           const DeterminismCase& c = info.param;
                           return c.shape + "_N" + std::to_string(c.n) + "_R" + std::to_string(c.r) + "_L" +
                                  std::to_string(c.l) + (c.surfaceOnly ? "_surface" : "_solid");
                         });

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
