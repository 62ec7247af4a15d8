// The winding tree pinned bit for bit (core/src/winding.cpp, buildWindingTree
// and buildWindingEdges): every winding build's bytes depend on the tree's
// node order and on each node's sums (the uncertified voxel centres take the
// exact sum in tree order), so a faster build must give the same tree. The
// expected hashes were computed by the build of main at 5090c8a (one nth_element
// over 152-byte items per node, edges sorted by corners); a change of them
// is a change of every winding build's output.
#include "hdt/mesh.hpp"
#include "hdt/mesh_io.hpp"
#include "hdt/winding_tree.hpp"
#include "support/mesh_files.hpp"
#include "support/shapes.hpp"
#include "support/winding_reference.hpp"

#include <gtest/gtest.h>
#include <tbb/task_arena.h>

#include <cstdint>
#include <cstdio>
#include <string>

namespace hdt {
namespace test {
namespace {

// windingTreeDigest as 16 hex digits.
std::string treeHash(const WindingTree& t) {
  char s[17];
  std::snprintf(s, sizeof s, "%016llx", static_cast<unsigned long long>(windingTreeDigest(t)));
  return s;
}

PreparedMesh prepared(const TriangleMesh& mesh, int resolution) {
  BuildConfig c;
  c.resolution = resolution;
  c.rootGrid = 8;
  c.leafSize = 8;
  c.insideTest = InsideTest::WindingNumber;
  return prepareMesh(mesh, c);
}

// The same hash on one thread and on all of them.
void expectTreeHash(const PreparedMesh& m, const std::string& expected, const std::string& what) {
  const WindingTree all = buildWindingTree(m.triangles);
  EXPECT_EQ(treeHash(all), expected) << what << ": " << m.triangles.size() << " triangles, " << all.nodes.size()
                                     << " nodes, " << all.edges.size() << " edges";
  WindingTree one;
  tbb::task_arena(1).execute([&] { one = buildWindingTree(m.triangles); });
  EXPECT_EQ(treeHash(one), expected) << what << " on one thread";
}

TEST(WindingTreePinned, ShapesMatchTheirHashes) {
  const char* const expected[] = {
      "73ac268a16abd401", "64689b046553d53e", "dade95f46799fc20", "710ed474fb81cbcd", "b2ffd8df3610c558",
      "d7409582cdbf6258", "7f5b2e868f1cef16", "73ac268a16abd401", "3887ecbc87567d23",
  };
  const std::vector<WindingShape> shapes = windingShapes();
  ASSERT_EQ(shapes.size(), sizeof expected / sizeof expected[0]);
  for (size_t i = 0; i < shapes.size(); ++i) expectTreeHash(prepared(shapes[i].mesh, 64), expected[i], shapes[i].name);
}

// 86,400 triangles, open: subtrees in parallel, many boundary edges.
TEST(WindingTreePinned, HemisphereMatchesItsHash) {
  expectTreeHash(prepared(uvHemisphere(120, 360, 1.0), 256), "6c7a2d9fa240d69b", "hemisphere");
  expectTreeHash(prepared(uvHemisphere(120, 360, 1.0), 8192), "d5ee08ba1e501e73", "hemisphere at 8192");
}

// The shared meshes as the GPU machine has them (binary PLY, HDT_MESHES_DIR).
TEST(WindingTreePinned, SharedMeshesMatchTheirHashes) {
  const struct {
    const char* file;
    const char* hash;
  } meshes[] = {
      {"teapot.ply", "b55777db056ea828"}, {"ogre.ply", "833d68dff43dd966"}, {"nefertiti.ply", "b2593f781567486b"}};
  int found = 0;
  for (const auto& m : meshes) {
    std::string why;
    const std::string path = sharedMeshPath(m.file, &why);
    if (path.empty()) continue;
    ++found;
    expectTreeHash(prepared(readMesh(path), 8192), m.hash, m.file);
  }
  if (found == 0) GTEST_SKIP() << "no binary PLY copies of the shared meshes (HDT_MESHES_DIR)";
}

} // namespace
} // namespace test
} // namespace hdt
