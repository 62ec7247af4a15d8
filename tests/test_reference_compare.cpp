// The CPU builder against the independent brute-force reference
// (tests/support/reference_voxelizer.*), over every test shape, several
// (N, R, L) splits and both modes, plus the reference's own sanity checks.
#include "hdt/builder.hpp"
#include "hdt/error.hpp"
#include "hdt/mesh.hpp"
#include "hdt/volume.hpp"
#include "support/reference_voxelizer.hpp"
#include "support/shapes.hpp"

#include <gtest/gtest.h>

#include <functional>
#include <map>
#include <memory>
#include <sstream>
#include <tuple>

namespace hdt {
namespace test {
namespace {

struct GridCase {
  int n, r, l;
};

// Every split below is N = R * 2^h * L; heights 0 to 3, all three leaf sizes.
const std::vector<GridCase>& gridCases() {
  static const std::vector<GridCase> cases = {
      {32, 4, 8},   // h = 0
      {32, 2, 16},  // h = 0, L = 16
      {64, 4, 8},   // h = 1
      {64, 1, 8},   // h = 3, a single root cell
      {64, 2, 32},  // h = 0, L = 32 (full 32-bit row masks)
      {128, 16, 8}, // h = 0, many roots
      {128, 2, 16}, // h = 2
      {128, 1, 32}, // h = 2, L = 32
      {256, 16, 8}, // h = 1
      {256, 16, 16} // h = 0
  };
  return cases;
}

struct CompareCase {
  std::string shape;
  GridCase grid;
  bool surfaceOnly;
};

std::vector<CompareCase> compareCases() {
  std::vector<CompareCase> out;
  for (const ShapeFactory& s : standardShapes())
    for (const GridCase& g : gridCases())
      for (bool surfaceOnly : {false, true}) out.push_back({s.name, g, surfaceOnly});
  return out;
}

// Readable parameters in failure lines (instead of gtest's byte dump).
void PrintTo(const CompareCase& c, std::ostream* os) {
  *os << c.shape << " N=" << c.grid.n << " R=" << c.grid.r << " L=" << c.grid.l
      << (c.surfaceOnly ? " surface-only" : " solid");
}

std::string caseName(const ::testing::TestParamInfo<CompareCase>& info) {
  const CompareCase& c = info.param;
  return c.shape + "_N" + std::to_string(c.grid.n) + "_R" + std::to_string(c.grid.r) + "_L" +
         std::to_string(c.grid.l) + (c.surfaceOnly ? "_surface" : "_solid");
}

bool sameTriangles(const PreparedMesh& a, const PreparedMesh& b) {
  if (a.triangles.size() != b.triangles.size()) return false;
  for (size_t i = 0; i < a.triangles.size(); ++i)
    for (int j = 0; j < 3; ++j)
      for (int k = 0; k < 3; ++k)
        if (a.triangles[i].v[j][k] != b.triangles[i].v[j][k]) return false;
  return true;
}

// The reference depends on the snapped mesh and the mode only (placement
// depends on N, not on R or L), so consecutive cases of one shape and N share
// it. The cache keeps one shape/N at a time: at N = 256 a reference is 32 MB.
const ReferenceVoxels& cachedReference(const std::string& shape, const PreparedMesh& mesh, bool surfaceOnly) {
  struct Entry {
    PreparedMesh mesh;
    std::unique_ptr<ReferenceVoxels> ref;
  };
  static std::string currentKey;
  static std::map<bool, Entry> entries;
  const std::string key = shape + "/" + std::to_string(mesh.grid.resolution);
  if (key != currentKey) {
    entries.clear();
    currentKey = key;
  }
  Entry& e = entries[surfaceOnly];
  if (!e.ref || !sameTriangles(e.mesh, mesh) || e.mesh.closed != mesh.closed) {
    e.mesh = mesh;
    e.ref = std::make_unique<ReferenceVoxels>(referenceVoxelize(mesh, surfaceOnly));
  }
  return *e.ref;
}

class ReferenceCompare : public ::testing::TestWithParam<CompareCase> {};

TEST_P(ReferenceCompare, CpuBuildMatchesReference) {
  const CompareCase& c = GetParam();
  const Shape shape = makeShape(c.shape, c.grid.n);
  const BuildConfig config = shape.config(c.grid.n, c.grid.r, c.grid.l, c.surfaceOnly);
  const PreparedMesh mesh = prepareMesh(shape.mesh, config);
  ASSERT_EQ(mesh.closed, shape.expectClosed) << c.shape << ": the case would not test the rule it is meant to";

  const ReferenceVoxels& ref = cachedReference(c.shape, mesh, c.surfaceOnly);
  if (mesh.closed && !c.surfaceOnly) {
    ASSERT_EQ(ref.axisDisagreements, 0u)
        << "reference self-check: on a closed mesh the +x, +y and +z parities must agree; first: "
        << ref.firstDisagreement;
  }
  ASSERT_GT(ref.surfaceCount, 0u) << "the shape produced no surface voxel: the case tests nothing";

  BuildOptions options;
  options.backend = Backend::Cpu;
  const Volume volume = buildCpu(mesh, options);
  const TreeView view = walkVolume(volume);
  EXPECT_TRUE(volumeMatchesReference(volume, view, ref))
      << c.shape << " N=" << c.grid.n << " R=" << c.grid.r << " L=" << c.grid.l
      << (c.surfaceOnly ? " surface-only" : " solid") << (mesh.closed ? " (closed rule)" : " (open rule)");
  if (!view.problems.empty()) return; // the counts below would only repeat it

  // Structural statistics against the reference and the walked tree.
  const Statistics& s = volume.stats;
  const uint64_t L = uint64_t(c.grid.l);
  EXPECT_EQ(s.activeVoxels, ref.surfaceCount) << "stats.activeVoxels vs reference surface voxels";
  EXPECT_EQ(s.activeVoxels, view.surfaceVoxels) << "stats.activeVoxels vs the tree's own surface voxels";
  if (mesh.closed || c.surfaceOnly)
    EXPECT_EQ(s.insideVoxels, ref.insideCount) << "stats.insideVoxels vs reference inside voxels";
  EXPECT_EQ(s.insideVoxels, view.insideVoxels) << "stats.insideVoxels vs the tree's dense view";
  if (c.surfaceOnly) EXPECT_EQ(s.insideVoxels, 0u) << "surface-only builds have no inside voxel";
  EXPECT_EQ(s.leafGrids, view.boundaryCount);
  EXPECT_EQ(s.leafGrids, volume.leafCount());
  EXPECT_EQ(s.leafVoxels, s.leafGrids * L * L * L);
  EXPECT_EQ(s.treeElements, volume.elements.size());
  EXPECT_EQ(s.topologyBytes, volume.elements.size() * 4);
  EXPECT_EQ(s.leafBytes, volume.leafWords.size() * 4);
  EXPECT_EQ(s.triangles, mesh.triangles.size());
  EXPECT_EQ(s.degenerateTriangles, mesh.degenerateTriangles);
  EXPECT_EQ(volume.levelStart.size(), size_t(volume.grid.height) + 2);
  EXPECT_EQ(volume.grid.height, mesh.grid.height);
  EXPECT_EQ(volume.surfaceOnly, c.surfaceOnly);
  EXPECT_EQ(volume.closedMesh, mesh.closed);

  // hdt::voxelAt (the library's own walker) against ours: every voxel up to
  // 64^3, a deterministic sample of 20000 above.
  const int n = c.grid.n;
  uint64_t mismatches = 0;
  std::string first;
  auto check = [&](int x, int y, int z) {
    const VoxelState a = voxelAt(volume, x, y, z);
    const uint8_t b = view.dense[ref.index(x, y, z)];
    if (uint8_t(a) != b && mismatches++ == 0) {
      std::ostringstream m;
      m << "voxel (" << x << "," << y << "," << z << "): voxelAt says " << stateName(a) << ", the tree walk "
        << stateName(VoxelState(b));
      first = m.str();
    }
  };
  if (n <= 64) {
    for (int z = 0; z < n; ++z)
      for (int y = 0; y < n; ++y)
        for (int x = 0; x < n; ++x) check(x, y, z);
  } else {
    uint64_t state = 0x9E3779B97F4A7C15ull;
    for (int i = 0; i < 20000; ++i) {
      state = state * 6364136223846793005ull + 1442695040888963407ull;
      check(int((state >> 16) % n), int((state >> 32) % n), int((state >> 48) % n));
    }
  }
  EXPECT_EQ(mismatches, 0u) << "hdt::voxelAt disagrees with the tree walk; first: " << first;
}

INSTANTIATE_TEST_SUITE_P(Shapes, ReferenceCompare, ::testing::ValuesIn(compareCases()), caseName);

// ---- the shapes themselves -------------------------------------------------------------

class ShapeSanity : public ::testing::TestWithParam<std::tuple<std::string, int>> {};

TEST_P(ShapeSanity, PreparedAsIntended) {
  const std::string name = std::get<0>(GetParam());
  const int n = std::get<1>(GetParam());
  const Shape shape = makeShape(name, n);
  const PreparedMesh mesh = prepareMesh(shape.mesh, shape.config(n, 4, 8, false));
  EXPECT_EQ(mesh.closed, shape.expectClosed);
  EXPECT_EQ(mesh.degenerateTriangles, shape.expectedDegenerate);
  EXPECT_EQ(mesh.triangles.size() + mesh.degenerateTriangles, shape.mesh.triangleCount());
  if (shape.expectClosed) {
    EXPECT_GT(signedVolume(shape.mesh), 0.0) << "closed test shapes must be oriented outward";
  }
  if (shape.hasBounds) {
    EXPECT_DOUBLE_EQ(mesh.grid.voxelSize, 1.0) << "unit-voxel frame";
    for (int a = 0; a < 3; ++a) EXPECT_DOUBLE_EQ(mesh.grid.origin[a], -0.5 * n);
  }
  const int64_t want = shape.latticeCheck == Shape::LatticeCheck::VoxelPlanes ? 0 : 128;
  if (shape.latticeCheck != Shape::LatticeCheck::None) {
    for (size_t t = 0; t < mesh.triangles.size(); ++t)
      for (int j = 0; j < 3; ++j)
        for (int a = 0; a < 3; ++a)
          ASSERT_EQ(mesh.triangles[t].v[j][a] % 256, want)
              << name << ": triangle " << t << " vertex " << j << " axis " << a << " snapped to "
              << mesh.triangles[t].v[j][a] << ", not on a voxel " << (want ? "centre" : "plane");
  }
}

std::vector<std::tuple<std::string, int>> sanityCases() {
  std::vector<std::tuple<std::string, int>> out;
  for (const ShapeFactory& s : standardShapes())
    for (int n : {32, 64, 128, 256}) out.emplace_back(s.name, n);
  return out;
}

INSTANTIATE_TEST_SUITE_P(Shapes, ShapeSanity, ::testing::ValuesIn(sanityCases()),
                         [](const ::testing::TestParamInfo<std::tuple<std::string, int>>& info) {
                           return std::get<0>(info.param) + "_N" + std::to_string(std::get<1>(info.param));
                         });

TEST(ShapeOrientation, HollowSphereInnerShellFacesInward) {
  TriangleMesh inner = icosphere(2, 0.55);
  const double v = signedVolume(inner);
  flipOrientation(inner);
  EXPECT_GT(v, 0.0);
  EXPECT_NEAR(signedVolume(inner), -v, 1e-12);
  EXPECT_LT(signedVolume(hollowSphereShape().mesh), signedVolume(sphereShape().mesh));
}

// ---- the reference's own checks (no builder involved) ------------------------------------

LatticeTriangle lt(std::initializer_list<int32_t> c) {
  LatticeTriangle t{};
  auto it = c.begin();
  for (int j = 0; j < 3; ++j)
    for (int a = 0; a < 3; ++a) t.v[j][a] = *it++;
  return t;
}

TEST(ReferencePrimitives, BoxTriangleTouchingIsExact) {
  const int64_t lo[3] = {0, 0, 0}, hi[3] = {512, 512, 512};
  // Only the edge-cross-axis separates: bounding boxes and the plane overlap.
  // The hypotenuse is the line x + y = c in the plane z = 256; the box's
  // nearest edge has x + y = 1024.
  auto hyp = [](int32_t c) { return lt({c - 128, 128, 256, 128, c - 128, 256, 1024, 1024, 256}); };
  EXPECT_TRUE(refBoxMeetsTriangle(hyp(1023), lo, hi));
  EXPECT_TRUE(refBoxMeetsTriangle(hyp(1024), lo, hi)) << "touching the box edge counts";
  EXPECT_FALSE(refBoxMeetsTriangle(hyp(1025), lo, hi)) << "one lattice unit off";
  // A face lying in the box's face plane touches; one unit outside does not.
  EXPECT_TRUE(refBoxMeetsTriangle(lt({512, 100, 100, 512, 900, 100, 512, 100, 900}), lo, hi));
  EXPECT_FALSE(refBoxMeetsTriangle(lt({513, 100, 100, 513, 900, 100, 513, 100, 900}), lo, hi));
  // Vertex on the box corner; a tilted plane just missing the corner.
  EXPECT_TRUE(refBoxMeetsTriangle(lt({512, 512, 512, 900, 600, 700, 600, 900, 800}), lo, hi));
  // Plane x + y + z = 1537 misses the corner (512,512,512) (sum 1536) by one unit.
  EXPECT_FALSE(refBoxMeetsTriangle(lt({1537, 0, 0, 0, 1537, 0, 0, 0, 1537}), lo, hi));
  EXPECT_TRUE(refBoxMeetsTriangle(lt({1536, 0, 0, 0, 1536, 0, 0, 0, 1536}), lo, hi));
  // A large triangle enclosing the box in projection, plane through the middle.
  EXPECT_TRUE(refBoxMeetsTriangle(lt({-5000, -5000, 256, 9000, -5000, 256, -5000, 9000, 256}), lo, hi));
}

TEST(ReferencePrimitives, PerturbedRayCountsSharedEdgesAndVerticesOnce) {
  // A 2 x 2 grid of squares in the plane x = 1000 (u = y, w = z), each split
  // along a diagonal, with alternating diagonals: every query point on the
  // lattice of half-squares strictly inside the grid, including vertices and
  // edges, must be counted by exactly one triangle along +x.
  std::vector<LatticeTriangle> tris;
  for (int i = 0; i < 2; ++i)
    for (int j = 0; j < 2; ++j) {
      const int32_t y0 = 256 * i, y1 = y0 + 256, z0 = 256 * j, z1 = z0 + 256;
      if ((i + j) % 2 == 0) {
        tris.push_back(lt({1000, y0, z0, 1000, y1, z0, 1000, y1, z1}));
        tris.push_back(lt({1000, y0, z0, 1000, y1, z1, 1000, y0, z1}));
      } else {
        tris.push_back(lt({1000, y0, z0, 1000, y1, z0, 1000, y0, z1}));
        tris.push_back(lt({1000, y1, z0, 1000, y1, z1, 1000, y0, z1}));
      }
    }
  for (int64_t pu = 64; pu <= 448; pu += 64)
    for (int64_t pw = 64; pw <= 448; pw += 64) {
      int hits = 0;
      for (const LatticeTriangle& t : tris) {
        __int128 num;
        int64_t den;
        if (refRayCrossing(t, 0, pu, pw, num, den)) {
          ++hits;
          EXPECT_EQ(num, __int128(1000) * den);
        }
      }
      EXPECT_EQ(hits, 1) << "query (y, z) = (" << pu << ", " << pw << ")";
    }
  // Outside the grid: nothing.
  for (const LatticeTriangle& t : tris) {
    __int128 num;
    int64_t den;
    EXPECT_FALSE(refRayCrossing(t, 0, -1, 100, num, den));
    EXPECT_FALSE(refRayCrossing(t, 0, 100, 513, num, den));
  }
  // A triangle parallel to the ray is never crossed.
  __int128 num;
  int64_t den;
  EXPECT_FALSE(refRayCrossing(lt({0, 0, 0, 512, 0, 0, 0, 512, 0}), 0, 100, 0, num, den));
  EXPECT_EQ(refOrientPerturbed(0, 0, 0, 0, 5, 5), 0) << "only a zero-length edge has no sign";
}

TEST(ReferencePrimitives, CrossingPositionIsExact) {
  // Plane x = y / 3 + 100 through (100,0,0), (100,0,900), (400,900,0); the +x
  // ray at (y, z) = (128, 128) meets it at x = 100 + 128/3.
  const LatticeTriangle t = lt({100, 0, 0, 100, 0, 900, 400, 900, 0});
  __int128 num;
  int64_t den;
  ASSERT_TRUE(refRayCrossing(t, 0, 128, 128, num, den));
  ASSERT_GT(den, 0);
  EXPECT_EQ(num * 3, __int128(428) * den);
  // The same along +y (u = z, w = x): through (z, x) = (128, 120) at y = 60.
  ASSERT_TRUE(refRayCrossing(t, 1, 128, 120, num, den));
  EXPECT_EQ(num, __int128(60) * den);
}

// Closed-form voxel counts for boxes with faces on voxel planes / centres:
// checks the reference itself, including the tie rules, at N = 64.
TEST(ReferenceSelfCheck, GridAlignedBoxCounts) {
  const int n = 64;
  const Shape shape = gridAlignedBoxShape(n);
  const PreparedMesh mesh = prepareMesh(shape.mesh, shape.config(n, 4, 8, false));
  const ReferenceVoxels ref = referenceVoxelize(mesh, false);
  // Faces on planes a and b (voxel indices): voxels a-1 .. b touch the box,
  // a+1 .. b-2 touch no face.
  const int lo[3] = {n / 4, n / 8 + 1, 3 * n / 16}, hi[3] = {3 * n / 4, 5 * n / 8 + 1, 13 * n / 16 - 1};
  uint64_t touching = 1, interior = 1;
  for (int a = 0; a < 3; ++a) {
    touching *= uint64_t(hi[a] - lo[a] + 2);
    interior *= uint64_t(hi[a] - lo[a] - 2);
  }
  EXPECT_EQ(ref.surfaceCount, touching - interior);
  EXPECT_EQ(ref.insideCount, interior);
  EXPECT_EQ(ref.axisDisagreements, 0u) << ref.firstDisagreement;
  EXPECT_EQ(ref.at(lo[0] - 1, lo[1], lo[2]), VoxelState::Surface) << "the voxel outside a face touches it";
  EXPECT_EQ(ref.at(lo[0] - 2, lo[1], lo[2]), VoxelState::Outside);
  EXPECT_EQ(ref.at(lo[0] + 1, lo[1] + 1, lo[2] + 1), VoxelState::Inside);
  const ReferenceVoxels surf = referenceVoxelize(mesh, true);
  EXPECT_EQ(surf.surfaceCount, touching - interior);
  EXPECT_EQ(surf.insideCount, 0u);
}

TEST(ReferenceSelfCheck, CentreBoxCounts) {
  const int n = 64;
  const Shape shape = centreBoxShape(n);
  const PreparedMesh mesh = prepareMesh(shape.mesh, shape.config(n, 4, 8, false));
  const ReferenceVoxels ref = referenceVoxelize(mesh, false);
  // Faces through the centres of voxels a and b: voxels a .. b touch the box,
  // a+1 .. b-1 touch no face; the rays along the faces are decided by the
  // perturbation and must not leak into the count.
  const int lo[3] = {n / 4, n / 8 + 1, 3 * n / 16}, hi[3] = {3 * n / 4, 5 * n / 8 + 1, 13 * n / 16 - 1};
  uint64_t touching = 1, interior = 1;
  for (int a = 0; a < 3; ++a) {
    touching *= uint64_t(hi[a] - lo[a] + 1);
    interior *= uint64_t(hi[a] - lo[a] - 1);
  }
  EXPECT_EQ(ref.surfaceCount, touching - interior);
  EXPECT_EQ(ref.insideCount, interior);
  EXPECT_EQ(ref.axisDisagreements, 0u) << ref.firstDisagreement;
}

TEST(ReferenceSelfCheck, SphereVolumeIsPlausible) {
  const int n = 128;
  const Shape shape = sphereShape();
  const PreparedMesh mesh = prepareMesh(shape.mesh, shape.config(n, 16, 8, false));
  const ReferenceVoxels ref = referenceVoxelize(mesh, false);
  EXPECT_EQ(ref.axisDisagreements, 0u) << ref.firstDisagreement;
  // Inside + surface brackets the polyhedron's volume (in voxels).
  const double s = mesh.grid.voxelSize;
  const double volume = signedVolume(shape.mesh) / (s * s * s);
  EXPECT_LT(double(ref.insideCount), volume);
  EXPECT_GT(double(ref.insideCount + ref.surfaceCount), volume);
  EXPECT_GT(double(ref.insideCount), 0.9 * volume);
}

TEST(ReferenceSelfCheck, TieRulesOfThePerturbation) {
  // See openTiePlatesShape: every ray of Q0..Q2 passes exactly through a
  // plate edge or corner that the (eps, eps^2) rule counts, Q3's through a
  // corner it does not count.
  for (int n : {32, 64}) {
    const Shape shape = openTiePlatesShape(n);
    const PreparedMesh mesh = prepareMesh(shape.mesh, shape.config(n, 4, 8, false));
    ASSERT_FALSE(mesh.closed);
    const ReferenceVoxels ref = referenceVoxelize(mesh, false);
    for (int q = 0; q < 4; ++q) {
      const int i = n / 2 - 9 + 6 * q;
      const bool counted = q < 3;
      EXPECT_EQ(int(ref.parity[ref.index(i, i, i)]), counted ? 7 : 0) << "N=" << n << " Q" << q;
      EXPECT_EQ(ref.at(i, i, i), counted ? VoxelState::Inside : VoxelState::Outside) << "N=" << n << " Q" << q;
    }
  }
}

TEST(ReferenceSelfCheck, OpenMeshUsesMajorityVote) {
  // The single triangle spans the grid diagonally: some outside voxels see one
  // or two crossings ahead of them, so the three parities do disagree and the
  // majority decides. Check that against the stored parities.
  const int n = 32;
  const Shape shape = singleTriangleShape();
  const PreparedMesh mesh = prepareMesh(shape.mesh, shape.config(n, 4, 8, false));
  ASSERT_FALSE(mesh.closed);
  const ReferenceVoxels ref = referenceVoxelize(mesh, false);
  EXPECT_GT(ref.axisDisagreements, 0u) << "the open case would not exercise the vote";
  uint64_t inside = 0;
  for (size_t i = 0; i < ref.state.size(); ++i) {
    if (ref.state[i] == uint8_t(VoxelState::Surface)) continue;
    const int votes = (ref.parity[i] & 1) + ((ref.parity[i] >> 1) & 1) + ((ref.parity[i] >> 2) & 1);
    EXPECT_EQ(ref.state[i] == uint8_t(VoxelState::Inside), votes >= 2) << "voxel #" << i;
    inside += votes >= 2;
  }
  EXPECT_EQ(inside, ref.insideCount);
  EXPECT_GT(inside, 0u);
}

// ---- the comparison itself must be able to fail -------------------------------------------

struct Built {
  PreparedMesh mesh;
  ReferenceVoxels ref;
  Volume volume;
};

Built buildFor(const Shape& shape, int n, int r, int l) {
  Built b;
  b.mesh = prepareMesh(shape.mesh, shape.config(n, r, l, false));
  b.ref = referenceVoxelize(b.mesh, false);
  BuildOptions options;
  options.backend = Backend::Cpu;
  b.volume = buildCpu(b.mesh, options);
  return b;
}

// The comparison of a corrupted copy fails and its message contains `needle`.
void expectCaught(const Built& b, const std::function<void(Volume&)>& corrupt, const std::string& needle) {
  Volume v = b.volume;
  corrupt(v);
  const ::testing::AssertionResult r = volumeMatchesReference(v, walkVolume(v), b.ref);
  EXPECT_FALSE(r) << "corruption not detected (expected a message with \"" << needle << "\")";
  EXPECT_NE(std::string(r.message()).find(needle), std::string::npos) << r.message();
}

uint64_t firstElement(const Volume& v, ElementState s, uint64_t from = 0) {
  for (uint64_t i = from; i < v.elements.size(); ++i)
    if (elementState(v.elements[i]) == s) return i;
  ADD_FAILURE() << "no " << stateName(s) << " element";
  return 0;
}

TEST(ComparisonCanFail, CorruptedVolumesAreCaught) {
  const Built b = buildFor(sphereShape(), 64, 4, 8); // height 1
  ASSERT_TRUE(volumeMatchesReference(b.volume, walkVolume(b.volume), b.ref));
  const int L = 8;
  // A leaf voxel turned from Surface to Outside.
  expectCaught(b, [&](Volume& v) {
    const uint64_t e = firstElement(v, ElementState::Boundary);
    uint32_t* w = v.leafWords.data() + uint64_t(elementPayload(v.elements[e])) * leafWordCount(L);
    for (int i = 0; i < int(leafWordCount(L)); ++i)
      if (w[i] & 0xAAAAAAAAu) {
        const int bit = __builtin_ctz(w[i] & 0xAAAAAAAAu);
        w[i] &= ~(1u << bit);
        return;
      }
  }, "expected Surface, got Outside");
  // A Full element made Empty.
  expectCaught(b, [&](Volume& v) { v.elements[firstElement(v, ElementState::Full)] = makeElement(ElementState::Empty, 0); },
               "expected Full");
  // Two leaves swapped: same voxels, but not the canonical order any more.
  expectCaught(b, [&](Volume& v) {
    const uint64_t a = firstElement(v, ElementState::Boundary), c = firstElement(v, ElementState::Boundary, a + 1);
    std::swap(v.elements[a], v.elements[c]);
  }, "canonical order");
  // A leaf grid dropped: its element made Empty.
  expectCaught(b, [&](Volume& v) { v.elements[firstElement(v, ElementState::Boundary)] = makeElement(ElementState::Empty, 0); },
               "used by no element");
  // The invalid 2-bit value.
  expectCaught(b, [&](Volume& v) { v.leafWords[0] |= 3u; }, "invalid 2-bit value 3");
  // levelStart off by one.
  expectCaught(b, [&](Volume& v) { v.levelStart[1] += 1; }, "levelStart[1]");
  // A branch pointing at the wrong child block.
  expectCaught(b, [&](Volume& v) {
    const uint64_t e = firstElement(v, ElementState::Branch);
    v.elements[e] = makeElement(ElementState::Branch, elementPayload(v.elements[e]) + 8);
  }, "canonical breadth-first order");
}

TEST(ComparisonCanFail, OpenMeshUniformElementsAreChecked) {
  // Open rule: a uniform element must carry its lowest-corner voxel's state.
  const Built b = buildFor(openHemisphereShape(), 64, 4, 8);
  ASSERT_FALSE(b.mesh.closed);
  ASSERT_TRUE(volumeMatchesReference(b.volume, walkVolume(b.volume), b.ref));
  bool flipped = false;
  expectCaught(b, [&](Volume& v) {
    for (uint64_t i = 0; i < v.elements.size() && !flipped; ++i) {
      const ElementState s = elementState(v.elements[i]);
      if (s == ElementState::Full || s == ElementState::Empty) {
        v.elements[i] = makeElement(s == ElementState::Full ? ElementState::Empty : ElementState::Full, 0);
        flipped = true;
      }
    }
  }, "lowest-corner voxel");
  EXPECT_TRUE(flipped);
}

} // namespace
} // namespace test
} // namespace hdt
