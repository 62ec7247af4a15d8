// The CUDA driver's own behaviour: repeated runs give the same bytes, builds
// split into chunks by a small device memory budget give the same bytes as
// one-piece builds, a budget too small for one root cell is refused with
// OutOfResources, aborting through progress works and leaves the driver
// usable, a bad device ordinal is an InvalidArgument.
#include "chunked.hpp" // estimateBytes (host code: runs without a device)
#include "cuda_compare.hpp"

#include "hdt/builder.hpp"
#include "hdt/cuda_build.hpp"
#include "hdt/error.hpp"
#include "hdt/hdt_file.hpp"
#include "hdt/mesh.hpp"
#include "hdt/warm_pages.hpp"
#include "support/shapes.hpp"

#include <gtest/gtest.h>

#include <algorithm>
#include <regex>
#include <string>
#include <utility>
#include <vector>

namespace hdt {
namespace test {
namespace {

PreparedMesh prepared(const std::string& shape, int n, int r, int l, bool surfaceOnly) {
  const Shape s = makeShape(shape, n);
  return prepareMesh(s.mesh, s.config(n, r, l, surfaceOnly));
}

TEST(CudaDriver, RepeatedRunsGiveTheSameBytes) {
  HDT_REQUIRE_CUDA();
  for (const char* name : {"two_bodies", "open_hemisphere"}) {
    const PreparedMesh mesh = prepared(name, 512, 16, 16, false);
    const Volume first = build(mesh, cudaOptions());
    for (int run = 0; run < 3; ++run) {
      const Volume again = build(mesh, cudaOptions());
      EXPECT_EQ(again.elements, first.elements) << name << " run " << run;
      EXPECT_EQ(again.leafWords, first.leafWords) << name << " run " << run;
      EXPECT_EQ(again.levelStart, first.levelStart) << name << " run " << run;
    }
  }
}

// prepareCuda (what hdt-voxelize runs while it reads the mesh) leaves the
// driver giving the CPU driver's bytes; the copy back of these volumes (tens
// of MB) goes through the pinned staging ring in more than one piece.
TEST(CudaDriver, PreparedDeviceGivesTheCpuBytes) {
  HDT_REQUIRE_CUDA();
  for (bool surfaceOnly : {false, true}) {
    const Shape s = makeShape("two_bodies", 2048);
    const BuildConfig config = s.config(2048, 16, 16, surfaceOnly);
    prepareCuda(config, cudaOptions());
    const PreparedMesh mesh = prepareMesh(s.mesh, config);
    const Volume gpu = build(mesh, cudaOptions());
    EXPECT_GT(gpu.leafWords.size() * 4, size_t(20) << 20) << "the ring is not exercised";
    EXPECT_TRUE(sameVolume(gpu, build(mesh, cpuOptions())));
  }
}

// prepareCuda asks whether the mesh is known closed once, after the closed-mesh
// warm-up, and not for surface-only builds (whose two warm-ups run the same
// kernels). An open mesh built after a set-up told "closed" (its open-mesh
// kernels not loaded) still gives the CPU driver's bytes.
TEST(CudaDriver, PreparedForClosedMeshAsksOnceAndOpenBuildsStillMatch) {
  HDT_REQUIRE_CUDA();
  for (bool surfaceOnly : {false, true}) {
    const Shape s = openHemisphereShape();
    const BuildConfig config = s.config(1024, 16, 16, surfaceOnly);
    int asked = 0;
    prepareCuda(config, cudaOptions(), [&asked] { return ++asked > 0; });
    EXPECT_EQ(asked, surfaceOnly ? 0 : 1) << "surfaceOnly " << surfaceOnly;
    const PreparedMesh mesh = prepareMesh(s.mesh, config);
    ASSERT_FALSE(mesh.closed);
    EXPECT_TRUE(sameVolume(build(mesh, cudaOptions()), build(mesh, cpuOptions()))) << "surfaceOnly " << surfaceOnly;
  }
}

// What hdt-voxelize does around a build: the leaf words' estimate reserved as
// warm pages (the copy back then lands in them), and releaseCuda after the
// build. The volume is the CPU driver's, and a build after the release (a new
// context, pool and ring) gives the same bytes again.
TEST(CudaDriver, WarmPagesAndReleaseGiveTheCpuBytes) {
  HDT_REQUIRE_CUDA();
  const Shape s = makeShape("two_bodies", 2048);
  const BuildConfig config = s.config(2048, 16, 16, false);
  const PreparedMesh mesh = prepareMesh(s.mesh, config);
  const Volume cpu = build(mesh, cpuOptions());
  const size_t leafBytes = cpu.leafWords.size() * sizeof(uint32_t);
  trimWarmPages();
  reserveWarmPages(leafBytes + (size_t(4) << 20));
  const Volume warm = build(mesh, cudaOptions());
  EXPECT_LT(warmPagesState().free, size_t(8) << 20) << "the leaf words did not take the reserved pages";
  EXPECT_TRUE(sameVolume(warm, cpu));
  releaseCuda(cudaOptions());
  const Volume again = build(mesh, cudaOptions());
  EXPECT_TRUE(sameVolume(again, cpu));
  releaseCuda(cudaOptions());
  releaseCuda(cudaOptions()); // twice: nothing left to release
  EXPECT_TRUE(sameVolume(build(mesh, cudaOptions()), cpu));
}

// The copy back feeds the .hdt writer's leaf blocks piece by piece
// (HdtLeafEncoder): the CPU driver's volume, and the file the writer gives
// without the streamed blocks, byte for byte. Winding-number builds rewrite
// their leaves on the host after the copy: the writer compresses those itself.
TEST(CudaDriver, StreamedLeafBlocksGiveTheWrittenBytes) {
  HDT_REQUIRE_CUDA();
  for (bool surfaceOnly : {false, true}) {
    const Shape s = makeShape("two_bodies", 2048);
    const PreparedMesh mesh = prepareMesh(s.mesh, s.config(2048, 16, 16, surfaceOnly));
    HdtLeafEncoder streamed;
    BuildOptions options = cudaOptions();
    options.leafSink = &streamed;
    const Volume gpu = build(mesh, options);
    EXPECT_GT(gpu.leafWords.size() * 4, size_t(20) << 20) << "the ring is not exercised";
    EXPECT_TRUE(sameVolume(gpu, build(mesh, cpuOptions())));
    EXPECT_TRUE(serializeHdt(gpu, {}, &streamed) == serializeHdt(gpu)) << "surface only " << surfaceOnly;
    EXPECT_TRUE(streamed.usedByWriter()) << "surface only " << surfaceOnly;
  }
  const Shape s = makeShape("open_hemisphere", 256);
  BuildConfig config = s.config(256, 8, 16, false);
  config.insideTest = InsideTest::WindingNumber;
  const PreparedMesh mesh = prepareMesh(s.mesh, config);
  HdtLeafEncoder streamed;
  BuildOptions options = cudaOptions();
  options.leafSink = &streamed;
  const Volume gpu = build(mesh, options);
  EXPECT_TRUE(serializeHdt(gpu, {}, &streamed) == serializeHdt(gpu));
  EXPECT_FALSE(streamed.usedByWriter()) << "the winding number rewrites the leaves after the copy";
}

struct ChunkCase {
  const char* shape;
  int n, r, l;
  bool surfaceOnly;
};

class CudaChunked : public ::testing::TestWithParam<ChunkCase> {};

// A third of the one-piece peak forces chunks; every chunk still fits since
// no root cell holds a third of the surface.
TEST_P(CudaChunked, SameBytesAsOnePiece) {
  HDT_REQUIRE_CUDA();
  const ChunkCase c = GetParam();
  const PreparedMesh mesh = prepared(c.shape, c.n, c.r, c.l, c.surfaceOnly);
  const Volume whole = build(mesh, cudaOptions());
  const Volume cpu = build(mesh, cpuOptions());
  ASSERT_TRUE(sameVolume(whole, cpu));

  BuildOptions o = cudaOptions();
  o.deviceMemoryBudget = whole.stats.peakDeviceBytes / 3;
  std::vector<std::string> log;
  o.log = [&](const std::string& m) { log.push_back(m); };
  const Volume chunked = build(mesh, o);
  EXPECT_TRUE(sameVolume(chunked, cpu));
  EXPECT_LE(chunked.stats.peakDeviceBytes, o.deviceMemoryBudget);
  bool saidChunks = false;
  for (const std::string& m : log) saidChunks |= m.find("chunks") != std::string::npos;
  EXPECT_TRUE(saidChunks) << "the budget did not make the driver chunk the root grid";
}

INSTANTIATE_TEST_SUITE_P(Cases, CudaChunked,
                         ::testing::Values(ChunkCase{"sphere", 512, 16, 16, false},
                                           ChunkCase{"open_hemisphere", 512, 16, 8, false},
                                           ChunkCase{"two_bodies", 512, 8, 32, false},
                                           ChunkCase{"torus", 256, 8, 8, true},
                                           ChunkCase{"thin_plate_tilted", 512, 16, 16, true}),
                         [](const ::testing::TestParamInfo<ChunkCase>& i) {
                           return std::string(i.param.shape) + "_R" + std::to_string(i.param.r) + "_L" +
                                  std::to_string(i.param.l) + (i.param.surfaceOnly ? "_surface" : "_solid");
                         });

TEST(CudaDriver, BudgetBelowOneRootCellIsOutOfResources) {
  HDT_REQUIRE_CUDA();
  // One root cell (R = 1): nothing to split.
  const PreparedMesh mesh = prepared("sphere", 512, 1, 16, false);
  const Volume whole = build(mesh, cudaOptions());
  BuildOptions o = cudaOptions();
  o.deviceMemoryBudget = whole.stats.peakDeviceBytes / 2;
  try {
    build(mesh, o);
    FAIL() << "expected Error(OutOfResources)";
  } catch (const Error& e) {
    EXPECT_EQ(e.kind(), ErrorKind::OutOfResources) << e.what();
    EXPECT_NE(std::string(e.what()).find("MiB"), std::string::npos) << e.what();
  }
  // The device is still usable afterwards.
  EXPECT_TRUE(sameVolume(build(mesh, cudaOptions()), whole));
}

TEST(CudaDriver, ProgressCanAbort) {
  HDT_REQUIRE_CUDA();
  const PreparedMesh mesh = prepared("torus", 512, 16, 16, false);
  for (const char* stopAt : {"mapping", "branching", "leaf processing", "classification"}) {
    BuildOptions o = cudaOptions();
    std::vector<std::string> phases;
    o.progress = [&](double, const char* phase) {
      phases.push_back(phase);
      return std::string(phase) != stopAt;
    };
    try {
      build(mesh, o);
      FAIL() << "expected Error(Aborted) at " << stopAt;
    } catch (const Error& e) {
      EXPECT_EQ(e.kind(), ErrorKind::Aborted) << e.what();
    }
  }
  BuildOptions o = cudaOptions();
  std::vector<double> fractions;
  o.progress = [&](double f, const char*) {
    fractions.push_back(f);
    return true;
  };
  const Volume v = build(mesh, o);
  ASSERT_FALSE(fractions.empty());
  EXPECT_EQ(fractions.front(), 0.0);
  EXPECT_EQ(fractions.back(), 1.0);
  EXPECT_TRUE(sameVolume(v, build(mesh, cpuOptions())));
}

// An open mesh under the winding number: the device phases take the first
// part of the progress and the pass (host loops, device passes) the rest, one
// rising fraction; an abort at the pass leaves the driver usable.
TEST(CudaDriver, WindingPassReportsAndAborts) {
  HDT_REQUIRE_CUDA();
  const Shape shape = makeShape("open_hemisphere", 256);
  BuildConfig config = shape.config(256, 16, 16, false);
  config.insideTest = InsideTest::WindingNumber;
  const PreparedMesh mesh = prepareMesh(shape.mesh, config);
  const std::string windingPhase = "inside test: winding number";
  BuildOptions o = cudaOptions();
  std::vector<std::pair<double, std::string>> calls;
  o.progress = [&](double f, const char* phase) {
    calls.emplace_back(f, phase);
    return true;
  };
  const Volume v = build(mesh, o);
  ASSERT_FALSE(calls.empty());
  size_t winding = 0;
  for (size_t i = 0; i < calls.size(); ++i) {
    if (i > 0) EXPECT_GE(calls[i].first, calls[i - 1].first) << calls[i].second;
    if (calls[i].second == windingPhase) ++winding;
  }
  EXPECT_GE(winding, 3u);
  EXPECT_EQ(calls.back().second, "done");
  EXPECT_EQ(calls.back().first, 1.0);
  EXPECT_TRUE(sameVolume(v, build(mesh, cpuOptions())));

  o.progress = [&](double, const char* phase) { return phase != windingPhase; };
  try {
    build(mesh, o);
    FAIL() << "expected Error(Aborted) in the winding pass";
  } catch (const Error& e) {
    EXPECT_EQ(e.kind(), ErrorKind::Aborted) << e.what();
  }
  EXPECT_TRUE(sameVolume(v, build(mesh, cudaOptions())));
}

// The winding pass's device arrays count against the build's DeviceMemory
// (winding_device.cu, PassMemory): the reported peak includes them, and a
// budget caps them: with room beyond the build the pass runs on the device
// within it (its queues grow with the levels, cut to the budget), with none
// the leaf pass returns to the host; the bytes are the same every time.
BuildConfig windingConfig(const Shape& shape, InsideTest test) {
  BuildConfig config = shape.config(256, 16, 16, false);
  config.insideTest = test;
  return config;
}

struct LoggedBuild {
  Volume volume;
  std::vector<std::string> log;
  std::string text() const { // for failure messages
    std::string all;
    for (const std::string& l : log) all += l + "\n";
    return all;
  }
  bool said(const std::string& text) const {
    return std::any_of(log.begin(), log.end(), [&](const std::string& l) { return l.find(text) != std::string::npos; });
  }
  uint64_t passPeakBytes() const { // the driver's "held at most N bytes at once"
    const std::regex re("the device passes held at most ([0-9]+) bytes");
    std::smatch m;
    for (const std::string& l : log)
      if (std::regex_search(l, m, re)) return std::stoull(m[1].str());
    return 0;
  }
};

LoggedBuild buildLogged(const PreparedMesh& mesh, uint64_t budget) {
  LoggedBuild b;
  BuildOptions o = cudaOptions();
  o.deviceMemoryBudget = budget;
  o.log = [&b](const std::string& line) { b.log.push_back(line); };
  b.volume = build(mesh, o);
  return b;
}

TEST(CudaDriver, WindingPassCountsAgainstThePeakAndTheBudget) {
  HDT_REQUIRE_CUDA();
  const Shape shape = makeShape("open_hemisphere", 256);
  const PreparedMesh mesh = prepareMesh(shape.mesh, windingConfig(shape, InsideTest::WindingNumber));
  const Volume cpu = build(mesh, cpuOptions());
  // The parity build allocates more than the winding build's device phases
  // (which skip the parity buffers): an upper bound on them.
  const uint64_t parityPeak =
      build(prepareMesh(shape.mesh, windingConfig(shape, InsideTest::Parity)), cudaOptions()).stats.peakDeviceBytes;

  const LoggedBuild unlimited = buildLogged(mesh, 0);
  EXPECT_TRUE(sameVolume(unlimited.volume, cpu));
  ASSERT_TRUE(unlimited.said("winding pass on the device")) << unlimited.text();
  const uint64_t passPeak = unlimited.passPeakBytes();
  EXPECT_GE(unlimited.volume.stats.peakDeviceBytes, passPeak) << "the reported peak leaves the pass out";
  // The box queues grow with the levels' boxes: a 256^3 build holds nothing
  // like the largest queues' 2 x 2^23 boxes (0.67 GB of leaf boxes).
  EXPECT_LT(passPeak, uint64_t(128) << 20) << unlimited.text();

  // Room for the pass beside the build: it runs on the device, within it.
  const uint64_t roomy = parityPeak + (uint64_t(64) << 20);
  const LoggedBuild roomyBuild = buildLogged(mesh, roomy);
  EXPECT_TRUE(sameVolume(roomyBuild.volume, cpu));
  EXPECT_TRUE(roomyBuild.said("winding pass on the device")) << roomyBuild.text();
  EXPECT_LE(roomyBuild.volume.stats.peakDeviceBytes, roomy);

  // 1 MiB beyond the build: the leaf pass declines (its list of hard voxels
  // alone takes 8 MiB) and the host decides the leaves.
  const uint64_t tight = parityPeak + (uint64_t(1) << 20);
  const LoggedBuild declined = buildLogged(mesh, tight);
  EXPECT_TRUE(sameVolume(declined.volume, cpu));
  EXPECT_TRUE(declined.said("no device memory for the winding leaf pass; it runs on the host")) << declined.text();
  EXPECT_LE(declined.volume.stats.peakDeviceBytes, tight);
}

// The one-piece estimate of a build followed by the winding pass counts what
// its device phases allocate: the surface only, as for a surface-only build
// (no parity buffers, line tables or pass-1 masks).
TEST(CudaDriver, WindingBuildEstimateIsTheSurfaceBuilds) {
  HDT_REQUIRE_CUDA();
  const Shape shape = makeShape("open_hemisphere", 256);
  const auto estimate = [&](InsideTest test, bool surfaceOnly) {
    BuildConfig config = windingConfig(shape, test);
    config.surfaceOnly = surfaceOnly;
    CudaBuildReport report;
    buildCudaWithReport(prepareMesh(shape.mesh, config), cudaOptions(), &report, true);
    return report.estimatedBytes;
  };
  const uint64_t winding = estimate(InsideTest::WindingNumber, false);
  EXPECT_EQ(winding, estimate(InsideTest::WindingNumber, true));
  EXPECT_LT(winding, estimate(InsideTest::Parity, false));
}

// The same on the estimate itself (chunked.cpp; no device needed): closed
// and open meshes, the winding number's estimate is the surface build's and
// below the parity build's.
TEST(CudaDriver, EstimateOfAWindingBuildSkipsTheParityBuffers) {
  for (const char* name : {"sphere", "open_hemisphere"}) {
    const Shape shape = makeShape(name, 256);
    const auto estimate = [&](InsideTest test, bool surfaceOnly) {
      BuildConfig config = windingConfig(shape, test);
      config.surfaceOnly = surfaceOnly;
      return cuda::estimateBytes(prepareMesh(shape.mesh, config), 1.0e6, 5000, 4096);
    };
    const uint64_t winding = estimate(InsideTest::WindingNumber, false);
    EXPECT_EQ(winding, estimate(InsideTest::WindingNumber, true)) << name;
    EXPECT_LT(winding, estimate(InsideTest::Parity, false)) << name;
  }
}

TEST(CudaDriver, BadDeviceIsInvalidArgument) {
  HDT_REQUIRE_CUDA();
  const PreparedMesh mesh = prepared("sphere", 256, 16, 16, false);
  BuildOptions o = cudaOptions();
  o.device = 1000;
  try {
    build(mesh, o);
    FAIL() << "expected Error(InvalidArgument)";
  } catch (const Error& e) {
    EXPECT_EQ(e.kind(), ErrorKind::InvalidArgument) << e.what();
  }
}

TEST(CudaDriver, AutoPrefersTheDevice) {
  HDT_REQUIRE_CUDA();
  const PreparedMesh mesh = prepared("sphere", 256, 16, 16, false);
  BuildOptions o;
  o.backend = Backend::Auto;
  EXPECT_EQ(build(mesh, o).stats.backend, "cuda");
}

} // namespace
} // namespace test
} // namespace hdt
