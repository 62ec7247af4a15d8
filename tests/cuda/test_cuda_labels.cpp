// Labelled builds (hdt/labels.hpp): the CUDA driver against the CPU driver,
// byte for byte (tree, leaf words, element and voxel labels), on the label
// test cases of tests/test_labels.cpp and on the shared meshes labelled by
// connected components.
#include "cuda_compare.hpp"

#include "hdt/builder.hpp"
#include "hdt/error.hpp"
#include "hdt/labels.hpp"
#include "hdt/mesh.hpp"
#include "hdt/mesh_io.hpp"
#include "support/mesh_files.hpp"
#include "support/shapes.hpp"

#include <gtest/gtest.h>

#include <algorithm>
#include <cstdlib>
#include <string>
#include <sys/stat.h>
#include <vector>

namespace hdt {
namespace test {
namespace {

TriangleMesh withLabel(TriangleMesh m, Label label) {
  m.triangleLabels.assign(m.triangleCount(), label);
  return m;
}

TriangleMesh combined(std::initializer_list<TriangleMesh> parts) {
  TriangleMesh all;
  for (const TriangleMesh& p : parts) {
    append(all, p);
    all.triangleLabels.insert(all.triangleLabels.end(), p.triangleLabels.begin(), p.triangleLabels.end());
  }
  return all;
}

BuildConfig grid(int n, int r, int l) {
  BuildConfig c;
  c.resolution = n;
  c.rootGrid = r;
  c.leafSize = l;
  c.insideTest = InsideTest::Parity; // the open parts' three-axis rule, on the device
  return c;
}

::testing::AssertionResult sameLabelled(const Volume& gpu, const Volume& cpu) {
  const ::testing::AssertionResult states = sameVolume(gpu, cpu);
  if (!states) return states;
  if (gpu.labels.elementLabels != cpu.labels.elementLabels)
    return ::testing::AssertionFailure() << "element labels differ";
  const LabelField &g = gpu.labels, &c = cpu.labels;
  if (g.palettes != c.palettes || g.paletteIndices != c.paletteIndices || g.wideLabels != c.wideLabels)
    return ::testing::AssertionFailure() << "voxel labels differ (palettes, palette indices or wide labels)";
  if (g.mixedIndex != c.mixedIndex || g.mixedBlock != c.mixedBlock) // the device makes them too
    return ::testing::AssertionFailure() << "the index of mixed leaves differs";
  if (unpackVoxelLabels(gpu) != unpackVoxelLabels(cpu)) return ::testing::AssertionFailure() << "voxel labels differ";
  // The device combination counts its voxels on the device; the CPU's come from the host pass.
  if (gpu.stats.activeVoxels != cpu.stats.activeVoxels || gpu.stats.insideVoxels != cpu.stats.insideVoxels)
    return ::testing::AssertionFailure() << "voxel counts differ: surface " << gpu.stats.activeVoxels << " vs "
                                         << cpu.stats.activeVoxels << ", inside " << gpu.stats.insideVoxels << " vs "
                                         << cpu.stats.insideVoxels;
  return ::testing::AssertionSuccess();
}

// Which labelled path a CUDA build took, from its log: the device
// combination (buildLabelledCuda) or per-part builds combined on the host.
struct PathLog {
  std::string text;
  BuildOptions options(BuildOptions o) {
    o.log = [this](const std::string& line) { text += line + "\n"; };
    return o;
  }
  bool onDevice() const { return text.find("combined on the device") != std::string::npos; }
};

void expectSameOnBoth(const TriangleMesh& mesh, const BuildConfig& config, const LabelOptions& labels = {}) {
  const Volume cpu = voxelizeLabelled(mesh, config, cpuOptions(), labels);
  PathLog log;
  const Volume gpu = voxelizeLabelled(mesh, config, log.options(cudaOptions()), labels);
  EXPECT_TRUE(sameLabelled(gpu, cpu));
  // These cases all fit the device: the device combination must be what ran
  // (a mesh of one label has none: it is built once, as unlabelled).
  EXPECT_EQ(log.onDevice(), onlyLabel(mesh) == kOutsideLabel) << log.text;
  BuildOptions chunked = cudaOptions();
  chunked.deviceMemoryBudget = 64ull << 20; // small: builds the root grid in chunks (per-part path)
  EXPECT_TRUE(sameLabelled(voxelizeLabelled(mesh, config, chunked, labels), cpu)) << "chunked";
  // The parts prepared beforehand (as hdt-voxelize does), the whole mesh prepared solid.
  const Volume prepared = voxelizeLabelled(prepareMesh(mesh, config), prepareLabelledParts(mesh, config),
                                           mesh.labelNames, cudaOptions(), labels);
  EXPECT_TRUE(sameLabelled(prepared, cpu)) << "parts prepared beforehand";
}

// An open box (the +z face missing): classified by the three-axis majority.
TriangleMesh openBox(const Vec3& lo, const Vec3& hi) {
  TriangleMesh m = box(lo, hi);
  TriangleMesh open;
  open.points = m.points;
  for (size_t t = 0; t < m.triangleCount(); ++t) {
    bool top = true;
    for (int c = 0; c < 3; ++c) top = top && m.points[3 * m.triangles[3 * t + size_t(c)] + 2] == hi[2];
    if (!top) open.triangles.insert(open.triangles.end(), m.triangles.begin() + 3 * t, m.triangles.begin() + 3 * t + 3);
  }
  return open;
}

TEST(CudaLabels, TouchingCubesNestedBoxesOverlappingSpheres) {
  HDT_REQUIRE_CUDA();
  const TriangleMesh cubes = combined({withLabel(box({-1, -1, -1}, {0, 1, 1}), 1), withLabel(box({0, -1, -1}, {1, 1, 1}), 2)});
  const TriangleMesh nested =
      combined({withLabel(box({-1, -1, -1}, {1, 1, 1}), 1), withLabel(box({-0.3, -0.3, -0.3}, {0.3, 0.3, 0.3}), 2)});
  const TriangleMesh spheres = combined({withLabel(icosphere(4, 1.0, {-0.4, 0, 0}), 3),
                                         withLabel(icosphere(4, 1.0, {0.4, 0, 0}), 7)});
  for (const BuildConfig& c : {grid(128, 4, 8), grid(512, 16, 16), grid(512, 8, 32)}) {
    expectSameOnBoth(cubes, c);
    expectSameOnBoth(nested, c);
    for (OverlapPolicy p : {OverlapPolicy::Lowest, OverlapPolicy::Highest}) {
      LabelOptions o;
      o.overlap = p;
      expectSameOnBoth(spheres, c, o);
    }
    LabelOptions priority;
    priority.overlap = OverlapPolicy::Priority;
    priority.priority = {7};
    expectSameOnBoth(spheres, c, priority);
    BuildConfig surface = c;
    surface.surfaceOnly = true;
    expectSameOnBoth(spheres, surface);
  }
}

// Parts of every kind of claim: an open part (three ray axes) beside a
// closed one, a part nested in the open one (inherited Full claims in mixed
// leaves), three labels where the policy orders them differently from their
// input order.
TEST(CudaLabels, OpenNestedAndThreeWayOverlaps) {
  HDT_REQUIRE_CUDA();
  const TriangleMesh mesh = combined({withLabel(openBox({-1, -1, -1}, {0.2, 1, 0.9}), 9),
                                      withLabel(box({-0.6, -0.5, -0.5}, {-0.1, 0.4, 0.3}), 4),
                                      withLabel(icosphere(3, 0.7, {0.4, 0.1, 0}), 2)});
  for (const BuildConfig& c : {grid(128, 4, 8), grid(256, 8, 16)}) {
    expectSameOnBoth(mesh, c);
    LabelOptions highest;
    highest.overlap = OverlapPolicy::Highest;
    expectSameOnBoth(mesh, c, highest);
    LabelOptions priority;
    priority.overlap = OverlapPolicy::Priority;
    priority.priority = {4, 9};
    expectSameOnBoth(mesh, c, priority);
  }
}

// A part whose triangles are all degenerate (none left after snapping):
// the device path steps aside, and the per-part path does what the CPU does.
// Thin touching slabs, labels out of order: leaves of 2 to 4 labels (palette
// leaves, the palette sorted) and of 5 or more (wide leaves), on both drivers.
TEST(CudaLabels, ManySlabsGivePaletteAndWideLeaves) {
  HDT_REQUIRE_CUDA();
  const Label labels[] = {9, 3, 12, 1, 40, 7, 2, 65535, 5};
  TriangleMesh slabs;
  for (int k = 0; k < 9; ++k) {
    const double x0 = -0.09 + 0.02 * k; // about 2.5 voxels: a 16^3 leaf meets 6 or 7 slabs
    const TriangleMesh slab = withLabel(box({x0, -0.5, -0.5}, {x0 + 0.02, 0.5, 0.5}), labels[k]);
    slabs = k == 0 ? slab : combined({slabs, slab});
  }
  size_t wide = 0, palette = 0;
  for (int leafSize : {8, 16}) {
    const BuildConfig config = grid(128, 2, leafSize);
    const Volume cpu = voxelizeLabelled(slabs, config, cpuOptions());
    for (const LeafPalette& p : cpu.labels.palettes) (p.isWide() ? wide : palette) += 1;
    expectSameOnBoth(slabs, config);
  }
  EXPECT_GT(wide, 0u) << "no leaf of 5 labels or more";
  EXPECT_GT(palette, 0u) << "no palette leaf";
}

TEST(CudaLabels, PartWithoutTrianglesFallsBack) {
  HDT_REQUIRE_CUDA();
  TriangleMesh flat;
  flat.points = {0, 0, 0, 0.5, 0, 0, 1, 0, 0};
  flat.triangles = {0, 1, 2};
  const TriangleMesh mesh = combined({withLabel(box({-1, -1, -1}, {1, 1, 1}), 1), withLabel(flat, 2)});
  PathLog log;
  std::string cpuError, gpuError;
  Volume cpu, gpu;
  try {
    cpu = voxelizeLabelled(mesh, grid(128, 4, 8), cpuOptions());
  } catch (const Error& e) {
    cpuError = e.what();
  }
  try {
    gpu = voxelizeLabelled(mesh, grid(128, 4, 8), log.options(cudaOptions()));
  } catch (const Error& e) {
    gpuError = e.what();
  }
  EXPECT_FALSE(log.onDevice()) << log.text;
  EXPECT_EQ(gpuError, cpuError);
  if (cpuError.empty()) EXPECT_TRUE(sameLabelled(gpu, cpu));
}

// The number of part builds a device labelled build logged (-1: none).
int partBuildsLogged(const std::string& log) {
  const size_t at = log.find(" part builds combined on the device");
  if (at == std::string::npos) return -1;
  const size_t in = log.rfind(" in ", at);
  return std::stoi(log.substr(in + 4, at - in - 4));
}

// Parts far enough apart (no cell in common) share device builds: eight
// separate spheres (labels out of input order) and an open box share one; a
// sphere nested in one of them needs another, which a second open box
// (not two open parts in one build) joins. The bytes stay the CPU's
// (per-part builds), solid and surface only.
TEST(CudaLabels, SeparatePartsShareBuilds) {
  HDT_REQUIRE_CUDA();
  const Label labels[] = {5, 2, 8, 1, 7, 3, 6, 4};
  TriangleMesh mesh;
  for (int k = 0; k < 8; ++k) {
    const Vec3 centre{k & 1 ? 0.5 : -0.5, k & 2 ? 0.5 : -0.5, k & 4 ? 0.5 : -0.5};
    const TriangleMesh sphere = withLabel(icosphere(3, 0.2, centre), labels[k]);
    mesh = k == 0 ? sphere : combined({mesh, sphere});
  }
  mesh = combined({mesh, withLabel(icosphere(3, 0.1, {0.5, -0.5, -0.5}), 9),
                   withLabel(openBox({-0.7, -0.1, -0.1}, {-0.4, 0.1, 0.1}), 10),
                   withLabel(openBox({0.4, -0.1, -0.1}, {0.7, 0.1, 0.1}), 11)});
  for (bool surfaceOnly : {false, true}) {
    BuildConfig c = grid(256, 8, 16);
    c.surfaceOnly = surfaceOnly;
    expectSameOnBoth(mesh, c);
    PathLog log;
    BuildOptions o = log.options(cudaOptions());
    std::vector<double> progress; // reported fractions: rise from 0 to 1 over the part builds
    o.progress = [&](double f, const char*) {
      progress.push_back(f);
      return true;
    };
    voxelizeLabelled(mesh, c, o);
    EXPECT_EQ(partBuildsLogged(log.text), 2) << log.text;
    ASSERT_FALSE(progress.empty());
    EXPECT_TRUE(std::is_sorted(progress.begin(), progress.end()));
    EXPECT_GE(progress.front(), 0.0);
    EXPECT_DOUBLE_EQ(progress.back(), 1.0);
    LabelOptions highest;
    highest.overlap = OverlapPolicy::Highest;
    expectSameOnBoth(mesh, c, highest);
  }
}

// A label 0 (reserved for outside) fails as on the CPU, though the device
// path splits the parts while it builds the whole mesh.
TEST(CudaLabels, LabelZeroFailsAsOnTheCpu) {
  HDT_REQUIRE_CUDA();
  TriangleMesh mesh = combined({withLabel(box({-1, -1, -1}, {0, 1, 1}), 1), withLabel(box({0, -1, -1}, {1, 1, 1}), 2)});
  mesh.triangleLabels[3] = kOutsideLabel;
  for (Backend backend : {Backend::Cuda, Backend::Auto}) {
    BuildOptions o = cudaOptions();
    o.backend = backend;
    try {
      voxelizeLabelled(mesh, grid(128, 4, 8), o);
      ADD_FAILURE() << "label 0 accepted";
    } catch (const Error& e) {
      EXPECT_NE(std::string(e.what()).find("reserved for outside"), std::string::npos) << e.what();
    }
  }
}

// A mesh of one label: built once and labelled (labelAsOnePart) on both
// drivers, it is the device combination of its one part (buildLabelledCuda)
// and the CPU's combined part, byte for byte; closed and open, solid and
// surface only, at two leaf sizes.
TEST(CudaLabels, OnePartFastPathIsTheDeviceCombination) {
  HDT_REQUIRE_CUDA();
  const TriangleMesh meshes[] = {withLabel(icosphere(4, 0.8, {0.1, -0.2, 0.05}), 5),
                                 withLabel(openBox({-0.7, -0.6, -0.5}, {0.6, 0.5, 0.7}), 300)};
  for (const TriangleMesh& mesh : meshes) {
    const Label label = mesh.triangleLabels[0];
    for (bool surfaceOnly : {false, true}) {
      for (const BuildConfig& base : {grid(128, 4, 8), grid(256, 8, 16)}) {
        BuildConfig c = base;
        c.surfaceOnly = surfaceOnly;
        PathLog log;
        const Volume fastGpu = voxelizeLabelled(mesh, c, log.options(cudaOptions()));
        EXPECT_FALSE(log.onDevice()) << "the one-part mesh ran the general path: " << log.text;
        const Volume fastCpu = voxelizeLabelled(mesh, c, cpuOptions());
        BuildConfig surface = c;
        surface.surfaceOnly = true;
        Volume generalGpu;
        ASSERT_TRUE(buildLabelledCuda(prepareMesh(mesh, surface), {prepareMesh(mesh, c)}, {label}, {}, cudaOptions(),
                                      generalGpu));
        const Volume generalCpu = combineLabelledParts({voxelize(mesh, c, cpuOptions())}, {label}, {});
        // (sameLabelled: a CUDA volume first.)
        EXPECT_TRUE(sameLabelled(generalGpu, generalCpu));
        EXPECT_TRUE(sameLabelled(fastGpu, generalCpu));
        EXPECT_TRUE(sameLabelled(generalGpu, fastCpu));
        EXPECT_EQ(fastGpu.labels.mixedIndex, generalGpu.labels.mixedIndex);
        EXPECT_EQ(fastGpu.insideTest, generalGpu.insideTest);
        EXPECT_EQ(fastGpu.closedMesh, generalGpu.closedMesh);
      }
    }
  }
}

TEST(CudaLabels, SharedMeshesByComponents) {
  HDT_REQUIRE_CUDA();
  const std::string dir = sharedMeshesDir();
  int done = 0;
  for (const char* name : {"cycloidal-drive.ply", "ogre.obj", "bracket.stl"}) {
    std::string path = dir + "/" + name;
    struct stat st;
    if (::stat(path.c_str(), &st) != 0) { // the GPU machine carries the meshes as binary PLY
      path = path.substr(0, path.rfind('.')) + ".ply";
      if (::stat(path.c_str(), &st) != 0) continue;
    }
    if (path.find(".ply") == std::string::npos && !readsAllMeshFormats()) continue;
    const TriangleMesh mesh = readMesh(path, {MeshLabelSource::Kind::Components, ""});
    SCOPED_TRACE(name);
    expectSameOnBoth(mesh, grid(512, 16, 16));
    expectSameOnBoth(mesh, grid(1024, 16, 16));
    ++done;
  }
  if (done == 0) GTEST_SKIP() << "no shared meshes in " << dir;
}

} // namespace
} // namespace test
} // namespace hdt
