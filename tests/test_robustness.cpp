// Issue 12 ("nothing lost, nothing hangs"): one regression test per defect the
// robustness pass found, with the inputs it reported. Each fails on 2be9b13.
#include "hdt/atomic_file.hpp"
#include "hdt/builder.hpp"
#include "hdt/dense.hpp"
#include "hdt/error.hpp"
#include "hdt/hdt_file.hpp"
#include "hdt/mesh.hpp"
#include "hdt/mesh_io.hpp"
#include "support/format_volumes.hpp"
#include "support/shapes.hpp"

#include <gtest/gtest.h>

#include <dirent.h>
#include <signal.h>
#include <sys/resource.h>
#include <sys/stat.h>
#include <sys/sysmacros.h>
#include <unistd.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <fstream>
#include <functional>
#include <future>
#include <iterator>
#include <string>
#include <thread>
#include <vector>

#include <tbb/info.h>

namespace hdt {
namespace test {
namespace {

// The message of the hdt::Error f throws (checked to be of `kind`), or "".
std::string errorOf(const std::function<void()>& f, ErrorKind kind) {
  try {
    f();
  } catch (const Error& e) {
    EXPECT_EQ(int(e.kind()), int(kind)) << e.what();
    return e.what();
  }
  ADD_FAILURE() << "nothing thrown";
  return "";
}

void writeText(const std::string& path, const std::string& text) {
  std::ofstream out(path, std::ios::binary | std::ios::trunc);
  out << text;
}

std::string readAll(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  return std::string(std::istreambuf_iterator<char>(in), {});
}

// A fresh, empty directory for one test.
std::string freshDir(const std::string& name) {
  const std::string dir = tempPath("robust_" + name);
  std::system(("rm -rf '" + dir + "'").c_str());
  ::mkdir(dir.c_str(), 0777);
  return dir;
}

std::vector<std::string> entries(const std::string& dir) {
  std::vector<std::string> names;
  if (DIR* d = ::opendir(dir.c_str())) {
    while (dirent* e = ::readdir(d))
      if (std::string(e->d_name) != "." && std::string(e->d_name) != "..") names.push_back(e->d_name);
    ::closedir(d);
  }
  std::sort(names.begin(), names.end());
  return names;
}

Volume sphereVolume(int resolution) {
  BuildConfig c;
  c.resolution = resolution;
  c.rootGrid = 4;
  c.leafSize = 8;
  BuildOptions o;
  o.backend = Backend::Cpu;
  return voxelize(icosphere(3, 1.0), c, o);
}

// Runs f with the file-size limit set to `bytes` (SIGXFSZ ignored, so a
// write past it fails with EFBIG instead of killing the test).
void withFileSizeLimit(rlim_t bytes, const std::function<void()>& f) {
  rlimit old{};
  ::getrlimit(RLIMIT_FSIZE, &old);
  auto previous = ::signal(SIGXFSZ, SIG_IGN);
  rlimit limited = old;
  limited.rlim_cur = bytes;
  ::setrlimit(RLIMIT_FSIZE, &limited);
  try {
    f();
  } catch (...) {
    ::setrlimit(RLIMIT_FSIZE, &old);
    ::signal(SIGXFSZ, previous);
    throw;
  }
  ::setrlimit(RLIMIT_FSIZE, &old);
  ::signal(SIGXFSZ, previous);
}

// ---- defect 1: the tiny PLY that hung readPly (the issue's file, 66 bytes with LF) -------------------------------------

TEST(Issue12Ply, ElementWithoutPropertiesAndAHugeCountIsRefused) {
  const std::string path = tempPath("robust_junk.ply");
  writeText(path, "ply\nformat ascii 1.0\nelement junk 18446744073709551615\nend_header\n");
  // Guard against the hang this test is about: report it instead of blocking ctest.
  auto result = std::async(std::launch::async, [&] {
    return errorOf([&] { readMesh(path); }, ErrorKind::BadInput);
  });
  if (result.wait_for(std::chrono::seconds(60)) != std::future_status::ready) {
    ADD_FAILURE() << "readMesh still loops over the empty records after 60 s";
    std::fflush(stdout);
    std::_Exit(1);
  }
  const std::string m = result.get();
  EXPECT_NE(m.find("declares 18446744073709551615 entries"), std::string::npos) << m;
}

TEST(Issue12Ply, PropertylessCountsAreBoundedByTheFileSize) {
  // 10^8 empty records in a file of a hundred bytes: refused without looping.
  const std::string path = tempPath("robust_junk_small.ply");
  writeText(path, "ply\nformat binary_little_endian 1.0\nelement junk 100000000\nend_header\n");
  const std::string m = errorOf([&] { readMesh(path); }, ErrorKind::BadInput);
  EXPECT_NE(m.find("element 'junk' declares 100000000 entries"), std::string::npos) << m;
}

TEST(Issue12Ply, FewEmptyRecordsAreSkipped) {
  const std::string path = tempPath("robust_junk_ok.ply");
  writeText(path, "ply\nformat ascii 1.0\nelement junk 5\nelement vertex 3\nproperty float x\n"
                  "property float y\nproperty float z\nelement face 1\nproperty list uchar int vertex_indices\n"
                  "end_header\n0 0 0\n1 0 0\n0 1 0\n3 0 1 2\n");
  const TriangleMesh m = readMesh(path);
  EXPECT_EQ(m.triangleCount(), 1u);
  EXPECT_EQ(m.pointCount(), 3u);
}

// ---- defect 8: +-1e308 overflowed the extent and was called "zero extent" ---------------

TEST(Issue12Extent, OverflowingExtentIsNamed) {
  const std::string path = tempPath("robust_huge.ply");
  writeText(path, "ply\nformat ascii 1.0\nelement vertex 3\nproperty double x\nproperty double y\n"
                  "property double z\nelement face 1\nproperty list uchar int vertex_indices\nend_header\n"
                  "-1e308 0 0\n1e308 0 0\n0 1e308 0\n3 0 1 2\n");
  const TriangleMesh mesh = readMesh(path);
  BuildConfig c;
  c.resolution = 256;
  const std::string m = errorOf([&] { prepareMesh(mesh, c); }, ErrorKind::BadInput);
  EXPECT_NE(m.find("overflows double precision"), std::string::npos) << m;
  EXPECT_EQ(m.find("zero extent"), std::string::npos) << m;
  // Large but not overflowing: coordinates 1e308 and 1.5e308 (their sum is inf).
  TriangleMesh far;
  far.points = {1e308, 1e308, 1e308, 1.5e308, 1e308, 1e308, 1e308, 1.5e308, 1e308};
  far.triangles = {0, 1, 2};
  const PreparedMesh p = prepareMesh(far, c);
  for (double o : p.grid.origin) EXPECT_TRUE(std::isfinite(o));
}

// ---- defect 2: a failed write destroyed data ------------------------------------------

TEST(Issue12AtomicWrite, FailedOverwriteKeepsTheOldFile) {
  const std::string dir = freshDir("overwrite");
  const std::string path = dir + "/knot.hdt";
  const Volume small = sphereVolume(64), large = sphereVolume(256);
  writeHdt(small, path);
  const std::string before = readAll(path);
  std::string m;
  withFileSizeLimit(before.size() + 1000, [&] {
    m = errorOf([&] { writeHdt(large, path); }, ErrorKind::OutputFailed);
  });
  EXPECT_NE(m.find(path + ": "), std::string::npos) << m;
  EXPECT_EQ(readAll(path), before) << "the old file was lost";
  EXPECT_EQ(entries(dir), std::vector<std::string>{"knot.hdt"}) << "the temporary file was left behind";
  writeHdt(large, path); // without the limit it succeeds and replaces it
  expectSameVolume(large, readHdt(path));
}

TEST(Issue12AtomicWrite, FailedDenseOverwriteKeepsTheOldFile) {
  const std::string dir = freshDir("dense");
  const std::string path = dir + "/v.nrrd";
  writeNrrd(sphereVolume(64), path);
  const std::string before = readAll(path);
  withFileSizeLimit(before.size() + 1000, [&] {
    errorOf([&] { writeNrrd(sphereVolume(128), path); }, ErrorKind::OutputFailed);
  });
  EXPECT_EQ(readAll(path), before);
  EXPECT_EQ(entries(dir), std::vector<std::string>{"v.nrrd"});
}

TEST(Issue12AtomicWrite, NonRegularTargetsAreRefusedAndKept) {
  const std::string dir = freshDir("special");
  const Volume v = sphereVolume(64);
  // A directory (the old writer's std::remove deleted an empty one).
  const std::string sub = dir + "/out.hdt";
  ASSERT_EQ(::mkdir(sub.c_str(), 0777), 0);
  std::string m = errorOf([&] { writeHdt(v, sub); }, ErrorKind::OutputFailed);
  EXPECT_NE(m.find("is a directory"), std::string::npos) << m;
  struct stat st {};
  EXPECT_TRUE(::stat(sub.c_str(), &st) == 0 && S_ISDIR(st.st_mode)) << "the directory was removed";
  errorOf([&] { writeNrrd(v, sub); }, ErrorKind::OutputFailed);
  EXPECT_TRUE(::stat(sub.c_str(), &st) == 0 && S_ISDIR(st.st_mode));
  // A copy of /dev/full (root only: mknod): writing fails, the node must stay.
  const std::string full = dir + "/full.hdt";
  if (::mknod(full.c_str(), S_IFCHR | 0666, makedev(1, 7)) == 0) {
    m = errorOf([&] { writeHdt(v, full); }, ErrorKind::OutputFailed);
    EXPECT_NE(m.find("not a regular file"), std::string::npos) << m;
    EXPECT_TRUE(::lstat(full.c_str(), &st) == 0 && S_ISCHR(st.st_mode)) << "the device node was unlinked";
    errorOf([&] { writeNrrd(v, full); }, ErrorKind::OutputFailed);
    EXPECT_TRUE(::lstat(full.c_str(), &st) == 0 && S_ISCHR(st.st_mode));
  }
  std::vector<std::string> expected = {"out.hdt"};
  if (::lstat(full.c_str(), &st) == 0) expected.insert(expected.begin(), "full.hdt");
  EXPECT_EQ(entries(dir), expected);
}

TEST(Issue12AtomicWrite, SymbolicLinksAreWrittenThroughAndNeverUnlinked) {
  const std::string dir = freshDir("symlink");
  const std::string file = dir + "/real.hdt", link = dir + "/link.hdt";
  const Volume small = sphereVolume(64), large = sphereVolume(256);
  writeHdt(small, file);
  ASSERT_EQ(::chmod(file.c_str(), 0640), 0);
  ASSERT_EQ(::symlink("real.hdt", link.c_str()), 0);
  const std::string before = readAll(file);
  withFileSizeLimit(before.size() + 1000, [&] {
    errorOf([&] { writeHdt(large, link); }, ErrorKind::OutputFailed);
  });
  struct stat st {};
  ASSERT_TRUE(::lstat(link.c_str(), &st) == 0 && S_ISLNK(st.st_mode)) << "the link was removed";
  EXPECT_EQ(readAll(file), before);
  writeHdt(large, link); // succeeds: the link stays, the file it names is replaced
  ASSERT_TRUE(::lstat(link.c_str(), &st) == 0 && S_ISLNK(st.st_mode));
  expectSameVolume(large, readHdt(file));
  ASSERT_EQ(::stat(file.c_str(), &st), 0);
  EXPECT_EQ(st.st_mode & 07777, 0640u) << "the replaced file lost its permissions";
  EXPECT_EQ(entries(dir), (std::vector<std::string>{"link.hdt", "real.hdt"}));
  // A dangling link is refused and kept.
  const std::string dangling = dir + "/dangling.hdt";
  ASSERT_EQ(::symlink("nowhere/x.hdt", dangling.c_str()), 0);
  errorOf([&] { writeHdt(small, dangling); }, ErrorKind::OutputFailed);
  EXPECT_TRUE(::lstat(dangling.c_str(), &st) == 0 && S_ISLNK(st.st_mode));
}

TEST(Issue12AtomicWrite, NewFilesGetTheUmaskAndMissingDirectoriesAreReported) {
  const std::string dir = freshDir("mode");
  const mode_t old = ::umask(022);
  writeNrrd(sphereVolume(64), dir + "/v.nrrd");
  ::umask(old);
  struct stat st {};
  ASSERT_EQ(::stat((dir + "/v.nrrd").c_str(), &st), 0);
  EXPECT_EQ(st.st_mode & 07777, 0644u);
  const std::string missing = dir + "/no/such/dir/v.hdt";
  const std::string m = errorOf([&] { checkOutputWritable(missing); }, ErrorKind::OutputFailed);
  EXPECT_NE(m.find("No such file or directory"), std::string::npos) << m;
  errorOf([&] { writeHdt(sphereVolume(64), missing); }, ErrorKind::OutputFailed);
  EXPECT_NO_THROW(checkOutputWritable(dir + "/v.nrrd"));
  EXPECT_EQ(entries(dir), std::vector<std::string>{"v.nrrd"}) << "the probe file was left behind";
}

TEST(Issue12AtomicWrite, UncommittedFilesLeaveNothing) {
  const std::string dir = freshDir("uncommitted");
  writeText(dir + "/keep.hdt", "old");
  {
    AtomicFile f(dir + "/keep.hdt");
    f.write("new", 3);
    EXPECT_EQ(entries(dir).size(), 2u); // the temporary file beside the target
  } // destroyed without commit(): as after a failure part-way
  EXPECT_EQ(readAll(dir + "/keep.hdt"), "old");
  EXPECT_EQ(entries(dir), std::vector<std::string>{"keep.hdt"});
}

// ---- defect 3: --threads unbounded -------------------------------------------------------

TEST(Issue12Threads, AbsurdCountsAreRefusedAndTheCountUsedIsRecorded) {
  BuildConfig c;
  c.resolution = 64;
  c.rootGrid = 4;
  c.leafSize = 8;
  const PreparedMesh p = prepareMesh(icosphere(2, 1.0), c);
  BuildOptions o;
  o.backend = Backend::Cpu;
  for (int threads : {kMaxCpuThreads + 1, 10000000, 1 << 30, 2147483647, -1}) {
    o.threads = threads;
    const std::string m = errorOf([&] { buildCpu(p, o); }, ErrorKind::InvalidArgument);
    EXPECT_NE(m.find("between 0 (all cores) and " + std::to_string(kMaxCpuThreads)), std::string::npos) << m;
  }
  o.threads = 3;
  const Volume three = buildCpu(p, o);
  EXPECT_EQ(three.stats.threads, 3);
  o.threads = 0;
  const Volume all = buildCpu(p, o);
  EXPECT_EQ(all.stats.threads, tbb::info::default_concurrency());
  const std::vector<uint8_t> bytes = serializeHdt(three);
  EXPECT_EQ(deserializeHdt(bytes.data(), bytes.size()).stats.threads, 3) << "the .hdt records another count";
}

// ---- defect 9: silent surprises ----------------------------------------------------------

TEST(Issue12Warnings, DoubledClosedMeshIsReported) {
  TriangleMesh twice = icosphere(3, 1.0);
  append(twice, icosphere(3, 1.0));
  BuildConfig c;
  c.resolution = 64;
  c.rootGrid = 4;
  c.leafSize = 8;
  BuildOptions o;
  o.backend = Backend::Cpu;
  const PreparedMesh p = prepareMesh(twice, c);
  EXPECT_EQ(p.duplicateTriangles, p.triangles.size() / 2);
  const Volume v = build(p, o);
  ASSERT_TRUE(v.closedMesh);
  EXPECT_EQ(v.stats.insideVoxels, 0u);
  const std::vector<std::string> w = buildWarnings(p, v);
  ASSERT_EQ(w.size(), 2u);
  const std::string counts = std::to_string(p.triangles.size() / 2) + " of " + std::to_string(p.triangles.size());
  EXPECT_NE(w[0].find(counts + " triangles repeat"), std::string::npos) << w[0];
  EXPECT_NE(w[1].find("closed but no voxel is inside"), std::string::npos) << w[1];

  // Reversed copies count too; a plain sphere warns of nothing.
  TriangleMesh reversed = icosphere(3, 1.0), flipped = icosphere(3, 1.0);
  flipOrientation(flipped);
  append(reversed, flipped);
  EXPECT_EQ(prepareMesh(reversed, c).duplicateTriangles, p.duplicateTriangles);
  const PreparedMesh once = prepareMesh(icosphere(3, 1.0), c);
  EXPECT_EQ(once.duplicateTriangles, 0u);
  EXPECT_TRUE(buildWarnings(once, build(once, o)).empty());
}

// ---- defect 4: the memory estimate, wrong both ways --------------------------------------
// Deterministic parts only (a measured peak is not): the estimate covers the
// peaks the issue measured, and its leaf-grid count brackets the real one.
// Estimates against measured peaks: bench/results/memory-estimate.md.

TEST(Issue12MemoryEstimate, CoversTheRootGridPeaksTheIssueMeasured) {
  // Root-grid dominated: R = 512, L = 8, N = 4096 and R = 640, N = 5120 (the
  // issue's cases, estimated at 3.53 and 6.5 GB then). With the root-range CPU
  // driver they peak at 1.86 and 3.56 GB (bench/results/memory-estimate.md):
  // the estimate covers them, within 1.5x.
  const TriangleMesh sphere = builtinMesh("sphere");
  BuildConfig c;
  c.leafSize = 8;
  c.rootGrid = 512;
  c.resolution = 4096;
  const uint64_t e4096 = estimateHostBytes(prepareMesh(sphere, c));
  EXPECT_GT(e4096, uint64_t(1.86e9));
  EXPECT_LT(e4096, uint64_t(1.5 * 1.86e9));
  c.rootGrid = 640;
  c.resolution = 5120;
  const uint64_t e5120 = estimateHostBytes(prepareMesh(sphere, c));
  EXPECT_GT(e5120, uint64_t(3.56e9));
  EXPECT_LT(e5120, uint64_t(1.5 * 3.56e9));
}

TEST(Issue12MemoryEstimate, LeafGridCountIsBracketed) {
  // Leaves come from a raster of the triangles at the leaf level that counts
  // each leaf cube once: an upper bound, tight where the old area model was
  // not (3A / L^2 + triangles was 4.4x too high on a CAD mesh of many small
  // triangles; the projected area counted both sides of a thin wall, 2x).
  const auto bracket = [](const Shape& shape, int n, int r, int l, const std::string& what) {
    const PreparedMesh p = prepareMesh(shape.mesh, shape.config(n, r, l, false));
    BuildOptions o;
    o.backend = Backend::Cpu;
    const double actual = double(buildCpu(p, o).stats.leafGrids);
    const double estimated = estimateHostMemory(p).leafGrids;
    EXPECT_GE(estimated, actual) << what << " N=" << n;
    EXPECT_LE(estimated, 1.15 * actual) << what << " N=" << n;
  };
  for (const char* name : {"sphere", "torus", "knot"}) {
    Shape s;
    s.mesh = builtinMesh(name);
    bracket(s, 256, 16, 8, name);
    bracket(s, 512, 16, 16, name);
  }
  for (int n : {256, 512}) {
    bracket(thinPlateShape(n), n, 8, 8, "thin plate");
    bracket(tiltedThinPlateShape(n), n, 8, 8, "tilted thin plate");
    bracket(gridAlignedBoxShape(n), n, 8, 8, "box with faces on leaf planes");
  }
  bracket(rotatedCubeShape(), 256, 8, 8, "rotated cube");
  // Many tiny triangles in few leaves: the estimate must not count one leaf a triangle.
  Shape fine;
  fine.mesh = icosphere(6, 1.0);
  bracket(fine, 128, 4, 32, "icosphere of 81,920 triangles");
  BuildConfig c;
  c.resolution = 128;
  c.rootGrid = 4;
  c.leafSize = 32;
  EXPECT_LT(estimateHostBytes(prepareMesh(icosphere(6, 1.0), c)), uint64_t(256) << 20);
}

TEST(Issue12MemoryEstimate, WindingNumberAddsItsTreeAndRowCounts) {
  // The winding-number pass (winding.cpp) holds the tree over the triangles
  // and, per leaf, a signed count for each of its L^2 rows beside the leaf
  // states; parity needs neither.
  const Shape s = openHemisphereShape();
  BuildConfig c = s.config(256, 16, 8, false);
  c.insideTest = InsideTest::Parity;
  const HostMemoryEstimate parity = estimateHostMemory(prepareMesh(s.mesh, c));
  c.insideTest = InsideTest::WindingNumber;
  const HostMemoryEstimate winding = estimateHostMemory(prepareMesh(s.mesh, c));
  EXPECT_EQ(parity.winding, 0u);
  EXPECT_GE(double(winding.winding), winding.leafGrids * 8 * 8 * 4);
  EXPECT_EQ(winding.total - parity.total, winding.winding);
}

} // namespace
} // namespace test
} // namespace hdt
