// Data transfer (issue 17, hdt/transfer.hpp) against a brute-force reference:
// every triangle tested against every voxel of its voxel box with the build's
// predicate, the nearest one to each surface voxel's centre found with a
// closest-point routine written here independently (plane projection, else
// the nearest of the three edges), and values compared tightly (float32
// rounding of the exact value, not a voxel-size tolerance).
#include "hdt/builder.hpp"
#include "hdt/geometry.hpp"
#include "hdt/hdt_file.hpp"
#include "hdt/labels.hpp"
#include "hdt/mesh.hpp"
#include "hdt/mesh_io.hpp"
#include "hdt/transfer.hpp"
#include "hdt/error.hpp"
#include "support/mesh_files.hpp"
#include "support/shapes.hpp"

#include <gtest/gtest.h>
#include <tbb/task_arena.h>

#include <cfloat>
#include <cstring>
#include <cmath>
#include <filesystem>
#include <limits>

namespace hdt {
namespace test {
namespace {

BuildOptions cpu(int threads = 0) {
  BuildOptions o;
  o.backend = Backend::Cpu;
  o.threads = threads;
  return o;
}

BuildConfig config(int n, int rootGrid = 2, int leafSize = 8) {
  BuildConfig c;
  c.resolution = n;
  c.rootGrid = rootGrid;
  c.leafSize = leafSize;
  return c;
}

// ---- the independent reference --------------------------------------------------

Vec3 minus(const Vec3& a, const Vec3& b) { return {a[0] - b[0], a[1] - b[1], a[2] - b[2]}; }
double dot3(const Vec3& a, const Vec3& b) { return a[0] * b[0] + a[1] * b[1] + a[2] * b[2]; }
Vec3 cross(const Vec3& a, const Vec3& b) {
  return {a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0]};
}

// Closest point of segment [a, b] to p.
Vec3 closestOnSegment(const Vec3& p, const Vec3& a, const Vec3& b) {
  const Vec3 ab = minus(b, a);
  const double t = std::clamp(dot3(minus(p, a), ab) / dot3(ab, ab), 0.0, 1.0);
  return {a[0] + t * ab[0], a[1] + t * ab[1], a[2] + t * ab[2]};
}

// Closest point of triangle (a, b, c) to p: the projection onto the plane
// when it falls inside (same-side tests with the normal), else the nearest
// point of the three edges.
Vec3 referenceClosestPoint(const Vec3& p, const Vec3& a, const Vec3& b, const Vec3& c) {
  const Vec3 n = cross(minus(b, a), minus(c, a));
  const double t = dot3(minus(p, a), n) / dot3(n, n);
  const Vec3 q = {p[0] - t * n[0], p[1] - t * n[1], p[2] - t * n[2]};
  if (dot3(cross(minus(b, a), minus(q, a)), n) >= 0 && dot3(cross(minus(c, b), minus(q, b)), n) >= 0 &&
      dot3(cross(minus(a, c), minus(q, c)), n) >= 0)
    return q;
  Vec3 best = closestOnSegment(p, a, b);
  for (const Vec3& e : {closestOnSegment(p, b, c), closestOnSegment(p, c, a)})
    if (dot3(minus(p, e), minus(p, e)) < dot3(minus(p, best), minus(p, best))) best = e;
  return best;
}

Vec3 corner(const TriangleMesh& m, size_t t, int j) {
  const double* p = &m.points[3 * size_t(m.triangles[3 * t + size_t(j)])];
  return {p[0], p[1], p[2]};
}

Vec3 centreOf(const GridSpec& g, int x, int y, int z) {
  return {g.origin[0] + (x + 0.5) * g.voxelSize, g.origin[1] + (y + 0.5) * g.voxelSize,
          g.origin[2] + (z + 0.5) * g.voxelSize};
}

double distance2(const TriangleMesh& m, size_t t, const Vec3& p) {
  const Vec3 q = referenceClosestPoint(p, corner(m, t, 0), corner(m, t, 1), corner(m, t, 2));
  return dot3(minus(p, q), minus(p, q));
}

// The squared distance as the library computes it, for the tie rule only.
double libraryDistance2(const TriangleMesh& m, size_t t, const Vec3& p) {
  const Vec3 a = corner(m, t, 0), b = corner(m, t, 1), c = corner(m, t, 2);
  const std::array<double, 3> w = closestPointWeights(p.data(), a.data(), b.data(), c.data());
  double d2 = 0;
  for (size_t k = 0; k < 3; ++k) {
    const double q = w[0] * a[k] + w[1] * b[k] + w[2] * c[k];
    d2 += (p[k] - q) * (p[k] - q);
  }
  return d2;
}

// Per voxel (dense, x fastest): the triangles that touch it (build predicate,
// label filter), the smallest reference distance among them.
struct Reference {
  int n = 0;
  std::vector<double> best;
  std::vector<std::vector<uint32_t>> candidates;
  size_t at(int x, int y, int z) const { return size_t(x) + size_t(n) * (size_t(y) + size_t(n) * size_t(z)); }
};

Reference reference(const TriangleMesh& m, const Volume& v) {
  const GridSpec& g = v.grid;
  Reference r;
  r.n = g.resolution;
  const size_t n3 = size_t(r.n) * r.n * r.n;
  r.best.assign(n3, std::numeric_limits<double>::infinity());
  r.candidates.resize(n3);
  for (size_t t = 0; t < m.triangleCount(); ++t) {
    LatticeTriangle lt;
    for (int j = 0; j < 3; ++j)
      for (int a = 0; a < 3; ++a)
        lt.v[j][a] = int32_t(std::llround((corner(m, t, j)[size_t(a)] - g.origin[size_t(a)]) * 256.0 / g.voxelSize));
    if (isDegenerate(lt)) continue;
    int lo[3], hi[3];
    for (int a = 0; a < 3; ++a) {
      const int32_t mn = std::min({lt.v[0][a], lt.v[1][a], lt.v[2][a]}), mx = std::max({lt.v[0][a], lt.v[1][a], lt.v[2][a]});
      lo[a] = std::max(0, int(std::floor(mn / 256.0)) - 1);
      hi[a] = std::min(r.n - 1, int(mx / 256) + 1);
    }
    for (int z = lo[2]; z <= hi[2]; ++z)
      for (int y = lo[1]; y <= hi[1]; ++y)
        for (int x = lo[0]; x <= hi[0]; ++x) {
          if (!triangleOverlapsCube(lt, 256 * int64_t(x), 256 * int64_t(y), 256 * int64_t(z), 256)) continue;
          if (voxelAt(v, x, y, z) != VoxelState::Surface) continue;
          if (!v.labels.empty() && labelAt(v, x, y, z) != m.triangleLabels[t]) continue;
          r.candidates[r.at(x, y, z)].push_back(uint32_t(t));
          r.best[r.at(x, y, z)] = std::min(r.best[r.at(x, y, z)], distance2(m, t, centreOf(g, x, y, z)));
        }
  }
  return r;
}

// Appends the arrays every check below reads: the triangle index (cell) and
// the point coordinates x and (x, y, z) (point).
std::vector<MeshArray> probeArrays(const TriangleMesh& m) {
  MeshArray index{"TriangleIndex", ArraySource::Cell, 1, {}};
  for (size_t t = 0; t < m.triangleCount(); ++t) index.values.push_back(double(t));
  MeshArray x{"X", ArraySource::Point, 1, {}}, xyz{"XYZ", ArraySource::Point, 3, m.points};
  for (size_t p = 0; p < m.pointCount(); ++p) x.values.push_back(m.points[3 * p]);
  return {index, x, xyz};
}

// Checks every voxel of v (arrays from probeArrays, first at `first`):
// surface voxels carry the nearest touching triangle (up to an exact tie) and
// f = x, (x, y, z) at its closest point; other voxels NaN.
void expectMatchesReference(const TriangleMesh& m, const Volume& v, size_t first = 0) {
  const Reference r = reference(m, v);
  const GridSpec& g = v.grid;
  size_t surface = 0, failures = 0;
  for (int z = 0; z < r.n; ++z)
    for (int y = 0; y < r.n; ++y)
      for (int x = 0; x < r.n; ++x) {
        const float index = voxelArrayValue(v, first, 0, x, y, z);
        if (voxelAt(v, x, y, z) != VoxelState::Surface) {
          if (!std::isnan(index) && ++failures < 10) ADD_FAILURE() << "not surface, not NaN at " << x << " " << y << " " << z;
          continue;
        }
        ++surface;
        const std::vector<uint32_t>& cand = r.candidates[r.at(x, y, z)];
        ASSERT_FALSE(cand.empty()) << "reference: no triangle touches surface voxel " << x << " " << y << " " << z;
        const uint32_t t = uint32_t(index);
        const Vec3 p = centreOf(g, x, y, z);
        const bool touches = std::find(cand.begin(), cand.end(), t) != cand.end();
        const double d = touches ? distance2(m, t, p) : HUGE_VAL;
        const double best = r.best[r.at(x, y, z)];
        if ((!touches || d > best + 1e-12 * (best + g.voxelSize * g.voxelSize)) && ++failures < 10)
          ADD_FAILURE() << "voxel " << x << " " << y << " " << z << ": triangle " << t << " at d2 " << d
                        << ", nearest touching at " << best;
        // Among exact ties the lowest index wins. Ties are the library's own
        // metric's (closestPointWeights): another method's rounding differs.
        for (uint32_t c : cand)
          if (c < t && libraryDistance2(m, c, p) == libraryDistance2(m, t, p) && ++failures < 10)
            ADD_FAILURE() << "voxel " << x << " " << y << " " << z << ": triangle " << t << " ties with lower " << c;
        const Vec3 q = referenceClosestPoint(p, corner(m, t, 0), corner(m, t, 1), corner(m, t, 2));
        for (uint32_t c = 0; c < 3; ++c) {
          const float got = voxelArrayValue(v, first + 2, c, x, y, z);
          const double want = q[c];
          // float32 rounding of a double within 1e-12 of the exact value.
          const double tol = FLT_EPSILON * std::abs(want) + 1e-12 * g.voxelSize * g.resolution;
          if (!(std::abs(double(got) - want) <= tol) && ++failures < 10)
            ADD_FAILURE() << "XYZ[" << c << "] at " << x << " " << y << " " << z << ": " << got << " vs " << want;
        }
        EXPECT_EQ(voxelArrayValue(v, first + 1, 0, x, y, z), voxelArrayValue(v, first + 2, 0, x, y, z));
      }
  EXPECT_EQ(failures, 0u);
  EXPECT_EQ(surface, v.stats.activeVoxels);
  EXPECT_EQ(v.arrays[first].values.size(), v.stats.activeVoxels);
  EXPECT_EQ(v.arrays[first + 2].values.size(), 3 * v.stats.activeVoxels);
}

Volume transferred(const TriangleMesh& m, const BuildConfig& c, int threads = 0) {
  Volume v = voxelize(m, c, cpu());
  tbb::task_arena arena(threads > 0 ? threads : tbb::task_arena::automatic);
  arena.execute([&] { transferArrays(m, probeArrays(m), v); });
  return v;
}

TEST(Transfer, ClosestPointWeightsOfEachRegion) {
  const double a[3] = {0, 0, 0}, b[3] = {2, 0, 0}, c[3] = {0, 2, 0};
  for (const Vec3& p : std::vector<Vec3>{{0.5, 0.5, 1}, {-1, -1, 0}, {3, -1, 0}, {-1, 3, 2}, {1, -1, 0}, {-1, 1, 0}, {2, 2, 0}}) {
    const std::array<double, 3> w = closestPointWeights(p.data(), a, b, c);
    const Vec3 q = referenceClosestPoint(p, {0, 0, 0}, {2, 0, 0}, {0, 2, 0});
    EXPECT_NEAR(w[1] * 2, q[0], 1e-15);
    EXPECT_NEAR(w[2] * 2, q[1], 1e-15);
    EXPECT_NEAR(w[0] + w[1] + w[2], 1.0, 1e-15);
  }
}

TEST(Transfer, PointRampAndTriangleIndexOnShapes) {
  for (const TriangleMesh& m : {icosphere(2, 10.0), torus(10, 3.5, 24, 10, {0.3, -0.2, 0.1})}) {
    const Volume v = transferred(m, config(64));
    expectMatchesReference(m, v);
  }
}

TEST(Transfer, SurfaceOnlyAndLeafSizes) {
  const TriangleMesh m = torus(10, 3.5, 20, 9);
  BuildConfig c = config(64, 4, 16);
  c.surfaceOnly = true;
  expectMatchesReference(m, transferred(m, c));
  expectMatchesReference(m, transferred(m, config(64, 1, 32)));
}

TEST(Transfer, InsideVoxelsHaveNoValue) {
  const TriangleMesh m = icosphere(2, 10.0);
  const Volume v = transferred(m, config(32));
  const GridSpec& g = v.grid;
  ASSERT_EQ(voxelAt(v, g.resolution / 2, g.resolution / 2, g.resolution / 2), VoxelState::Inside);
  EXPECT_TRUE(std::isnan(voxelArrayValue(v, 1, 0, g.resolution / 2, g.resolution / 2, g.resolution / 2)));
  EXPECT_TRUE(std::isnan(voxelArrayValue(v, 1, 0, 0, 0, 0)));
}

// Two touching labelled cubes: a shared-face voxel gets the label the policy
// picks, and its cell value comes from a triangle of that part.
TEST(Transfer, LabelledCubesTakeTheirPartsTriangles) {
  TriangleMesh m = box({-12, -8, -8}, {0, 8, 8});
  append(m, box({0, -8, -8}, {12, 8, 8}));
  m.triangleLabels.assign(12, 1);
  m.triangleLabels.resize(24, 2);
  for (OverlapPolicy policy : {OverlapPolicy::Lowest, OverlapPolicy::Highest}) {
    LabelOptions lo;
    lo.overlap = policy;
    Volume v = voxelizeLabelled(m, config(32), cpu(), lo);
    MeshArray part{"Part", ArraySource::Cell, 1, {}};
    for (Label l : m.triangleLabels) part.values.push_back(10.0 * l);
    std::vector<MeshArray> arrays = probeArrays(m);
    arrays.push_back(part);
    transferArrays(m, arrays, v);
    expectMatchesReference(m, v);
    size_t shared = 0;
    const int n = v.grid.resolution;
    for (int z = 0; z < n; ++z)
      for (int y = 0; y < n; ++y)
        for (int x = 0; x < n; ++x) {
          if (voxelAt(v, x, y, z) != VoxelState::Surface) continue;
          EXPECT_EQ(voxelArrayValue(v, 3, 0, x, y, z), 10.0f * labelAt(v, x, y, z));
          shared += std::abs(centreOf(v.grid, x, y, z)[0]) < v.grid.voxelSize;
        }
    EXPECT_GT(shared, 0u);
  }
}

TEST(Transfer, SameValuesWhateverTheThreadCount) {
  const TriangleMesh m = torus(10, 3.5, 24, 10);
  const Volume one = transferred(m, config(64), 1);
  for (int threads : {2, 5}) {
    const Volume other = transferred(m, config(64), threads);
    ASSERT_EQ(other.arrays.size(), one.arrays.size());
    for (size_t k = 0; k < one.arrays.size(); ++k) {
      ASSERT_EQ(other.arrays[k].values.size(), one.arrays[k].values.size());
      EXPECT_EQ(std::memcmp(other.arrays[k].values.data(), one.arrays[k].values.data(),
                            one.arrays[k].values.size() * sizeof(float)), 0);
    }
  }
}

TEST(Transfer, RoundTripThroughTheFile) {
  const TriangleMesh m = icosphere(2, 10.0);
  const Volume v = transferred(m, config(32));
  for (bool compress : {false, true}) {
    HdtWriteOptions o;
    o.compressLeaves = compress;
    const std::vector<uint8_t> bytes = serializeHdt(v, o);
    const Volume back = deserializeHdt(bytes.data(), bytes.size(), "memory");
    ASSERT_EQ(back.arrays.size(), v.arrays.size());
    for (size_t k = 0; k < v.arrays.size(); ++k) {
      EXPECT_EQ(back.arrays[k].name, v.arrays[k].name);
      EXPECT_EQ(back.arrays[k].source, v.arrays[k].source);
      EXPECT_EQ(back.arrays[k].components, v.arrays[k].components);
      EXPECT_EQ(back.arrays[k].values, v.arrays[k].values);
    }
    EXPECT_EQ(serializeHdt(back, o), bytes);
  }
}

TEST(Transfer, BadArraysAreRefused) {
  const TriangleMesh m = icosphere(1, 10.0);
  Volume v = voxelize(m, config(32), cpu());
  auto refused = [&](const MeshArray& a) {
    EXPECT_THROW(transferArrays(m, {a}, v), Error) << a.name;
  };
  refused({"short", ArraySource::Point, 1, std::vector<double>(m.pointCount() - 1)});
  refused({"cells", ArraySource::Cell, 2, std::vector<double>(m.triangleCount())});
  refused({"", ArraySource::Cell, 1, std::vector<double>(m.triangleCount())});
  refused({"wide", ArraySource::Point, 65, std::vector<double>(65 * m.pointCount())});
  const MeshArray ok{"ok", ArraySource::Cell, 1, std::vector<double>(m.triangleCount(), 1.0)};
  EXPECT_THROW(transferArrays(m, {ok, ok}, v), Error);
  EXPECT_TRUE(v.arrays.empty()) << "a refused transfer leaves the volume alone";
  // Another mesh than the volume's: its triangles miss surface voxels.
  EXPECT_THROW(transferArrays(icosphere(1, 5.0), {MeshArray{"x", ArraySource::Cell, 1, std::vector<double>(80)}}, v), Error);
  transferArrays(m, {ok}, v);
  EXPECT_THROW(transferArrays(m, {ok}, v), Error) << "a name the volume already has";
  Volume broken = v;
  broken.arrays[0].values.pop_back();
  EXPECT_THROW(serializeHdt(broken), Error);
}

TEST(Transfer, PlyPropertiesBecomeArrays) {
  const std::string path = ::testing::TempDir() + "/transfer_props.ply";
  {
    std::FILE* f = std::fopen(path.c_str(), "w");
    ASSERT_TRUE(f);
    std::fputs("ply\nformat ascii 1.0\nelement vertex 4\nproperty float x\nproperty float y\nproperty float z\n"
               "property double t\nelement face 2\nproperty list uchar int vertex_indices\nproperty short side\n"
               "end_header\n0 0 0 0.5\n1 0 0 1.5\n1 1 0 2.5\n0 1 1 3.5\n4 0 1 2 3 7\n3 0 1 3 -2\n",
               f);
    std::fclose(f);
  }
  std::vector<MeshArray> arrays = {{"side", ArraySource::Point, 0, {}}, {"t", ArraySource::Cell, 0, {}}};
  const TriangleMesh m = readMesh(path, {}, arrays);
  ASSERT_EQ(m.triangleCount(), 3u);
  EXPECT_EQ(arrays[0].source, ArraySource::Cell); // found on the faces: one value per triangle of the face
  EXPECT_EQ(arrays[0].values, (std::vector<double>{7, 7, -2}));
  EXPECT_EQ(arrays[1].source, ArraySource::Point);
  EXPECT_EQ(arrays[1].values, (std::vector<double>{0.5, 1.5, 2.5, 3.5}));
  std::vector<MeshArray> missing = {{"nothere", ArraySource::Point, 0, {}}};
  EXPECT_THROW(readMesh(path, {}, missing), Error);
}

// A cell array on a real scan (the triangle index): skips without the shared meshes.
TEST(Transfer, OgreTriangleIndexMatchesReference) {
  std::string why;
  const std::string path = sharedMeshPath("ogre.obj", &why);
  if (path.empty()) GTEST_SKIP() << why;
  const TriangleMesh m = readMesh(path);
  const Volume v = transferred(m, config(64));
  expectMatchesReference(m, v);
}

} // namespace
} // namespace test
} // namespace hdt
