// Part labels (issue 17, hdt/labels.hpp) against a brute-force reference: each
// part voxelized densely on its own by the test oracle (reference_voxelizer),
// the union and the overlap policy applied voxel by voxel here.
#include "hdt/builder.hpp"
#include "hdt/dense.hpp"
#include "hdt/error.hpp"
#include "hdt/hdt_file.hpp"
#include "hdt/labels.hpp"
#include "hdt/mesh.hpp"
#include "hdt/mesh_io.hpp"
#include "support/format_volumes.hpp"
#include "support/reference_voxelizer.hpp"
#include "support/shapes.hpp"

#include <gtest/gtest.h>

#include <algorithm>
#include <array>
#include <fstream>
#include <map>

namespace hdt {
namespace test {
namespace {

constexpr int kN = 64;

struct Part {
  Label label;
  TriangleMesh mesh;
};

TriangleMesh labelledMesh(const std::vector<Part>& parts) {
  TriangleMesh all;
  for (const Part& p : parts) {
    append(all, p.mesh);
    all.triangleLabels.insert(all.triangleLabels.end(), p.mesh.triangleCount(), p.label);
  }
  return all;
}

// The unit-voxel frame of shapes.hpp: voxel size 1, voxel i spans [i - N/2, i + 1 - N/2].
BuildConfig unitFrame(int n = kN, int rootGrid = 2, int leafSize = 8) {
  BuildConfig c;
  c.resolution = n;
  c.rootGrid = rootGrid;
  c.leafSize = leafSize;
  c.hasBounds = true;
  const double b = (n - 2) / 2.0;
  c.boundsMin = {-b, -b, -b};
  c.boundsMax = {b, b, b};
  return c;
}

BuildOptions cpu(int threads = 0) {
  BuildOptions o;
  o.backend = Backend::Cpu;
  o.threads = threads;
  return o;
}

Vec3 plane3(int x, int y, int z) { return {voxelPlane(kN, x), voxelPlane(kN, y), voxelPlane(kN, z)}; }

// The reference: states and labels of every voxel, from each part's dense
// reference volume on the same grid.
struct ReferenceLabels {
  std::vector<uint8_t> state;
  std::vector<Label> label;
};

ReferenceLabels referenceLabels(const std::vector<Part>& parts, const BuildConfig& config,
                                const LabelOptions& options) {
  BuildConfig placed = config;
  if (!placed.hasBounds) {
    meshBounds(labelledMesh(parts), placed.boundsMin, placed.boundsMax);
    placed.hasBounds = true;
  }
  const size_t n3 = size_t(config.resolution) * config.resolution * config.resolution;
  ReferenceLabels ref{std::vector<uint8_t>(n3, 0), std::vector<Label>(n3, 0)};
  // Rank by the policy, written out here independently of LabelRanking.
  auto rank = [&](Label l) -> long {
    if (options.overlap == OverlapPolicy::Highest) return -long(l);
    if (options.overlap == OverlapPolicy::Priority) {
      const auto it = std::find(options.priority.begin(), options.priority.end(), l);
      if (it != options.priority.end()) return long(it - options.priority.begin()) - 100000;
    }
    return long(l);
  };
  for (const Part& p : parts) {
    const ReferenceVoxels r = referenceVoxelize(prepareMesh(p.mesh, placed), config.surfaceOnly);
    for (size_t i = 0; i < n3; ++i) {
      const uint8_t s = r.state[i];
      if (s == 0) continue;
      // Surface (2) beats Inside (1); within a state the policy decides.
      if (s > ref.state[i] || (s == ref.state[i] && rank(p.label) < rank(ref.label[i]))) {
        ref.state[i] = s;
        ref.label[i] = p.label;
      }
    }
  }
  return ref;
}

::testing::AssertionResult matchesReference(const Volume& v, const ReferenceLabels& ref) {
  const int n = v.grid.resolution;
  size_t wrong = 0;
  std::string first;
  for (int z = 0; z < n; ++z)
    for (int y = 0; y < n; ++y)
      for (int x = 0; x < n; ++x) {
        const size_t i = size_t(x) + size_t(n) * (size_t(y) + size_t(n) * size_t(z));
        const VoxelState s = voxelAt(v, x, y, z);
        const Label l = labelAt(v, x, y, z);
        if (uint8_t(s) != ref.state[i] || l != ref.label[i]) {
          if (wrong++ == 0) {
            first = "voxel (" + std::to_string(x) + "," + std::to_string(y) + "," + std::to_string(z) +
                    "): state " + std::to_string(int(s)) + " label " + std::to_string(l) + ", expected " +
                    std::to_string(int(ref.state[i])) + " / " + std::to_string(ref.label[i]);
          }
        }
      }
  if (wrong == 0) return ::testing::AssertionSuccess();
  return ::testing::AssertionFailure() << wrong << " voxels differ; first " << first;
}

// Per-label counts add up to the volume's counts.
void expectCountsAddUp(const Volume& v) {
  uint64_t surface = 0, inside = 0;
  for (const LabelStatistics& s : labelStatistics(v)) {
    surface += s.surfaceVoxels;
    inside += s.insideVoxels;
  }
  EXPECT_EQ(surface, v.stats.activeVoxels);
  EXPECT_EQ(inside, v.stats.insideVoxels);
}

Volume buildLabelled(const std::vector<Part>& parts, const BuildConfig& config, const LabelOptions& options,
                     const BuildOptions& build = cpu()) {
  Volume v = voxelizeLabelled(labelledMesh(parts), config, build, options);
  validateVolume(v);
  return v;
}

LabelOptions policy(OverlapPolicy p, std::vector<Label> priority = {}) {
  LabelOptions o;
  o.overlap = p;
  o.priority = std::move(priority);
  return o;
}

std::vector<Part> touchingCubes() {
  return {{1, box(plane3(16, 20, 20), plane3(32, 40, 40))}, {2, box(plane3(32, 20, 20), plane3(48, 40, 40))}};
}

TEST(Labels, TouchingCubesShareTheFaceByThePolicy) {
  const std::vector<Part> parts = touchingCubes();
  for (OverlapPolicy p : {OverlapPolicy::Lowest, OverlapPolicy::Highest}) {
    const Volume v = buildLabelled(parts, unitFrame(), policy(p));
    EXPECT_TRUE(matchesReference(v, referenceLabels(parts, unitFrame(), policy(p))));
    // The shared face x = plane 32 touches voxels 31 and 32: both are surface of both cubes.
    const Label winner = p == OverlapPolicy::Lowest ? 1 : 2;
    EXPECT_EQ(labelAt(v, 31, 30, 30), winner);
    EXPECT_EQ(labelAt(v, 32, 30, 30), winner);
    EXPECT_EQ(labelAt(v, 30, 30, 30), 1); // inside the first cube
    EXPECT_EQ(labelAt(v, 40, 30, 30), 2);
    EXPECT_EQ(labelAt(v, 50, 30, 30), 0);
    expectCountsAddUp(v);
  }
  // Disjoint interiors: the union is the unlabelled build of the whole mesh, byte for byte.
  const Volume labelled = buildLabelled(parts, unitFrame(), {});
  const Volume plain = voxelize(labelledMesh(parts), unitFrame(), cpu());
  EXPECT_EQ(firstDifference(plain, labelled), "");
  EXPECT_GT(labelled.labels.palettes.size(), 0u) << "the shared face's leaves hold two labels";
}

// The split into parts renumbers each part's points: a mesh whose labels
// share point indices and interleave in triangle order gives the volume of
// the same parts with points of their own.
TEST(Labels, PartsSharingPointsAndInterleavedSplitCleanly) {
  const std::vector<Part> parts = touchingCubes();
  const TriangleMesh separate = labelledMesh(parts);
  TriangleMesh shared;
  std::map<std::array<double, 3>, uint32_t> index; // one point per position
  for (size_t p = 0; p < separate.pointCount(); ++p) {
    const std::array<double, 3> x = {separate.points[3 * p], separate.points[3 * p + 1], separate.points[3 * p + 2]};
    if (index.emplace(x, uint32_t(shared.pointCount())).second) shared.points.insert(shared.points.end(), x.begin(), x.end());
  }
  const size_t n = separate.triangleCount(), half = parts[0].mesh.triangleCount();
  std::vector<size_t> order; // the two parts' triangles alternate
  for (size_t i = 0; i < std::max(half, n - half); ++i) {
    if (i < half) order.push_back(i);
    if (half + i < n) order.push_back(half + i);
  }
  for (size_t t : order) {
    for (int c = 0; c < 3; ++c) {
      const uint32_t p = separate.triangles[3 * t + size_t(c)];
      shared.triangles.push_back(index.at({separate.points[3 * p], separate.points[3 * p + 1], separate.points[3 * p + 2]}));
    }
    shared.triangleLabels.push_back(separate.triangleLabels[t]);
  }
  ASSERT_LT(shared.pointCount(), separate.pointCount()) << "the cubes' shared face shares no point";
  const Volume a = voxelizeLabelled(separate, unitFrame(), cpu());
  const Volume b = voxelizeLabelled(shared, unitFrame(), cpu());
  EXPECT_EQ(firstDifference(a, b), "");
  EXPECT_EQ(a.labels.elementLabels, b.labels.elementLabels);
  EXPECT_TRUE(unpackVoxelLabels(a) == unpackVoxelLabels(b));
  EXPECT_TRUE(a.labels.palettes == b.labels.palettes && a.labels.paletteIndices == b.labels.paletteIndices);
  EXPECT_TRUE(matchesReference(b, referenceLabels(parts, unitFrame(), {})));
}

TEST(Labels, NestedPartKeepsItsLabelUnderHighestAndPriority) {
  const std::vector<Part> parts = {{1, box(plane3(8, 8, 8), plane3(56, 56, 56))},
                                   {2, box(plane3(24, 24, 24), plane3(40, 40, 40))}};
  for (const LabelOptions& o : {policy(OverlapPolicy::Lowest), policy(OverlapPolicy::Highest),
                                policy(OverlapPolicy::Priority, {2})}) {
    const Volume v = buildLabelled(parts, unitFrame(), o);
    EXPECT_TRUE(matchesReference(v, referenceLabels(parts, unitFrame(), o)));
    const bool innerWins = o.overlap != OverlapPolicy::Lowest;
    EXPECT_EQ(labelAt(v, 32, 32, 32), innerWins ? 2 : 1); // inside both
    EXPECT_EQ(labelAt(v, 24, 32, 32), 2);                 // the inner surface: only part 2 touches it
    EXPECT_EQ(voxelAt(v, 32, 32, 32), VoxelState::Inside); // each part is a solid: no parity cancelling
    EXPECT_EQ(labelAt(v, 12, 32, 32), 1);
    expectCountsAddUp(v);
  }
}

TEST(Labels, OverlappingSpheresUnderEachPolicy) {
  const std::vector<Part> parts = {{3, icosphere(2, 14, {-6, 0, 0})}, {7, icosphere(2, 14, {6, 0, 0})},
                                   {5, icosphere(1, 6, {0, 0, 20})}};
  BuildConfig config = unitFrame();
  for (const LabelOptions& o :
       {policy(OverlapPolicy::Lowest), policy(OverlapPolicy::Highest), policy(OverlapPolicy::Priority, {7, 3}),
        policy(OverlapPolicy::Priority, {5})}) {
    const Volume v = buildLabelled(parts, config, o);
    EXPECT_TRUE(matchesReference(v, referenceLabels(parts, config, o)));
    const Label overlap = labelAt(v, 32, 32, 32); // the centre lies in both big spheres
    const Label expected = o.overlap == OverlapPolicy::Highest ? 7
                           : o.overlap == OverlapPolicy::Priority && o.priority[0] == 7 ? 7
                                                                                        : 3;
    EXPECT_EQ(overlap, expected);
    expectCountsAddUp(v);
  }
}

TEST(Labels, FreePlacementSurfaceOnlyAndLeafSizes) {
  const std::vector<Part> parts = {{1, icosphere(2, 1.0, {0, 0, 0})}, {2, torus(1.2, 0.3, 24, 12, {0, 0, 0.2})},
                                   {9, box({-0.3, -0.3, -1.4}, {0.3, 0.3, 1.4})}};
  for (bool surfaceOnly : {false, true}) {
    for (int L : {8, 16}) {
      BuildConfig c;
      c.resolution = 64;
      c.rootGrid = 2;
      c.leafSize = L;
      c.surfaceOnly = surfaceOnly;
      const Volume v = buildLabelled(parts, c, {});
      EXPECT_TRUE(matchesReference(v, referenceLabels(parts, c, {}))) << "L " << L << " surfaceOnly " << surfaceOnly;
      expectCountsAddUp(v);
    }
  }
}

// A mesh of one label: voxelizeLabelled builds it once and labels it
// (labelAsOnePart). The general path's volume is that one part's build
// combined (combineLabelledParts): the same tree, leaf words, labels, names
// and file bytes, and the reference's voxels; closed, open (Auto picks the
// winding number), surface only, a part with unused points.
TEST(Labels, OnePartFastPathIsTheCombinedPart) {
  TriangleMesh open = box(plane3(10, 12, 14), plane3(50, 44, 40));
  open.triangles.resize(open.triangles.size() - 6); // the last face's two triangles: open
  TriangleMesh sphere = icosphere(3, 20, {1.3, -0.7, 0.4});
  sphere.points.insert(sphere.points.end(), {0.0, 0.0, 0.0}); // used by no triangle
  for (const TriangleMesh* shape : {&sphere, &open}) {
    for (bool surfaceOnly : {false, true}) {
      BuildConfig config = unitFrame(kN, 2, 8);
      config.surfaceOnly = surfaceOnly;
      TriangleMesh mesh = *shape;
      mesh.triangleLabels.assign(mesh.triangleCount(), 7);
      mesh.labelNames = {{7, "part"}, {9, "named, no triangle"}};
      ASSERT_EQ(onlyLabel(mesh), 7);
      const Volume fast = voxelizeLabelled(mesh, config, cpu());
      Volume general = combineLabelledParts({voxelize(mesh, config, cpu())}, {7}, {});
      general.labels.names = {{7, "part"}, {9, "named, no triangle"}};
      validateVolume(fast);
      EXPECT_EQ(firstDifference(general, fast), "");
      const LabelField &f = fast.labels, &g = general.labels;
      EXPECT_EQ(f.elementLabels, g.elementLabels);
      EXPECT_TRUE(f.palettes.empty() && g.palettes.empty());
      EXPECT_EQ(f.mixedIndex, g.mixedIndex);
      EXPECT_EQ(f.mixedBlock, g.mixedBlock);
      EXPECT_EQ(f.names, g.names);
      EXPECT_EQ(fast.insideTest, general.insideTest);
      EXPECT_EQ(fast.closedMesh, general.closedMesh);
      EXPECT_EQ(fast.stats.activeVoxels, general.stats.activeVoxels);
      EXPECT_EQ(fast.stats.insideVoxels, general.stats.insideVoxels);
      // The file's statistics section holds timings and peak memory: those aside, the same bytes.
      const auto fileOf = [](Volume v) {
        v.stats.time = {};
        v.stats.peakHostBytes = v.stats.peakDeviceBytes = 0;
        return serializeHdt(v, {});
      };
      EXPECT_TRUE(fileOf(fast) == fileOf(general)) << "the .hdt bytes differ";
      EXPECT_TRUE(matchesReference(fast, referenceLabels({{7, *shape}}, config, {})));
      expectCountsAddUp(fast);
    }
  }
  TriangleMesh two = sphere;
  two.triangleLabels.assign(two.triangleCount(), 7);
  two.triangleLabels.back() = 8;
  EXPECT_EQ(onlyLabel(two), kOutsideLabel);
  two.triangleLabels.assign(two.triangleCount(), kOutsideLabel);
  EXPECT_EQ(onlyLabel(two), kOutsideLabel); // refused by the general path
}

// The parts prepared beforehand (prepareLabelledParts, as hdt-voxelize
// does) and the whole mesh prepared solid: the same volume and names as
// voxelizeLabelled of the mesh; free placement and the unit frame.
TEST(Labels, PartsPreparedBeforehandGiveTheSameVolume) {
  TriangleMesh mesh = labelledMesh({{3, icosphere(2, 14, {-6, 0, 0})}, {7, icosphere(2, 14, {6, 0, 0})},
                                    {5, icosphere(1, 6, {0, 0, 20})}});
  mesh.labelNames = {{3, "left"}, {5, "top"}};
  BuildConfig free;
  free.resolution = kN;
  free.rootGrid = 2;
  free.leafSize = 8;
  for (const BuildConfig& config : {unitFrame(), free}) {
    const LabelOptions o = policy(OverlapPolicy::Highest);
    const Volume expected = voxelizeLabelled(mesh, config, cpu(), o);
    const Volume v =
        voxelizeLabelled(prepareMesh(mesh, config), prepareLabelledParts(mesh, config), mesh.labelNames, cpu(), o);
    EXPECT_EQ(firstDifference(expected, v), "");
    EXPECT_EQ(v.labels.elementLabels, expected.labels.elementLabels);
    EXPECT_TRUE(unpackVoxelLabels(v) == unpackVoxelLabels(expected));
    EXPECT_EQ(v.labels.names, expected.labels.names);
    EXPECT_EQ(v.labels.names.at(5), "top");
  }
}

TEST(Labels, SameBytesWhateverTheThreadCount) {
  const std::vector<Part> parts = {{3, icosphere(2, 14, {-6, 0, 0})}, {7, icosphere(2, 14, {6, 0, 0})}};
  const std::vector<uint8_t> one = serializeHdt(buildLabelled(parts, unitFrame(), {}, cpu(1)));
  const std::vector<uint8_t> two = serializeHdt(buildLabelled(parts, unitFrame(), {}, cpu(2)));
  const std::vector<uint8_t> many = serializeHdt(buildLabelled(parts, unitFrame(), {}, cpu(7)));
  // Times and thread counts differ: compare everything but the statistics section.
  const auto strip = [](const std::vector<uint8_t>& b) {
    HdtImage im = parseHdtImage(b);
    im.sections.erase(im.sections.begin() + 1);
    return assembleHdtImage(im);
  };
  EXPECT_TRUE(strip(one) == strip(two));
  EXPECT_TRUE(strip(one) == strip(many));
}

TEST(Labels, StatisticsAndNames) {
  std::vector<Part> parts = touchingCubes();
  TriangleMesh mesh = labelledMesh(parts);
  mesh.labelNames = {{1, "left"}, {2, "right"}, {4, "unused"}};
  const Volume v = voxelizeLabelled(mesh, unitFrame(), cpu());
  const std::vector<LabelStatistics> table = labelStatistics(v);
  ASSERT_EQ(table.size(), 3u);
  EXPECT_EQ(table[0].name, "left");
  EXPECT_EQ(table[2].label, 4);
  EXPECT_EQ(table[2].surfaceVoxels + table[2].insideVoxels, 0u);
  // Each cube is 16 x 20 x 20 voxels; the face planes' voxels on both sides are surface.
  const double occupied = double(table[0].surfaceVoxels + table[0].insideVoxels);
  EXPECT_GE(occupied, 16.0 * 20 * 20);
  EXPECT_LE(occupied, 18.0 * 22 * 22);
  EXPECT_DOUBLE_EQ(table[0].volume, occupied); // voxel size 1
  const LabelField& f = v.labels;
  EXPECT_EQ(labelFieldBytes(v), f.elementLabels.size() * 2 + f.palettes.size() * 8 + f.paletteIndices.size() * 4 +
                                    f.wideLabels.size() * 2 + (f.mixedIndex.size() + f.mixedBlock.size()) * 4);
}

TEST(Labels, SurfaceAreaEstimateOfASphere) {
  const double r = 25;
  const Volume v = buildLabelled({{1, icosphere(4, r)}}, unitFrame(), {});
  const std::vector<LabelStatistics> table = labelStatistics(v);
  ASSERT_EQ(table.size(), 1u);
  const double area = 4 * 3.14159265358979 * r * r;
  EXPECT_NEAR(table[0].surfaceArea / area, 1.0, 0.1);
}

TEST(Labels, BuildsRoundTripThroughTheFile) {
  TriangleMesh mesh = labelledMesh(touchingCubes());
  mesh.labelNames = {{1, "left"}, {2, "right"}};
  const Volume v = voxelizeLabelled(mesh, unitFrame(), cpu());
  for (bool zstd : {false, true}) {
    HdtWriteOptions o;
    o.compressLeaves = zstd;
    const std::vector<uint8_t> b = serializeHdt(v, o);
    const Volume back = deserializeHdt(b.data(), b.size());
    expectSameVolume(v, back, zstd ? "zstd" : "raw");
    EXPECT_EQ(labelAt(back, 31, 30, 30), 1);
    const std::string path = tempPath("labels_roundtrip.hdt"); // the file reader's path too
    writeHdt(v, path, o);
    expectSameVolume(v, readHdt(path), zstd ? "zstd file" : "raw file");
    std::remove(path.c_str());
  }
}

void writeText(const std::string& path, const std::string& text) {
  std::ofstream(path, std::ios::binary) << text;
}

// Two unit boxes as OBJ faces (1-based indices), in groups or materials.
std::string twoBoxObj(const std::string& firstHead, const std::string& secondHead) {
  std::string obj;
  for (int b = 0; b < 2; ++b) {
    for (int i = 0; i < 8; ++i)
      obj += "v " + std::to_string((i & 1) + 2 * b) + " " + std::to_string((i >> 1) & 1) + " " +
             std::to_string((i >> 2) & 1) + "\n";
  }
  const int quads[6][4] = {{0, 2, 3, 1}, {4, 5, 7, 6}, {0, 1, 5, 4}, {2, 6, 7, 3}, {0, 4, 6, 2}, {1, 3, 7, 5}};
  for (int b = 0; b < 2; ++b) {
    obj += b == 0 ? firstHead : secondHead;
    for (const auto& q : quads) {
      obj += "f";
      for (int k : q) obj += " " + std::to_string(k + 1 + 8 * b);
      obj += "\n";
    }
  }
  return obj;
}

TEST(MeshLabels, ObjGroupsAndMaterials) {
  if (!readsAllMeshFormats()) GTEST_SKIP() << "built without assimp: no OBJ reader";
  const std::string path = tempPath("labels_groups.obj");
  writeText(path, twoBoxObj("g wheel\n", "g axle\n"));
  TriangleMesh m = readMesh(path, {MeshLabelSource::Kind::ObjGroup, ""});
  ASSERT_EQ(m.triangleCount(), 24u);
  ASSERT_EQ(m.triangleLabels.size(), 24u);
  // Each box's triangles carry one label, the two boxes different ones, named after the groups.
  for (size_t t = 0; t < 24; ++t) {
    const bool secondBox = m.points[3 * m.triangles[3 * t]] > 1.5; // x of a corner
    EXPECT_EQ(m.labelNames.at(m.triangleLabels[t]), secondBox ? "axle" : "wheel") << t;
  }
  const std::string mtl = tempPath("labels_materials.obj");
  writeText(mtl, twoBoxObj("usemtl steel\n", "usemtl brass\n"));
  m = readMesh(mtl, {MeshLabelSource::Kind::ObjMaterial, ""});
  ASSERT_EQ(m.triangleLabels.size(), 24u);
  for (size_t t = 0; t < 24; ++t) {
    const bool secondBox = m.points[3 * m.triangles[3 * t]] > 1.5; // x of a corner
    EXPECT_EQ(m.labelNames.at(m.triangleLabels[t]), secondBox ? "brass" : "steel") << t;
  }
  EXPECT_THROW(readMesh(path, {MeshLabelSource::Kind::PlyFaceProperty, "part"}), Error);
  std::remove(path.c_str());
  std::remove(mtl.c_str());
}

TEST(MeshLabels, PlyFacePropertyAndComponents) {
  const std::string path = tempPath("labels_faces.ply");
  // Two triangles and a quad (two triangles) with labels 7, 3, 9.
  writeText(path, "ply\nformat ascii 1.0\nelement vertex 5\nproperty float x\nproperty float y\n"
                  "property float z\nelement face 3\nproperty list uchar int vertex_indices\n"
                  "property ushort part\nend_header\n0 0 0\n1 0 0\n0 1 0\n0 0 1\n1 1 1\n"
                  "3 0 1 2 7\n3 0 1 3 3\n4 1 2 3 4 9\n");
  TriangleMesh m = readMesh(path, {MeshLabelSource::Kind::PlyFaceProperty, "part"});
  EXPECT_EQ(m.triangleLabels, (std::vector<Label>{7, 3, 9, 9}));
  EXPECT_THROW(readMesh(path, {MeshLabelSource::Kind::PlyFaceProperty, "missing"}), Error);
  writeText(path, "ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\nproperty float y\n"
                  "property float z\nelement face 1\nproperty list uchar int vertex_indices\n"
                  "property int part\nend_header\n0 0 0\n1 0 0\n0 1 0\n3 0 1 2 0\n");
  try {
    readMesh(path, {MeshLabelSource::Kind::PlyFaceProperty, "part"});
    ADD_FAILURE() << "label 0 accepted";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("labels are 1 to 65535"), std::string::npos) << e.what();
  }
  std::remove(path.c_str());

  // Two apart boxes (touching ones would share positions, hence one component).
  TriangleMesh parts = labelledMesh({{1, box(plane3(8, 8, 8), plane3(16, 16, 16))}, {2, box(plane3(40, 8, 8), plane3(48, 16, 16))}});
  parts.triangleLabels.clear();
  labelConnectedComponents(parts);
  for (size_t t = 0; t < parts.triangleCount(); ++t) EXPECT_EQ(parts.triangleLabels[t], t < 12 ? 1 : 2);
  // A triangle soup (every triangle its own points, as STL gives) connects by position.
  TriangleMesh soup;
  for (size_t t = 0; t < parts.triangleCount(); ++t) {
    for (int c = 0; c < 3; ++c) {
      const uint32_t p = parts.triangles[3 * t + size_t(c)];
      soup.points.insert(soup.points.end(), parts.points.begin() + 3 * p, parts.points.begin() + 3 * p + 3);
      soup.triangles.push_back(uint32_t(3 * t + size_t(c)));
    }
  }
  labelConnectedComponents(soup);
  for (size_t t = 0; t < soup.triangleCount(); ++t) EXPECT_EQ(soup.triangleLabels[t], t < 12 ? 1 : 2) << t;
}

TEST(Labels, DenseLabelsEqualTheWalk) {
  const std::vector<Part> parts = {{3, icosphere(2, 14, {-6, 0, 0})}, {7, icosphere(2, 14, {6, 0, 0})}};
  const Volume v = buildLabelled(parts, unitFrame(), {});
  const std::vector<uint16_t> dense = denseLabels(v);
  ASSERT_EQ(dense.size(), size_t(kN) * kN * kN);
  size_t wrong = 0;
  for (int z = 0; z < kN; ++z)
    for (int y = 0; y < kN; ++y)
      for (int x = 0; x < kN; ++x) wrong += dense[size_t(x) + kN * (size_t(y) + kN * size_t(z))] != labelAt(v, x, y, z);
  EXPECT_EQ(wrong, 0u);
  EXPECT_THROW(denseLabels(voxelize(labelledMesh(parts), unitFrame(), cpu())), Error); // unlabelled
}

TEST(Labels, BadLabelsAreRefused) {
  TriangleMesh mesh = labelledMesh(touchingCubes());
  mesh.triangleLabels.pop_back();
  EXPECT_THROW(voxelizeLabelled(mesh, unitFrame(), cpu()), Error);
  mesh.triangleLabels.push_back(0);
  try {
    voxelizeLabelled(mesh, unitFrame(), cpu());
    ADD_FAILURE() << "label 0 accepted";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("reserved for outside"), std::string::npos) << e.what();
  }
}

} // namespace
} // namespace test
} // namespace hdt
