// Data transfer (hdt/transfer.hpp) on CUDA-built volumes: the same .hdt bytes
// (tree, leaves, labels and transferred arrays) as on CPU-built ones. The
// transfer is a host pass, so this checks that nothing of the build it reads
// differs; skips without a device.
#include "cuda_compare.hpp"

#include "hdt/builder.hpp"
#include "hdt/hdt_file.hpp"
#include "hdt/labels.hpp"
#include "hdt/transfer.hpp"
#include "support/shapes.hpp"

#include <gtest/gtest.h>

namespace hdt {
namespace test {
namespace {

std::vector<MeshArray> arraysOf(const TriangleMesh& m) {
  MeshArray x{"x", ArraySource::Point, 3, m.points}, index{"index", ArraySource::Cell, 1, {}};
  for (size_t t = 0; t < m.triangleCount(); ++t) index.values.push_back(double(t));
  return {x, index};
}

std::vector<uint8_t> bytesWithoutStatistics(const Volume& v) {
  Volume copy = v;
  copy.stats = Statistics{};
  computeStructureStatistics(copy);
  HdtWriteOptions raw;
  raw.compressLeaves = false;
  return serializeHdt(copy, raw);
}

TEST(CudaTransfer, SameArraysAsTheCpuBuild) {
  HDT_REQUIRE_CUDA();
  TriangleMesh m = icosphere(4, 1.0, {-0.4, 0, 0});
  append(m, torus(1.0, 0.3, 48, 24, {0.5, 0.1, 0}));
  BuildConfig c;
  c.resolution = 256;
  c.rootGrid = 8;
  c.leafSize = 16;
  Volume cpu = voxelize(m, c, cpuOptions()), gpu = voxelize(m, c, cudaOptions());
  transferArrays(m, arraysOf(m), cpu);
  transferArrays(m, arraysOf(m), gpu);
  EXPECT_TRUE(bytesWithoutStatistics(cpu) == bytesWithoutStatistics(gpu));
  m.triangleLabels.assign(m.triangleCount(), 1);
  std::fill(m.triangleLabels.begin() + long(icosphere(4, 1.0).triangleCount()), m.triangleLabels.end(), 2);
  Volume lcpu = voxelizeLabelled(m, c, cpuOptions()), lgpu = voxelizeLabelled(m, c, cudaOptions());
  transferArrays(m, arraysOf(m), lcpu);
  transferArrays(m, arraysOf(m), lgpu);
  EXPECT_TRUE(bytesWithoutStatistics(lcpu) == bytesWithoutStatistics(lgpu));
}

} // namespace
} // namespace test
} // namespace hdt
