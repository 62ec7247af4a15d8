// What the library refuses, with which ErrorKind, and whether the message
// tells the user what is wrong. Every case goes through the public entry
// points (hdt::prepareMesh and hdt::voxelize).
#include "hdt/builder.hpp"
#include "hdt/config.hpp"
#include "hdt/error.hpp"
#include "hdt/mesh.hpp"
#include "support/shapes.hpp"

#include <gtest/gtest.h>

#include <sys/resource.h>

#include <algorithm>
#include <cctype>
#include <chrono>
#include <cmath>
#include <fstream>
#include <functional>
#include <limits>
#include <string>
#include <vector>

namespace hdt {
namespace test {
namespace {

const char* kindName(ErrorKind k) {
  switch (k) {
  case ErrorKind::InvalidArgument: return "InvalidArgument";
  case ErrorKind::BadInput: return "BadInput";
  case ErrorKind::OutOfResources: return "OutOfResources";
  case ErrorKind::Aborted: return "Aborted";
  case ErrorKind::OutputFailed: return "OutputFailed";
  }
  return "?";
}

std::string lower(std::string s) {
  std::transform(s.begin(), s.end(), s.begin(), [](unsigned char c) { return char(std::tolower(c)); });
  return s;
}

// Runs `f`, which must throw hdt::Error of `kind` whose message contains every
// key word (case-insensitive).
::testing::AssertionResult throwsError(const std::function<void()>& f, ErrorKind kind,
                                       const std::vector<std::string>& keywords) {
  try {
    f();
  } catch (const Error& e) {
    if (e.kind() != kind)
      return ::testing::AssertionFailure() << "threw " << kindName(e.kind()) << " instead of " << kindName(kind)
                                           << ": \"" << e.what() << "\"";
    const std::string msg = lower(e.what());
    for (const std::string& k : keywords)
      if (msg.find(lower(k)) == std::string::npos)
        return ::testing::AssertionFailure() << "message \"" << e.what() << "\" does not mention \"" << k << "\"";
    return ::testing::AssertionSuccess() << e.what();
  } catch (const std::exception& e) {
    return ::testing::AssertionFailure() << "threw a non-hdt exception: " << e.what();
  }
  return ::testing::AssertionFailure() << "did not throw";
}

BuildConfig smallConfig() {
  BuildConfig c;
  c.resolution = 32;
  c.rootGrid = 4;
  c.leafSize = 8;
  return c;
}

BuildOptions cpuOptions() {
  BuildOptions o;
  o.backend = Backend::Cpu;
  return o;
}

// Both entry points must refuse the mesh the same way.
void expectMeshRefused(const TriangleMesh& mesh, ErrorKind kind, const std::vector<std::string>& keywords) {
  EXPECT_TRUE(throwsError([&] { prepareMesh(mesh, smallConfig()); }, kind, keywords)) << "prepareMesh";
  EXPECT_TRUE(throwsError([&] { voxelize(mesh, smallConfig(), cpuOptions()); }, kind, keywords)) << "voxelize";
}

TriangleMesh tetrahedron() {
  TriangleMesh m;
  m.points = {0, 0, 0, 1, 0, 0, 0, 1, 0, 0, 0, 1};
  m.triangles = {0, 2, 1, 0, 1, 3, 0, 3, 2, 1, 2, 3};
  return m;
}

// ---- the mesh -------------------------------------------------------------------------

TEST(BadInput, ValidTetrahedronIsAccepted) {
  // The baseline every case below breaks in one way.
  const PreparedMesh p = prepareMesh(tetrahedron(), smallConfig());
  EXPECT_EQ(p.triangles.size(), 4u);
  EXPECT_TRUE(p.closed);
  EXPECT_NO_THROW(voxelize(tetrahedron(), smallConfig(), cpuOptions()));
}

TEST(BadInput, EmptyMesh) {
  expectMeshRefused(TriangleMesh{}, ErrorKind::BadInput, {"no triangles"});
  TriangleMesh pointsOnly = tetrahedron();
  pointsOnly.triangles.clear();
  expectMeshRefused(pointsOnly, ErrorKind::BadInput, {"no triangles"});
}

TEST(BadInput, ArraysNotMultiplesOfThree) {
  TriangleMesh m = tetrahedron();
  m.triangles.push_back(0);
  expectMeshRefused(m, ErrorKind::BadInput, {"multiple of 3"});
  m = tetrahedron();
  m.points.push_back(0.5);
  expectMeshRefused(m, ErrorKind::BadInput, {"multiple of 3"});
}

TEST(BadInput, NaNCoordinate) {
  TriangleMesh m = tetrahedron();
  m.points[3 * 2 + 1] = std::numeric_limits<double>::quiet_NaN();
  expectMeshRefused(m, ErrorKind::BadInput, {"non-finite", "point 2"});
}

TEST(BadInput, InfiniteCoordinates) {
  TriangleMesh m = tetrahedron();
  m.points[3 * 3 + 2] = std::numeric_limits<double>::infinity();
  expectMeshRefused(m, ErrorKind::BadInput, {"non-finite", "point 3"});
  m = tetrahedron();
  m.points[0] = -std::numeric_limits<double>::infinity();
  expectMeshRefused(m, ErrorKind::BadInput, {"non-finite", "point 0"});
}

TEST(BadInput, UnreferencedNaNPointIsHarmless) {
  // Only points used by triangles matter (readers keep unused vertices).
  TriangleMesh m = tetrahedron();
  m.points.insert(m.points.end(), {std::nan(""), 0.0, 0.0});
  EXPECT_NO_THROW(prepareMesh(m, smallConfig()));
}

TEST(BadInput, IndexOutOfRange) {
  TriangleMesh m = tetrahedron();
  m.triangles[3 * 2 + 1] = 4; // 4 points: 0..3
  expectMeshRefused(m, ErrorKind::BadInput, {"triangle 2", "point 4"});
  m.triangles[3 * 2 + 1] = 0xFFFFFFFFu;
  expectMeshRefused(m, ErrorKind::BadInput, {"triangle 2", "4294967295"});
}

TEST(BadInput, ZeroExtent) {
  TriangleMesh m = tetrahedron();
  for (size_t i = 0; i < m.points.size(); ++i) m.points[i] = 1.5; // all four points coincide
  expectMeshRefused(m, ErrorKind::BadInput, {"zero extent"});
}

TEST(BadInput, AllTrianglesDegenerate) {
  TriangleMesh m;
  m.points = {0, 0, 0, 1, 1, 1, 2, 2, 2, 3, 0, 0};
  m.triangles = {0, 1, 2,  // collinear
                 3, 3, 0,  // repeated index
                 1, 0, 2}; // collinear
  expectMeshRefused(m, ErrorKind::BadInput, {"degenerate", "3"});
}

TEST(BadInput, AllTrianglesDegenerateAfterSnapping) {
  // A sliver 1e-6 voxel high next to a long edge: non-zero area in doubles,
  // zero on the 1/256-voxel lattice.
  TriangleMesh m;
  m.points = {0, 0, 0, 10, 0, 0, 5, 1e-6, 0};
  m.triangles = {0, 1, 2};
  EXPECT_TRUE(throwsError([&] { prepareMesh(m, smallConfig()); }, ErrorKind::BadInput, {"degenerate"}));
}

TEST(BadInput, ExplicitBoundsMustContainTheMesh) {
  BuildConfig c = smallConfig();
  c.hasBounds = true;
  c.boundsMin = {0, 0, 0};
  c.boundsMax = {1, 1, 0.5}; // the tetrahedron reaches z = 1
  EXPECT_TRUE(throwsError([&] { prepareMesh(tetrahedron(), c); }, ErrorKind::InvalidArgument, {"bounds"}));
}

// ---- the configuration ----------------------------------------------------------------

struct ResolutionCase {
  int n, r, l;
  std::vector<std::string> mention; // the offending value and the nearest valid ones
};

void PrintTo(const ResolutionCase& c, std::ostream* os) {
  *os << "N=" << c.n << " R=" << c.r << " L=" << c.l;
}

class BadResolution : public ::testing::TestWithParam<ResolutionCase> {};

TEST_P(BadResolution, RefusedNamingTheNearestValidValues) {
  const ResolutionCase& c = GetParam();
  BuildConfig config;
  config.resolution = c.n;
  config.rootGrid = c.r;
  config.leafSize = c.l;
  EXPECT_TRUE(throwsError([&] { validateConfig(config); }, ErrorKind::InvalidArgument, c.mention));
  EXPECT_TRUE(throwsError([&] { prepareMesh(tetrahedron(), config); }, ErrorKind::InvalidArgument, c.mention));
  EXPECT_TRUE(
      throwsError([&] { voxelize(tetrahedron(), config, cpuOptions()); }, ErrorKind::InvalidArgument, c.mention));
}

INSTANTIATE_TEST_SUITE_P(
    Config, BadResolution,
    ::testing::Values(ResolutionCase{1000, 16, 16, {"1000", "512", "1024"}},  // between two valid values
                      ResolutionCase{300, 4, 8, {"300", "256", "512"}},
                      ResolutionCase{100, 3, 8, {"100", "96", "192"}},        // R need not be a power of 2
                      ResolutionCase{384, 16, 16, {"384", "256", "512"}},     // a multiple of R*L, not R*2^h*L
                      ResolutionCase{128, 16, 16, {"128", "256"}},            // below R*L
                      ResolutionCase{0, 16, 16, {"0", "256"}},
                      ResolutionCase{-512, 16, 16, {"-512", "256"}},
                      ResolutionCase{70000, 16, 16, {"70000", "65536"}},     // above the maximum
                      ResolutionCase{131072, 16, 16, {"131072", "65536"}}),
    [](const ::testing::TestParamInfo<ResolutionCase>& info) {
      const int n = info.param.n;
      return std::string(n < 0 ? "minus" : "") + std::to_string(std::abs(n)) + "_R" + std::to_string(info.param.r) +
             "_L" + std::to_string(info.param.l);
    });

TEST(BadConfig, NearestValidResolutions) {
  EXPECT_EQ(nearestValidResolutions(1000, 16, 16), (std::vector<int>{512, 1024}));
  EXPECT_EQ(nearestValidResolutions(0, 16, 16), (std::vector<int>{256}));
  EXPECT_EQ(nearestValidResolutions(100000, 16, 16), (std::vector<int>{65536}));
  EXPECT_EQ(nearestValidResolutions(100, 3, 8), (std::vector<int>{96, 192}));
}

TEST(BadConfig, LeafSize) {
  for (int l : {0, 4, 12, 64, -8}) {
    BuildConfig c = smallConfig();
    c.leafSize = l;
    c.resolution = 4 * 16; // irrelevant: the leaf size is checked first
    EXPECT_TRUE(throwsError([&] { prepareMesh(tetrahedron(), c); }, ErrorKind::InvalidArgument,
                            {"leaf", "8", "16", "32", std::to_string(l)}))
        << "L = " << l;
    EXPECT_TRUE(throwsError([&] { voxelize(tetrahedron(), c, cpuOptions()); }, ErrorKind::InvalidArgument, {"leaf"}))
        << "L = " << l;
  }
}

TEST(BadConfig, RootGrid) {
  for (int r : {0, -4}) {
    BuildConfig c = smallConfig();
    c.rootGrid = r;
    EXPECT_TRUE(throwsError([&] { prepareMesh(tetrahedron(), c); }, ErrorKind::InvalidArgument, {"root grid"}))
        << "R = " << r;
    EXPECT_TRUE(throwsError([&] { voxelize(tetrahedron(), c, cpuOptions()); }, ErrorKind::InvalidArgument,
                            {"root grid"}))
        << "R = " << r;
  }
  BuildConfig c = smallConfig(); // R * L above the maximum resolution
  c.rootGrid = 4096;
  c.leafSize = 32;
  c.resolution = 65536;
  EXPECT_TRUE(throwsError([&] { prepareMesh(tetrahedron(), c); }, ErrorKind::InvalidArgument, {"root grid"}));
}

TEST(BadConfig, ConfigurationErrorsComeBeforeMeshErrors) {
  // A bad option is the caller's fault whatever the mesh: report it first.
  BuildConfig c = smallConfig();
  c.resolution = 33;
  EXPECT_TRUE(throwsError([&] { prepareMesh(TriangleMesh{}, c); }, ErrorKind::InvalidArgument, {"33"}));
}

// ---- resources --------------------------------------------------------------------------

uint64_t memAvailableBytes() {
  std::ifstream in("/proc/meminfo");
  std::string key, unit;
  uint64_t kb = 0;
  while (in >> key >> kb >> unit)
    if (key == "MemAvailable:") return kb * 1024;
  return 0;
}

uint64_t peakRssBytes() {
  rusage u{};
  getrusage(RUSAGE_SELF, &u);
  return uint64_t(u.ru_maxrss) * 1024;
}

TEST(BadResources, HugeResolutionIsRefusedBeforeAllocating) {
  // Eight concentric spheres at 65536^3 with R = 1, L = 8: terabytes of leaf
  // grids by the surface-area estimate, more than any machine we run on has.
  TriangleMesh m;
  for (int i = 0; i < 8; ++i) append(m, icosphere(3, 1.0 - 0.05 * i));
  BuildConfig c;
  c.resolution = 65536;
  c.rootGrid = 1;
  c.leafSize = 8;
  const PreparedMesh p = prepareMesh(m, c);
  EXPECT_EQ(p.grid.height, 13);
  const uint64_t estimate = estimateHostBytes(p);
  EXPECT_GT(estimate, uint64_t(256) << 30) << "leaf states alone need more than 400 GB here";
  const uint64_t available = memAvailableBytes();
  if (available == 0 || estimate <= available)
    GTEST_SKIP() << "this machine reports " << (available >> 30) << " GiB available, the estimate is "
                 << (estimate >> 30) << " GiB: not running a build that might really allocate";

  const uint64_t rssBefore = peakRssBytes();
  const auto t0 = std::chrono::steady_clock::now();
  EXPECT_TRUE(throwsError([&] { buildCpu(p, cpuOptions()); }, ErrorKind::OutOfResources, {"65536", "memory"}));
  EXPECT_TRUE(throwsError([&] { voxelize(m, c, cpuOptions()); }, ErrorKind::OutOfResources, {"65536", "memory"}));
  const double seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  EXPECT_LT(seconds, 5.0) << "the refusal must come from the estimate, not from running out";
  EXPECT_LT(peakRssBytes() - rssBefore, uint64_t(256) << 20) << "memory was allocated before refusing";
}

TEST(BadResources, EstimateGrowsWithResolution) {
  // The estimate the refusal relies on scales like the surface area (N^2).
  const Shape s = sphereShape();
  const uint64_t e1 = estimateHostBytes(prepareMesh(s.mesh, s.config(4096, 16, 16, false)));
  const uint64_t e2 = estimateHostBytes(prepareMesh(s.mesh, s.config(8192, 16, 16, false)));
  EXPECT_GT(e2, 3 * e1);
  EXPECT_LT(e2, 5 * e1);
}

} // namespace
} // namespace test
} // namespace hdt
