// Optional: the real meshes of ../shared/meshes (scans and CAD parts made by
// other people) against the reference at 64^3 and 128^3, with the closed or the open
// rule as PreparedMesh::closed decides. Skips, saying why, when the folder is
// absent; the unit tests proper never depend on it.
#include "hdt/builder.hpp"
#include "hdt/error.hpp"
#include "hdt/mesh.hpp"
#include "hdt/mesh_io.hpp"
#include "support/mesh_files.hpp"
#include "support/reference_voxelizer.hpp"

#include <gtest/gtest.h>

#include <algorithm>
#include <filesystem>
#include <string>
#include <vector>

namespace hdt {
namespace test {
namespace {

namespace fs = std::filesystem;

struct SharedCase {
  std::string file; // "" when there is nothing to test
  int n, r, l;
};

std::vector<SharedCase> sharedCases() {
  std::vector<SharedCase> out;
  for (const std::string& f : meshFilesIn(sharedMeshesDir())) {
    out.push_back({f, 64, 2, 8});  // height 2
    if (!f.empty()) out.push_back({f, 128, 4, 8}); // height 2, more roots
  }
  return out;
}

void PrintTo(const SharedCase& c, std::ostream* os) {
  *os << (c.file.empty() ? "(none)" : c.file) << " N=" << c.n << " R=" << c.r << " L=" << c.l;
}

class SharedMesh : public ::testing::TestWithParam<SharedCase> {};

TEST_P(SharedMesh, CpuBuildMatchesReference) {
  const SharedCase& c = GetParam();
  if (c.file.empty())
    GTEST_SKIP() << "no meshes in \"" << sharedMeshesDir() << "\" (the shared folder beside the checkout is optional)";
  const std::string path = sharedMeshesDir() + "/" + c.file;
  const std::string ext = fs::path(path).extension().string();
  TriangleMesh mesh;
  try {
    mesh = readMesh(path);
  } catch (const Error& e) {
    // Only a build without assimp may refuse a format; a real reader error fails.
    if (!readsAllMeshFormats()) GTEST_SKIP() << "this build cannot read " << ext << " files: " << e.what();
    FAIL() << e.what();
  }

  BuildConfig config;
  config.resolution = c.n;
  config.rootGrid = c.r;
  config.leafSize = c.l;
  config.insideTest = InsideTest::Parity; // the reference's rules (open meshes: 3-axis majority)
  const PreparedMesh prepared = prepareMesh(mesh, config);
  const ReferenceVoxels ref = referenceVoxelize(prepared, false);
  if (prepared.closed) {
    EXPECT_EQ(ref.axisDisagreements, 0u)
        << "closed on the lattice, so the three ray parities must agree; first: " << ref.firstDisagreement;
  }
  BuildOptions options;
  options.backend = Backend::Cpu;
  const Volume volume = buildCpu(prepared, options);
  const TreeView view = walkVolume(volume);
  EXPECT_TRUE(volumeMatchesReference(volume, view, ref))
      << c.file << " N=" << c.n << " (" << prepared.triangles.size() << " triangles, "
      << prepared.degenerateTriangles << " degenerate after snapping, " << (prepared.closed ? "closed rule" : "open rule") << ")";
  EXPECT_EQ(volume.stats.activeVoxels, ref.surfaceCount);
  EXPECT_EQ(volume.stats.insideVoxels, view.insideVoxels);
  if (prepared.closed) EXPECT_EQ(volume.stats.insideVoxels, ref.insideCount);
  RecordProperty("closed", prepared.closed ? "yes" : "no");
  RecordProperty("surfaceVoxels", std::to_string(ref.surfaceCount));
  RecordProperty("insideVoxels", std::to_string(ref.insideCount));
}

INSTANTIATE_TEST_SUITE_P(Files, SharedMesh, ::testing::ValuesIn(sharedCases()),
                         [](const ::testing::TestParamInfo<SharedCase>& info) {
                           if (info.param.file.empty()) return meshCaseName("");
                           return meshCaseName(info.param.file) + "_N" + std::to_string(info.param.n);
                         });

} // namespace
} // namespace test
} // namespace hdt
