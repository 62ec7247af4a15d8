// Optional: the CUDA driver against the CPU driver on the real meshes of
// sharedMeshesDir() ($HDT_MESHES_DIR, which the GPU machine's script sets, or
// the shared folder beside the checkout) at 1024^3, 2048^3 and 4096^3, R = 16, L = 16, solid and surface-only.
// Skips, saying why, when no meshes are there.
#include "cuda_compare.hpp"
#include "support/mesh_files.hpp"

#include "hdt/builder.hpp"
#include "hdt/error.hpp"
#include "hdt/mesh.hpp"
#include "hdt/mesh_io.hpp"

#include <gtest/gtest.h>

#include <algorithm>
#include <cstdlib>
#include <filesystem>
#include <map>
#include <string>
#include <tuple>
#include <vector>

namespace hdt {
namespace test {
namespace {

namespace fs = std::filesystem;

using Param = std::tuple<std::string, int, bool>;

class CudaSharedMeshes : public ::testing::TestWithParam<Param> {};

// Meshes are read once per file (the resolutions share them).
const TriangleMesh& cachedMesh(const std::string& path) {
  static std::map<std::string, TriangleMesh> cache;
  auto it = cache.find(path);
  if (it == cache.end()) it = cache.emplace(path, readMesh(path)).first;
  return it->second;
}

TEST_P(CudaSharedMeshes, SameBytesAsCpu) {
  const std::string& file = std::get<0>(GetParam());
  if (file.empty()) GTEST_SKIP() << "no meshes in \"" << sharedMeshesDir() << "\" (HDT_MESHES_DIR, or the shared folder beside the checkout)";
  HDT_REQUIRE_CUDA();
  const std::string path = sharedMeshesDir() + "/" + file;
  TriangleMesh mesh;
  try {
    mesh = cachedMesh(path);
  } catch (const Error& e) {
    GTEST_SKIP() << "cannot read " << path << " in this build: " << e.what();
  }
  BuildConfig config;
  config.resolution = std::get<1>(GetParam());
  config.rootGrid = 16;
  config.leafSize = 16;
  config.surfaceOnly = std::get<2>(GetParam());
  config.insideTest = InsideTest::Parity; // the parity build's bytes (the winding pass: test_cuda_winding.cpp)
  const PreparedMesh prepared = prepareMesh(mesh, config);
  const Volume cpu = build(prepared, cpuOptions());
  const Volume gpu = build(prepared, cudaOptions());
  EXPECT_TRUE(sameVolume(gpu, cpu)) << file << " at " << config.resolution;
}

INSTANTIATE_TEST_SUITE_P(Files, CudaSharedMeshes,
                         ::testing::Combine(::testing::ValuesIn(meshFilesIn(sharedMeshesDir())), ::testing::Values(1024, 2048, 4096),
                                            ::testing::Bool()),
                         [](const ::testing::TestParamInfo<Param>& info) {
                           return meshCaseName(std::get<0>(info.param)) + "_N" + std::to_string(std::get<1>(info.param)) +
                                  (std::get<2>(info.param) ? "_surface" : "_solid");
                         });

} // namespace
} // namespace test
} // namespace hdt
