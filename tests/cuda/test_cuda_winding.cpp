// The winding-number inside test on the CUDA driver: the same bytes as the
// CPU driver on the winding-number shapes (open, overlapping, nested,
// self-intersecting, doubled) under Winding and Parity, as one piece and in
// memory-bounded chunks, and on the shared open meshes when present.
#include "cuda_compare.hpp"

#include "hdt/builder.hpp"
#include "hdt/mesh.hpp"
#include "hdt/mesh_io.hpp"
#include "support/mesh_files.hpp"
#include "support/winding_reference.hpp"

#include <gtest/gtest.h>

#include <cstdlib>
#include <fstream>
#include <string>

namespace hdt {
namespace test {
namespace {

BuildConfig config(int n, int r, int l, InsideTest test) {
  BuildConfig c;
  c.resolution = n;
  c.rootGrid = r;
  c.leafSize = l;
  c.insideTest = test;
  return c;
}

class CudaWinding : public ::testing::TestWithParam<int> {};

TEST_P(CudaWinding, SameBytesAsCpu) {
  HDT_REQUIRE_CUDA();
  const WindingShape s = windingShapes()[size_t(GetParam())];
  for (InsideTest test : {InsideTest::WindingNumber, InsideTest::Parity, InsideTest::Auto}) {
    const PreparedMesh mesh = prepareMesh(s.mesh, config(128, 4, 16, test));
    const Volume cpu = build(mesh, cpuOptions());
    const Volume gpu = build(mesh, cudaOptions());
    EXPECT_EQ(gpu.insideTest, cpu.insideTest) << s.name;
    EXPECT_TRUE(sameVolume(gpu, cpu)) << s.name << " test " << int(test);
    BuildOptions chunked = cudaOptions();
    chunked.deviceMemoryBudget = 48ull << 20; // forces chunks
    EXPECT_TRUE(sameVolume(build(mesh, chunked), cpu)) << s.name << " chunked, test " << int(test);
  }
}

INSTANTIATE_TEST_SUITE_P(Shapes, CudaWinding, ::testing::Range(0, int(windingShapes().size())),
                         [](const ::testing::TestParamInfo<int>& i) { return windingShapes()[size_t(i.param)].name; });

class CudaWindingShared : public ::testing::TestWithParam<const char*> {};

TEST_P(CudaWindingShared, SameBytesAsCpu) {
  HDT_REQUIRE_CUDA();
  const std::string dir = sharedMeshesDir(); // the GPU machine's binary PLY copies, or the shared folder
  std::string path;
  for (const char* ext : {".obj", ".ply", ".stl"}) {
    const std::string p = dir + "/" + GetParam() + ext;
    if (path.empty() && std::ifstream(p).good()) path = p;
  }
  if (path.empty()) GTEST_SKIP() << GetParam() << " not in \"" << dir << "\"";
  const TriangleMesh m = readMesh(path);
  for (InsideTest test : {InsideTest::WindingNumber, InsideTest::Parity}) {
    const PreparedMesh mesh = prepareMesh(m, config(128, 8, 16, test));
    EXPECT_TRUE(sameVolume(build(mesh, cudaOptions()), build(mesh, cpuOptions()))) << GetParam() << " " << int(test);
  }
}

INSTANTIATE_TEST_SUITE_P(Files, CudaWindingShared,
                         ::testing::Values("teapot", "ogre"),
                         [](const ::testing::TestParamInfo<const char*>& i) {
                           std::string n = i.param;
                           for (char& c : n)
                             if (c == '-') c = '_';
                           return n;
                         });

} // namespace
} // namespace test
} // namespace hdt
