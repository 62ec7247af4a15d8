// Labelled builds (hdt/labels.hpp): the CUDA driver against the CPU driver,
// byte for byte (tree, leaf words, element and voxel labels), on the label
// test cases of tests/test_labels.cpp and on the shared meshes labelled by
// connected components.
#include "cuda_compare.hpp"

#include "hdt/builder.hpp"
#include "hdt/labels.hpp"
#include "hdt/mesh.hpp"
#include "hdt/mesh_io.hpp"
#include "support/shapes.hpp"

#include <gtest/gtest.h>

#include <cstdlib>
#include <string>
#include <sys/stat.h>

namespace hdt {
namespace test {
namespace {

TriangleMesh withLabel(TriangleMesh m, Label label) {
  m.triangleLabels.assign(m.triangleCount(), label);
  return m;
}

TriangleMesh combined(std::initializer_list<TriangleMesh> parts) {
  TriangleMesh all;
  for (const TriangleMesh& p : parts) {
    append(all, p);
    all.triangleLabels.insert(all.triangleLabels.end(), p.triangleLabels.begin(), p.triangleLabels.end());
  }
  return all;
}

BuildConfig grid(int n, int r, int l) {
  BuildConfig c;
  c.resolution = n;
  c.rootGrid = r;
  c.leafSize = l;
  return c;
}

::testing::AssertionResult sameLabelled(const Volume& gpu, const Volume& cpu) {
  const ::testing::AssertionResult states = sameVolume(gpu, cpu);
  if (!states) return states;
  if (gpu.labels.elementLabels != cpu.labels.elementLabels)
    return ::testing::AssertionFailure() << "element labels differ";
  if (gpu.labels.voxelLabels != cpu.labels.voxelLabels) return ::testing::AssertionFailure() << "voxel labels differ";
  return ::testing::AssertionSuccess();
}

void expectSameOnBoth(const TriangleMesh& mesh, const BuildConfig& config, const LabelOptions& labels = {}) {
  const Volume cpu = voxelizeLabelled(mesh, config, cpuOptions(), labels);
  const Volume gpu = voxelizeLabelled(mesh, config, cudaOptions(), labels);
  EXPECT_TRUE(sameLabelled(gpu, cpu));
  BuildOptions chunked = cudaOptions();
  chunked.deviceMemoryBudget = 64ull << 20; // small: builds the root grid in chunks
  EXPECT_TRUE(sameLabelled(voxelizeLabelled(mesh, config, chunked, labels), cpu)) << "chunked";
}

TEST(CudaLabels, TouchingCubesNestedBoxesOverlappingSpheres) {
  HDT_REQUIRE_CUDA();
  const TriangleMesh cubes = combined({withLabel(box({-1, -1, -1}, {0, 1, 1}), 1), withLabel(box({0, -1, -1}, {1, 1, 1}), 2)});
  const TriangleMesh nested =
      combined({withLabel(box({-1, -1, -1}, {1, 1, 1}), 1), withLabel(box({-0.3, -0.3, -0.3}, {0.3, 0.3, 0.3}), 2)});
  const TriangleMesh spheres = combined({withLabel(icosphere(4, 1.0, {-0.4, 0, 0}), 3),
                                         withLabel(icosphere(4, 1.0, {0.4, 0, 0}), 7)});
  for (const BuildConfig& c : {grid(128, 4, 8), grid(512, 16, 16), grid(512, 8, 32)}) {
    expectSameOnBoth(cubes, c);
    expectSameOnBoth(nested, c);
    for (OverlapPolicy p : {OverlapPolicy::Lowest, OverlapPolicy::Highest}) {
      LabelOptions o;
      o.overlap = p;
      expectSameOnBoth(spheres, c, o);
    }
    LabelOptions priority;
    priority.overlap = OverlapPolicy::Priority;
    priority.priority = {7};
    expectSameOnBoth(spheres, c, priority);
    BuildConfig surface = c;
    surface.surfaceOnly = true;
    expectSameOnBoth(spheres, surface);
  }
}

TEST(CudaLabels, SharedMeshesByComponents) {
  HDT_REQUIRE_CUDA();
  const char* env = std::getenv("HDT_MESHES_DIR"); // as test_cuda_shared_meshes.cpp
  const std::string dir = env && *env ? env : HDT_SHARED_MESHES_DIR;
  int done = 0;
  for (const char* name : {"cycloidal-drive.ply", "ogre.obj", "bracket.stl"}) {
    const std::string path = dir + "/" + name;
    struct stat st;
    if (::stat(path.c_str(), &st) != 0) continue;
    if (std::string(name).find(".obj") != std::string::npos && !readsAllMeshFormats()) continue;
    const TriangleMesh mesh = readMesh(path, {MeshLabelSource::Kind::Components, ""});
    SCOPED_TRACE(name);
    expectSameOnBoth(mesh, grid(512, 16, 16));
    expectSameOnBoth(mesh, grid(1024, 16, 16));
    ++done;
  }
  if (done == 0) GTEST_SKIP() << "no shared meshes in " << dir;
}

} // namespace
} // namespace test
} // namespace hdt
