// readMesh and builtinMesh: every format written here, in ASCII and binary,
// read back with the right triangles (count, coordinates, winding); broken
// files refused with BadInput naming the file; the built-in meshes closed and
// outward. An optional suite reads the shared test meshes when present.
#include "hdt/error.hpp"
#include "hdt/mesh.hpp"
#include "hdt/mesh_io.hpp"
#include "support/mesh_files.hpp"
#include "support/shapes.hpp"

#include <gtest/gtest.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <map>
#include <set>
#include <string>
#include <vector>

namespace hdt {
namespace test {
namespace {

namespace fs = std::filesystem;

// ---- the reference mesh: a tetrahedron, outward, exactly representable in float --

using Corner = std::array<double, 3>;
using Triangle = std::array<Corner, 3>;

const std::vector<Corner> kPoints = {{0, 0, 0}, {2, 0, 0}, {0, 1.5, 0}, {0.25, 0.5, -3}};
const std::vector<std::array<int, 3>> kFaces = {{0, 2, 1}, {0, 1, 3}, {1, 2, 3}, {2, 0, 3}};

// A triangle rotated so its smallest corner comes first: the same triangle with
// the same winding compares equal whatever corner a reader starts from.
Triangle canonical(Triangle t) {
  const auto first = std::min_element(t.begin(), t.end()) - t.begin();
  std::rotate(t.begin(), t.begin() + first, t.end());
  return t;
}

// The mesh as a sorted list of canonical triangles: independent of point
// sharing and of triangle order, but not of winding.
std::vector<Triangle> triangleSet(const TriangleMesh& m) {
  std::vector<Triangle> out;
  for (size_t t = 0; t < m.triangleCount(); ++t) {
    Triangle tri;
    for (int k = 0; k < 3; ++k)
      for (int a = 0; a < 3; ++a) tri[k][a] = m.points[3 * size_t(m.triangles[3 * t + k]) + a];
    out.push_back(canonical(tri));
  }
  std::sort(out.begin(), out.end());
  return out;
}

std::vector<Triangle> referenceSet() {
  TriangleMesh m;
  for (const Corner& p : kPoints) m.points.insert(m.points.end(), p.begin(), p.end());
  for (const auto& f : kFaces) m.triangles.insert(m.triangles.end(), {uint32_t(f[0]), uint32_t(f[1]), uint32_t(f[2])});
  return triangleSet(m);
}

// ---- writing test files ----------------------------------------------------------

class MeshIo : public ::testing::Test {
protected:
  void SetUp() override {
    const char* base = std::getenv("HDT_TEST_TMPDIR");
    dir_ = fs::path(base ? base : fs::temp_directory_path().string()) /
           (std::string("mesh_io_") + ::testing::UnitTest::GetInstance()->current_test_info()->name());
    fs::remove_all(dir_);
    fs::create_directories(dir_);
  }
  void TearDown() override {
    if (!HasFailure()) fs::remove_all(dir_);
  }

  std::string write(const std::string& name, const std::string& bytes) {
    const std::string path = (dir_ / name).string();
    std::ofstream(path, std::ios::binary) << bytes;
    return path;
  }

  fs::path dir_;
};

// ASCII STL and OBJ: read through assimp, when the build has it.
class MeshIoAssimp : public MeshIo {
protected:
  void SetUp() override {
    if (!readsAllMeshFormats()) GTEST_SKIP() << "this build has no assimp: ASCII STL and OBJ are not readable";
    MeshIo::SetUp();
  }
};

template <class T>
void putLe(std::string& out, T value) {
  unsigned char bytes[sizeof(T)];
  std::memcpy(bytes, &value, sizeof(T)); // the test hosts are little endian
  out.append(reinterpret_cast<const char*>(bytes), sizeof(T));
}
template <class T>
void putBe(std::string& out, T value) {
  unsigned char bytes[sizeof(T)];
  std::memcpy(bytes, &value, sizeof(T));
  std::reverse(bytes, bytes + sizeof(T));
  out.append(reinterpret_cast<const char*>(bytes), sizeof(T));
}

std::string binaryStl(const std::string& header80 = "hdt test") {
  std::string s = header80;
  s.resize(80, ' ');
  putLe<uint32_t>(s, uint32_t(kFaces.size()));
  for (const auto& f : kFaces) {
    for (int k = 0; k < 3; ++k) putLe<float>(s, 0.0f); // normal: ignored
    for (int v : f)
      for (double x : kPoints[v]) putLe<float>(s, float(x));
    putLe<uint16_t>(s, 0);
  }
  return s;
}

std::string asciiStl() {
  std::string s = "solid tetra\n";
  for (const auto& f : kFaces) {
    s += "  facet normal 0 0 0\n    outer loop\n";
    for (int v : f) {
      char line[128];
      std::snprintf(line, sizeof line, "      vertex %.9g %.9g %.9g\n", kPoints[v][0], kPoints[v][1], kPoints[v][2]);
      s += line;
    }
    s += "    endloop\n  endfacet\n";
  }
  return s + "endsolid tetra\n";
}

std::string obj() {
  std::string s = "# tetrahedron\nmtllib missing.mtl\ng body\nusemtl none\n";
  for (const Corner& p : kPoints) s += "v " + std::to_string(p[0]) + " " + std::to_string(p[1]) + " " + std::to_string(p[2]) + "\n";
  s += "vt 0 0\nvn 0 0 1\n";
  // Mixed face syntaxes: plain, v/vt, v/vt/vn, v//vn and negative (relative) indices.
  s += "f 1 3 2\nf 1/1 2/1 4/1\nf 2/1/1 3/1/1 4/1/1\nf -2//1 -4//1 -1//1\n";
  return s;
}

std::string plyHeader(const std::string& format) {
  return "ply\nformat " + format + " 1.0\ncomment written by test_mesh_io\n"
         "element vertex 4\nproperty float x\nproperty float y\nproperty float z\n"
         "property float nx\nproperty float ny\nproperty float nz\nproperty uchar red\n"
         "element face 4\nproperty list uchar int vertex_indices\nend_header\n";
}

std::string asciiPly() {
  std::string s = plyHeader("ascii");
  for (const Corner& p : kPoints) s += std::to_string(p[0]) + " " + std::to_string(p[1]) + " " + std::to_string(p[2]) + " 0 0 1 255\n";
  for (const auto& f : kFaces) s += "3 " + std::to_string(f[0]) + " " + std::to_string(f[1]) + " " + std::to_string(f[2]) + "\n";
  return s;
}

template <bool BigEndian>
std::string binaryPly() {
  auto put = [](std::string& out, auto v) { BigEndian ? putBe(out, v) : putLe(out, v); };
  std::string s = plyHeader(BigEndian ? "binary_big_endian" : "binary_little_endian");
  for (const Corner& p : kPoints) {
    for (double x : p) put(s, float(x));
    for (float n : {0.0f, 0.0f, 1.0f}) put(s, n);
    s += char(255);
  }
  for (const auto& f : kFaces) {
    s += char(3);
    for (int v : f) put(s, int32_t(v));
  }
  return s;
}

// ---- reading what we wrote ---------------------------------------------------------

TEST_F(MeshIo, BinaryStlIsBuiltIn) {
  const TriangleMesh m = readMesh(write("tetra.stl", binaryStl()));
  ASSERT_EQ(m.triangleCount(), 4u);
  EXPECT_EQ(m.pointCount(), 12u); // STL shares nothing; the library merges by position
  EXPECT_EQ(triangleSet(m), referenceSet());
  // Order and corners exactly as in the file.
  for (size_t t = 0; t < 4; ++t)
    for (int k = 0; k < 3; ++k)
      for (int a = 0; a < 3; ++a)
        EXPECT_EQ(m.points[3 * size_t(m.triangles[3 * t + k]) + a], kPoints[kFaces[t][k]][a]);
}

TEST_F(MeshIo, BinaryStlWhoseHeaderSaysSolid) {
  // Many exporters start the binary header with "solid"; the size decides.
  const TriangleMesh m = readMesh(write("solid-header.STL", binaryStl("solid exported by a CAD tool")));
  EXPECT_EQ(triangleSet(m), referenceSet());
}

TEST_F(MeshIoAssimp, AsciiStl) {
  const TriangleMesh m = readMesh(write("tetra.stl", asciiStl()));
  EXPECT_EQ(triangleSet(m), referenceSet());
}

TEST_F(MeshIoAssimp, ObjWithMixedFaceSyntax) {
  const TriangleMesh m = readMesh(write("tetra.obj", obj()));
  EXPECT_EQ(triangleSet(m), referenceSet());
}

TEST_F(MeshIoAssimp, ObjPolygonsAreSplitIntoTriangles) {
  // A unit cube of 6 quads and a pentagon cap elsewhere: 12 + 3 triangles.
  std::string s =
      "v 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nv 0 0 1\nv 1 0 1\nv 1 1 1\nv 0 1 1\n"
      "f 1 4 3 2\nf 5 6 7 8\nf 1 2 6 5\nf 2 3 7 6\nf 3 4 8 7\nf 4 1 5 8\n"
      "v 5 0 0\nv 6 0 0\nv 6.5 1 0\nv 5.5 2 0\nv 4.5 1 0\nf 9 10 11 12 13\n";
  const TriangleMesh m = readMesh(write("polygons.obj", s));
  EXPECT_EQ(m.triangleCount(), 15u);
  TriangleMesh cube = m;
  cube.triangles.resize(12 * 3);
  EXPECT_NEAR(signedVolume(cube), 1.0, 1e-12); // winding kept
}

TEST_F(MeshIoAssimp, DegenerateTrianglesAreKept) {
  // Zero area (collinear) and a repeated corner: dropping them is prepareMesh's job.
  const std::string s = "v 0 0 0\nv 1 0 0\nv 2 0 0\nv 0 1 0\nf 1 2 3\nf 1 2 4\nf 1 1 4\n";
  EXPECT_EQ(readMesh(write("degenerate.obj", s)).triangleCount(), 3u);
}

TEST_F(MeshIo, AsciiPly) {
  EXPECT_EQ(triangleSet(readMesh(write("tetra.ply", asciiPly()))), referenceSet());
}

TEST_F(MeshIo, BinaryLittleEndianPly) {
  EXPECT_EQ(triangleSet(readMesh(write("tetra.ply", binaryPly<false>()))), referenceSet());
}

TEST_F(MeshIo, BinaryBigEndianPly) {
  EXPECT_EQ(triangleSet(readMesh(write("tetra.ply", binaryPly<true>()))), referenceSet());
}

TEST_F(MeshIo, ReadMeshFeedsPrepareMesh) {
  const TriangleMesh m = readMesh(write("tetra.stl", binaryStl()));
  BuildConfig config;
  config.resolution = 256;
  const PreparedMesh p = prepareMesh(m, config);
  EXPECT_EQ(p.triangles.size(), 4u);
  EXPECT_TRUE(p.closed); // unshared STL corners still close on the lattice
}

// ---- refusing broken input -----------------------------------------------------------

// readMesh(path) throws BadInput whose message starts with the path and contains `what`.
void expectBadInput(const std::string& path, const std::string& what) {
  try {
    readMesh(path);
    ADD_FAILURE() << path << ": no error";
  } catch (const Error& e) {
    EXPECT_EQ(e.kind(), ErrorKind::BadInput) << e.what();
    const std::string message = e.what();
    EXPECT_EQ(message.rfind(path + ": ", 0), 0u) << message;
    EXPECT_NE(message.find(what), std::string::npos) << "'" << message << "' lacks '" << what << "'";
  }
}

TEST_F(MeshIo, MissingFile) { expectBadInput((dir_ / "nothing.stl").string(), "cannot open"); }

TEST_F(MeshIo, DirectoryIsNotAMesh) {
  fs::create_directory(dir_ / "folder.stl");
  expectBadInput((dir_ / "folder.stl").string(), "not a regular file");
}

TEST_F(MeshIo, UnknownExtension) {
  expectBadInput(write("tetra.xyz", binaryStl()), "unknown extension '.xyz'");
  expectBadInput(write("tetra", binaryStl()), "no file extension");
}

TEST_F(MeshIo, EmptyFiles) {
  for (const char* name : {"empty.stl", "empty.obj", "empty.ply"}) expectBadInput(write(name, ""), "empty");
}

TEST_F(MeshIo, TruncatedBinaryStl) {
  std::string s = binaryStl();
  s.resize(s.size() - 7);
  expectBadInput(write("truncated.stl", s), "truncated or corrupt binary STL");
  expectBadInput(write("short.stl", "\x01\x02\x03"), "too short");
}

TEST_F(MeshIo, BinaryStlWithoutTriangles) {
  std::string s(80, ' ');
  putLe<uint32_t>(s, 0);
  expectBadInput(write("none.stl", s), "no triangles");
}

TEST_F(MeshIo, CorruptPly) {
  for (size_t cut : {1, 5, 12, 13, 40, 70}) { // inside the last face, the faces, the vertices
    std::string ply = binaryPly<false>();
    ply.resize(ply.size() - cut);
    expectBadInput(write("truncated.ply", ply), "truncated");
  }
  std::string ascii = asciiPly();
  ascii.resize(ascii.size() - 4);
  expectBadInput(write("truncated-ascii.ply", ascii), "truncated");
  expectBadInput(write("not.ply", "solid x\n"), "not a PLY file");
  expectBadInput(write("format.ply", "ply\nformat nonsense 1.0\nend_header\n"), "unknown PLY format 'nonsense'");
  expectBadInput(write("header.ply", "ply\nformat ascii 1.0\nelement vertex 3\n"), "end_header");
  // A count far beyond the bytes there: refused before allocating.
  std::string huge = binaryPly<false>();
  huge.replace(huge.find("element vertex 4"), 16, "element vertex 4000000000");
  expectBadInput(write("huge.ply", huge), "declares 4000000000");
  std::string noY = asciiPly();
  noY.replace(noY.find("property float y"), 16, "property float w");
  expectBadInput(write("no-y.ply", noY), "lacks x, y or z");
  std::string badIndex = asciiPly();
  badIndex.replace(badIndex.rfind("3 2 0 3"), 7, "3 2 0 9");
  expectBadInput(write("bad-index.ply", badIndex), "refers to vertex 9");
  std::string text = asciiPly();
  text.replace(text.find("0.250000"), 8, "0.25abc ");
  expectBadInput(write("not-a-number.ply", text), "not a number");
}

TEST_F(MeshIoAssimp, CorruptFilesReadByAssimp) {
  expectBadInput(write("points-only.obj", "v 0 0 0\nv 1 0 0\nv 0 1 0\n"), "no triangles");
  expectBadInput(write("lines-only.obj", "v 0 0 0\nv 1 0 0\nv 0 1 0\nl 1 2 3\n"), "");
  expectBadInput(write("bad-index.obj", "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 9\n"), "");
  expectBadInput(write("garbage.obj", std::string("\x00\x01\x02garbage\xff", 11)), "");
  std::string stl = asciiStl();
  stl.resize(stl.size() / 2);
  expectBadInput(write("truncated-ascii.stl", stl), "truncated ASCII STL");
}

// ---- built-in meshes -------------------------------------------------------------------

// Every directed edge once and its reverse once: closed, 2-manifold, consistently oriented.
void expectClosedAndOriented(const TriangleMesh& m) {
  std::map<std::pair<uint32_t, uint32_t>, int> directed;
  for (size_t t = 0; t < m.triangleCount(); ++t)
    for (int k = 0; k < 3; ++k) ++directed[{m.triangles[3 * t + k], m.triangles[3 * t + (k + 1) % 3]}];
  for (const auto& [edge, count] : directed) {
    ASSERT_EQ(count, 1) << "edge " << edge.first << "-" << edge.second << " used " << count << " times";
    ASSERT_EQ(directed.count({edge.second, edge.first}), 1u) << "edge " << edge.first << "-" << edge.second << " is a border";
  }
}

TEST(BuiltinMeshes, ClosedOutwardAndOfTheDocumentedSize) {
  const double pi = std::acos(-1.0);
  struct Expect {
    const char* name;
    size_t triangles;
    double volume, tolerance;
  };
  // Knot: a tube of radius 0.3 along the trefoil; the curve's length by quadrature.
  double length = 0;
  const int steps = 100000;
  for (int i = 0; i < steps; ++i) {
    const double u = 2 * pi * (i + 0.5) / steps, w = 1 + 0.5 * std::cos(3 * u);
    const double dx = -1.5 * std::sin(3 * u) * std::cos(2 * u) - 2 * w * std::sin(2 * u);
    const double dy = -1.5 * std::sin(3 * u) * std::sin(2 * u) + 2 * w * std::cos(2 * u);
    const double dz = 1.5 * std::cos(3 * u);
    length += std::sqrt(dx * dx + dy * dy + dz * dz) * 2 * pi / steps;
  }
  const Expect expected[] = {
      {"sphere", 20480, 4.0 / 3.0 * pi, 0.002},
      {"torus", 16384, 2 * pi * pi * 1.0 * 0.4 * 0.4, 0.005},
      {"knot", 40960, pi * 0.3 * 0.3 * length, 0.01},
  };
  ASSERT_EQ(builtinMeshNames().size(), std::size(expected));
  for (const Expect& e : expected) {
    SCOPED_TRACE(e.name);
    const TriangleMesh m = builtinMesh(e.name);
    EXPECT_EQ(m.triangleCount(), e.triangles);
    expectClosedAndOriented(m);
    EXPECT_NEAR(signedVolume(m) / e.volume, 1.0, e.tolerance);
    BuildConfig config;
    config.resolution = 256;
    EXPECT_TRUE(prepareMesh(m, config).closed);
  }
}

TEST(BuiltinMeshes, UnknownNameListsTheKnownOnes) {
  try {
    builtinMesh("bunny");
    FAIL() << "no error";
  } catch (const Error& e) {
    EXPECT_EQ(e.kind(), ErrorKind::InvalidArgument);
    const std::string message = e.what();
    for (const std::string& name : builtinMeshNames()) EXPECT_NE(message.find(name), std::string::npos) << message;
  }
}

// ---- the shared real meshes (optional) --------------------------------------------------

TEST(SharedMeshes, TriangleCountsMatchTheManifest) {
  const fs::path dir = sharedMeshesDir();
  if (dir.empty() || !fs::is_directory(dir)) GTEST_SKIP() << "no shared meshes at '" << dir.string() << "'";
  // MANIFEST.md: triangles after splitting polygons into fans.
  const std::pair<const char*, size_t> manifest[] = {
      {"stanford-dragon-100k.ply", 100000}, {"ogre.obj", 124008},  {"nefertiti.obj", 99938},
      {"teapot.obj", 6320},                 {"teapot-shell.obj", 15704}, {"fandisk.obj", 12946},
      {"bracket.stl", 32360},               {"turbine-blade.stl", 13306}, {"cycloidal-drive.ply", 43368},
      {"tray-bottom.stl", 4520},
  };
  int read = 0;
  for (const auto& [name, triangles] : manifest) {
    const fs::path path = dir / name;
    if (!fs::exists(path)) continue;
    try {
      EXPECT_EQ(readMesh(path.string()).triangleCount(), triangles) << name;
      ++read;
    } catch (const Error& e) {
      // Without assimp only binary STL is readable, and the message says why.
      if (readsAllMeshFormats() || std::string(e.what()).find("without assimp") == std::string::npos)
        ADD_FAILURE() << e.what();
    }
  }
  if (read == 0) GTEST_SKIP() << "none of the manifest's meshes is readable in " << dir.string();
}

// Brute force: every undirected lattice edge of the prepared triangles used
// an even number of times.
bool closedByEdgeCounts(const LatticeTriangles& tris) {
  std::map<std::array<int32_t, 6>, int> count;
  for (const LatticeTriangle& t : tris) {
    for (int j = 0; j < 3; ++j) {
      std::array<int32_t, 3> p{t.v[j][0], t.v[j][1], t.v[j][2]}, q{t.v[(j + 1) % 3][0], t.v[(j + 1) % 3][1], t.v[(j + 1) % 3][2]};
      if (q < p) std::swap(p, q);
      ++count[{p[0], p[1], p[2], q[0], q[1], q[2]}];
    }
  }
  return std::all_of(count.begin(), count.end(), [](const auto& e) { return e.second % 2 == 0; });
}

// Brute force: triangles whose sorted corners repeat an earlier triangle's.
size_t duplicatesByCornerCounts(const LatticeTriangles& tris) {
  std::set<std::array<std::array<int32_t, 3>, 3>> seen;
  for (const LatticeTriangle& t : tris) {
    std::array<std::array<int32_t, 3>, 3> c;
    for (int j = 0; j < 3; ++j) c[size_t(j)] = {t.v[j][0], t.v[j][1], t.v[j][2]};
    std::sort(c.begin(), c.end());
    seen.insert(c);
  }
  return tris.size() - seen.size();
}

// snapToLattice rounds as std::llround of the clamped lattice coordinate
// (halves away from zero): at every half of a small lattice, a double either
// side of it, at the ends and beyond them.
TEST(PrepareMesh, SnapRoundsAsLlround) {
  GridSpec g;
  g.resolution = 64;
  g.origin = {-1.0, 0.25, 3.0};
  g.voxelSize = 0.125;
  const double limit = double(int64_t(g.resolution) * kLatticePerVoxel);
  for (int a = 0; a < 3; ++a) {
    for (int64_t k = -2; k <= int64_t(limit) + 2; k += 7) {
      for (double step : {0.0, 0.25, 0.5, 0.75}) {
        const double q = double(k) + step; // lattice coordinate
        for (double qq : {std::nextafter(q, -1e30), q, std::nextafter(q, 1e30)}) {
          const double x = g.origin[size_t(a)] + qq * (g.voxelSize / double(kLatticePerVoxel));
          const double exact = (x - g.origin[size_t(a)]) * (double(kLatticePerVoxel) / g.voxelSize);
          const int32_t want = int32_t(std::llround(std::min(std::max(exact, 0.0), limit)));
          ASSERT_EQ(snapToLattice(x, g, a), want) << "axis " << a << " x " << x;
        }
      }
    }
    const double halfBelowOne = std::nextafter(0.5, 0.0); // + 0.5 rounds up to 1 in doubles
    const double x = g.origin[size_t(a)] + halfBelowOne * (g.voxelSize / double(kLatticePerVoxel));
    const double exact = (x - g.origin[size_t(a)]) * (double(kLatticePerVoxel) / g.voxelSize);
    EXPECT_EQ(snapToLattice(x, g, a), int32_t(std::llround(exact)));
  }
}

// prepareMesh's closedness test and duplicate count (hash buckets, several
// blocks) against the
// brute force: a closed sphere, the sphere with triangles taken away or
// repeated, and soups on a tiny lattice where most edges are shared by many.
TEST(PrepareMesh, ClosedAndDuplicatesAgreeWithBruteForce) {
  BuildConfig config;
  config.resolution = 256;
  const TriangleMesh sphere = builtinMesh("sphere");
  uint64_t seed = 12345;
  auto next = [&seed] { return (seed = seed * 6364136223846793005ull + 1442695040888963407ull) >> 33; };
  std::vector<TriangleMesh> cases = {sphere};
  for (int variant = 0; variant < 4; ++variant) {
    TriangleMesh m = sphere;
    const size_t t = next() % m.triangleCount();
    if (variant == 0) m.triangles.erase(m.triangles.begin() + 3 * t, m.triangles.begin() + 3 * t + 3);
    std::vector<uint32_t> tri(m.triangles.begin() + 3 * t, m.triangles.begin() + 3 * t + 3);
    for (int copies = 0; copies < variant; ++copies) m.triangles.insert(m.triangles.end(), tri.begin(), tri.end());
    cases.push_back(m);
  }
  for (size_t triangles : {7u, 1000u, 60000u}) {
    for (int paired = 0; paired < 2; ++paired) {
      TriangleMesh m;
      for (int i = 0; i < 4 * 4 * 4; ++i) m.points.insert(m.points.end(), {double(i % 4), double(i / 4 % 4), double(i / 16)});
      for (size_t i = 0; i < triangles; ++i) {
        uint32_t a = next() % 64, b = next() % 64, c = next() % 64;
        while (b == a) b = next() % 64;
        while (c == a || c == b) c = next() % 64;
        for (int k = 0; k < (paired ? 2 : 1); ++k) m.triangles.insert(m.triangles.end(), {a, b, c});
      }
      cases.push_back(m);
    }
  }
  int closed = 0, open = 0, duplicates = 0;
  for (size_t i = 0; i < cases.size(); ++i) {
    SCOPED_TRACE("case " + std::to_string(i));
    const PreparedMesh p = prepareMesh(cases[i], config);
    const bool expected = closedByEdgeCounts(p.triangles);
    EXPECT_EQ(p.closed, expected);
    EXPECT_EQ(p.duplicateTriangles, duplicatesByCornerCounts(p.triangles));
    duplicates += p.duplicateTriangles > 0;
    (expected ? closed : open) += 1;
  }
  EXPECT_GE(closed, 4); // both answers are exercised
  EXPECT_GE(open, 4);
  EXPECT_GE(duplicates, 4);
}

} // namespace
} // namespace test
} // namespace hdt
