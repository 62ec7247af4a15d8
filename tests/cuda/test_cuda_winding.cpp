// The winding-number inside test on the CUDA driver: the same bytes as the
// CPU driver on the winding-number shapes (open, overlapping, nested,
// self-intersecting, doubled) under Winding and Parity, as one piece and in
// memory-bounded chunks, and on the shared open meshes when present.
#include "cuda_compare.hpp"

#include "hdt/builder.hpp"
#include "hdt/mesh.hpp"
#include "hdt/mesh_io.hpp"
#include "hdt/volume_walk.hpp"
#include "hdt/winding_crossings.hpp"
#include "hdt/winding_tree.hpp"
#include "winding_device.hpp"
#include "support/mesh_files.hpp"
#include "support/shapes.hpp"
#include "support/winding_reference.hpp"

#include <gtest/gtest.h>

#include <algorithm>
#include <cstdlib>
#include <fstream>
#include <regex>
#include <string>
#include <vector>

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

// The device pass's N (cuda/src/winding_device.cu: crossings, line
// suffixes, per-voxel counts) against windingRayCrossings on the host at
// every non-surface voxel centre of a CPU build.
::testing::AssertionResult deviceCountsMatch(const PreparedMesh& mesh) {
  const Volume v = build(mesh, cpuOptions());
  const int L = v.grid.leafSize;
  std::vector<std::array<int, 3>> origins(v.leafWords.size() / leafWordCount(L));
  walkVolume(v, int(v.levelStart.size()) - 2, [&](const WalkedElement& e) {
    if (e.state() == ElementState::Boundary) origins[e.payload()] = e.origin;
  });
  const WindingTree tree = buildWindingTree(mesh.triangles);
  std::vector<int16_t> counts;
  std::vector<uint8_t> fits;
  cuda::windingCountsOnDevice(tree, L, origins, counts, fits);
  const size_t n = size_t(L) * size_t(L) * size_t(L);
  uint64_t compared = 0;
  for (size_t leaf = 0; leaf < origins.size(); ++leaf) {
    if (!fits[leaf]) return ::testing::AssertionFailure() << "leaf " << leaf << " does not fit 16 bits";
    const LeafView view{v.leafWords.data() + leafWordOffset(leaf, L), L};
    for (size_t i = 0; i < n; ++i) {
      const int x = int(i % size_t(L)), y = int((i / size_t(L)) % size_t(L)), z = int(i / (size_t(L) * size_t(L)));
      if (view.voxel(x, y, z) == VoxelState::Surface) continue;
      const double p[3] = {origins[leaf][0] + x + 0.5, origins[leaf][1] + y + 0.5, origins[leaf][2] + z + 0.5};
      int64_t P[3];
      int expected = 0;
      if (!windingLatticePoint(p, P) || !windingRayCrossings(tree.view(), P, expected))
        return ::testing::AssertionFailure() << "no reference count at a non-surface voxel of leaf " << leaf;
      if (int(counts[leaf * n + i]) != expected)
        return ::testing::AssertionFailure() << "leaf " << leaf << " voxel " << x << "," << y << "," << z
                                             << ": device N " << counts[leaf * n + i] << ", host " << expected;
      ++compared;
    }
  }
  if (compared == 0) return ::testing::AssertionFailure() << "no non-surface leaf voxel";
  return ::testing::AssertionSuccess() << compared << " voxels";
}

// The device leaf decision splits each leaf into 4x4 blocks of rows that own
// their words: leaf sizes 8 and 32 as well (SameBytesAsCpu uses 16).
TEST_P(CudaWinding, SameBytesAsCpuLeafSizes) {
  HDT_REQUIRE_CUDA();
  const WindingShape s = windingShapes()[size_t(GetParam())];
  for (const auto& rl : {std::pair<int, int>{4, 8}, std::pair<int, int>{2, 32}}) {
    const PreparedMesh mesh = prepareMesh(s.mesh, config(128, rl.first, rl.second, InsideTest::WindingNumber));
    EXPECT_TRUE(sameVolume(build(mesh, cudaOptions()), build(mesh, cpuOptions()))) << s.name << " L " << rl.second;
  }
}

TEST_P(CudaWinding, DeviceCountsEqualRayCrossings) {
  HDT_REQUIRE_CUDA();
  const WindingShape s = windingShapes()[size_t(GetParam())];
  for (int l : {8, 16}) EXPECT_TRUE(deviceCountsMatch(prepareMesh(s.mesh, config(64, 4, l, InsideTest::Parity))))
      << s.name << " L " << l;
}

// The crossings step spreads each leaf's (candidate, ray line) items over a
// block (winding_device.cu, leafCrossingSumsKernel): leaves with hundreds of
// candidates (more items than the block's threads, a thread taking several)
// and rows with a dozen crossings summed by many threads at once. Six nested
// icospheres, every other one inward, each of them doubled: the surfaces lie
// about two voxels apart at 64^3, N climbs and falls through them.
TEST(CudaWindingCrossings, ManyCandidatesPerLeaf) {
  HDT_REQUIRE_CUDA();
  TriangleMesh m;
  for (int k = 0; k < 6; ++k) {
    TriangleMesh shell = icosphere(3, 1.0 - 0.07 * k, {0.01 * k, -0.007 * k, 0.003 * k});
    if (k % 2) flipOrientation(shell);
    append(m, shell);
    append(m, shell);
  }
  for (int l : {8, 16}) {
    EXPECT_TRUE(deviceCountsMatch(prepareMesh(m, config(64, 4, l, InsideTest::Parity)))) << "L " << l;
    const PreparedMesh mesh = prepareMesh(m, config(128, 4, l, InsideTest::WindingNumber));
    EXPECT_TRUE(sameVolume(build(mesh, cudaOptions()), build(mesh, cpuOptions()))) << "L " << l;
  }
}

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
  EXPECT_TRUE(deviceCountsMatch(prepareMesh(m, config(64, 4, 8, InsideTest::Parity)))) << GetParam();
}

// Refinement on the device (the split elements' children and their fresh
// leaves, winding_device.cu): teapot at 2048^3 splits elements where w = 1/2
// spans the lid's opening.
TEST(CudaWindingRefined, TeapotSameBytesAsCpu) {
  HDT_REQUIRE_CUDA();
  const std::string path = sharedMeshesDir() + "/teapot.ply";
  if (!std::ifstream(path).good()) GTEST_SKIP() << "no " << path;
  const PreparedMesh mesh = prepareMesh(readMesh(path), config(2048, 8, 16, InsideTest::WindingNumber));
  const Volume gpu = build(mesh, cudaOptions());
  EXPECT_GT(gpu.stats.windingRefinedElements, 0u);
  EXPECT_TRUE(sameVolume(gpu, build(mesh, cpuOptions())));
}

// The device pass's fallbacks (winding_device.cu), forced through its test
// switches: box queues that overflow (elements to the serial walk, leaves to
// the host) and every single leaf voxel decided on the host.
class ScopedEnv {
public:
  ScopedEnv(const char* name, const char* value) : name_(name) { setenv(name, value, 1); }
  ~ScopedEnv() { unsetenv(name_); }

private:
  const char* name_;
};

// The numbers that `pattern`'s first group matches in the log lines, summed.
uint64_t loggedCount(const std::vector<std::string>& lines, const std::string& pattern) {
  const std::regex re(pattern);
  uint64_t sum = 0;
  std::smatch m;
  for (const std::string& l : lines)
    if (std::regex_search(l, m, re)) sum += std::stoull(m[1].str());
  return sum;
}

TEST(CudaWindingFallbacks, SameBytesWhenQueuesOverflowOrVoxelsGoToTheHost) {
  HDT_REQUIRE_CUDA();
  // HDT_WINDING_LEAF_PASS_FAILS: the device leaf pass gives up midway; the
  // host pass decides every leaf from the words the build kept on the device.
  for (const char* variable : {"HDT_WINDING_QUEUE_BOXES", "HDT_WINDING_HOST_VOXELS", "HDT_WINDING_LEAF_PASS_FAILS"}) {
    const ScopedEnv forced(variable, "1");
    uint64_t leftLeaves = 0, hostVoxels = 0, hostPasses = 0;
    for (const WindingShape& s : windingShapes()) {
      const PreparedMesh mesh = prepareMesh(s.mesh, config(128, 4, 16, InsideTest::WindingNumber));
      std::vector<std::string> log;
      BuildOptions o = cudaOptions();
      o.log = [&](const std::string& line) { log.push_back(line); };
      EXPECT_TRUE(sameVolume(build(mesh, o), build(mesh, cpuOptions()))) << s.name << " " << variable;
      leftLeaves += loggedCount(log, "([0-9]+) of [0-9]+ leaves left to the host");
      hostVoxels += loggedCount(log, "([0-9]+) voxels on the host");
      hostPasses += uint64_t(std::count_if(log.begin(), log.end(), [](const std::string& l) {
        return l.find("winding leaf pass; it runs on the host") != std::string::npos;
      }));
    }
    if (std::string(variable) == "HDT_WINDING_QUEUE_BOXES") EXPECT_GT(leftLeaves, 0u) << "no queue overflowed";
    if (std::string(variable) == "HDT_WINDING_HOST_VOXELS") EXPECT_GT(hostVoxels, 0u) << "no voxel went to the host";
    if (std::string(variable) == "HDT_WINDING_LEAF_PASS_FAILS") EXPECT_GT(hostPasses, 0u) << "the leaf pass never failed";
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
