// Dense export: denseStates against known voxels and against voxelAt, and the
// NRRD file parsed back field by field.
#include "hdt/builder.hpp"
#include "hdt/dense.hpp"
#include "hdt/error.hpp"
#include "hdt/mesh.hpp"
#include "support/format_volumes.hpp"
#include "support/shapes.hpp"

#include <gtest/gtest.h>

#include <cstdio>
#include <cstdlib>
#include <fstream>
#include <iterator>
#include <map>
#include <sstream>

namespace hdt {
namespace test {
namespace {

void setVoxel(uint32_t* words, int L, int x, int y, int z, VoxelState s) {
  const uint32_t v = uint32_t(x + L * (y + L * z));
  words[v >> 4] = (words[v >> 4] & ~(3u << (2 * (v & 15u)))) | (uint32_t(s) << (2 * (v & 15u)));
}

uint8_t leaf0State(int x, int y, int z) {
  if ((x == 0 && y == 0 && z == 0) || (x == 3 && y == 2 && z == 1)) return 2;
  if ((x == 7 && y == 7 && z == 7) || (x == 5 && y == 0 && z == 0)) return 1;
  return 0;
}
uint8_t leaf1State(int x, int y, int z) { return uint8_t((x + 2 * y + z) % 3); }

// R = 2, L = 8, h = 1 (N = 32), root cells of 16 voxels, level-1 elements of 8:
//   root 0 (0,0,0) Full
//   root 1 (1,0,0) Branch -> elements 8..15:
//     child 0 (+0,+0,+0) Boundary, leaf 0   child 3 (+x,+y,+0) Full
//     child 5 (+x,+0,+z) Boundary, leaf 1   the others Empty
//   root 6 (0,1,1) Full; the other roots Empty.
Volume knownVolume() {
  Volume v;
  v.grid.resolution = 32;
  v.grid.rootGrid = 2;
  v.grid.leafSize = 8;
  v.grid.height = 1;
  v.grid.origin = {-1.25, 3.5, 1e-3};
  v.grid.voxelSize = 0.1;
  v.elements.assign(16, makeElement(ElementState::Empty, 0));
  v.elements[0] = makeElement(ElementState::Full, 0);
  v.elements[1] = makeElement(ElementState::Branch, 8);
  v.elements[6] = makeElement(ElementState::Full, 0);
  v.elements[8 + 0] = makeElement(ElementState::Boundary, 0);
  v.elements[8 + 3] = makeElement(ElementState::Full, 0);
  v.elements[8 + 5] = makeElement(ElementState::Boundary, 1);
  v.levelStart = {0, 8, 16};
  v.leafWords.assign(2 * leafWordCount(8), 0);
  for (int z = 0; z < 8; ++z)
    for (int y = 0; y < 8; ++y)
      for (int x = 0; x < 8; ++x) {
        setVoxel(v.leafWords.data(), 8, x, y, z, VoxelState(leaf0State(x, y, z)));
        setVoxel(v.leafWords.data() + leafWordCount(8), 8, x, y, z, VoxelState(leaf1State(x, y, z)));
      }
  computeStructureStatistics(v);
  return v;
}

uint8_t knownState(int x, int y, int z) {
  if (x < 16 && y < 16 && z < 16) return 1;                                      // root 0
  if (x < 16 && y >= 16 && z >= 16) return 1;                                    // root 6
  if (x >= 16 && x < 24 && y < 8 && z < 8) return leaf0State(x - 16, y, z);      // root 1, child 0
  if (x >= 24 && y >= 8 && y < 16 && z < 8) return 1;                            // root 1, child 3
  if (x >= 24 && y < 8 && z >= 8 && z < 16) return leaf1State(x - 24, y, z - 8); // root 1, child 5
  return 0;
}

size_t at(int N, int x, int y, int z) { return size_t(x) + size_t(N) * (size_t(y) + size_t(N) * size_t(z)); }

// Compares every voxel (or every `stride`-th in a scrambled order) with voxelAt.
void expectMatchesVoxelAt(const Volume& v, const std::vector<uint8_t>& dense, int stride = 1) {
  const int N = v.grid.resolution;
  ASSERT_EQ(dense.size(), size_t(N) * N * N);
  size_t mismatches = 0;
  for (int z = 0; z < N; ++z)
    for (int y = 0; y < N; ++y)
      for (int x = 0; x < N; ++x) {
        if ((x * 31 + y * 17 + z) % stride != 0) continue;
        const uint8_t expected = uint8_t(voxelAt(v, x, y, z));
        if (dense[at(N, x, y, z)] != expected && mismatches++ < 5) {
          ADD_FAILURE() << "voxel (" << x << ", " << y << ", " << z << "): dense "
                        << int(dense[at(N, x, y, z)]) << ", voxelAt " << int(expected);
        }
      }
  EXPECT_EQ(mismatches, 0u);
}

TEST(Dense, KnownVoxels) {
  const Volume v = knownVolume();
  const std::vector<uint8_t> dense = denseStates(v);
  ASSERT_EQ(dense.size(), 32u * 32 * 32);
  size_t mismatches = 0;
  for (int z = 0; z < 32; ++z)
    for (int y = 0; y < 32; ++y)
      for (int x = 0; x < 32; ++x)
        if (dense[at(32, x, y, z)] != knownState(x, y, z) && mismatches++ < 5)
          ADD_FAILURE() << "voxel (" << x << ", " << y << ", " << z << ")";
  EXPECT_EQ(mismatches, 0u);
  // A few by hand, x fastest.
  EXPECT_EQ(dense[at(32, 16, 0, 0)], 2);   // leaf 0 (0,0,0)
  EXPECT_EQ(dense[at(32, 19, 2, 1)], 2);   // leaf 0 (3,2,1)
  EXPECT_EQ(dense[at(32, 23, 7, 7)], 1);   // leaf 0 (7,7,7)
  EXPECT_EQ(dense[at(32, 21, 0, 0)], 1);   // leaf 0 (5,0,0)
  EXPECT_EQ(dense[at(32, 0, 31, 31)], 1);  // root 6
  EXPECT_EQ(dense[at(32, 31, 31, 31)], 0); // root 7
  expectMatchesVoxelAt(v, dense);
}

TEST(Dense, RandomVolumesMatchVoxelAt) {
  struct Case {
    int R, L, h;
    bool surfaceOnly;
    double branch;
  };
  const Case cases[] = {{1, 8, 3, false, 0.6},
                        {3, 8, 1, false, 0.5},
                        {2, 32, 0, false, 0.0},
                        {1, 16, 2, true, 0.9},
                        {2, 8, 2, false, 0.3}};
  for (const Case& c : cases) {
    RandomVolumeSpec spec;
    spec.rootGrid = c.R;
    spec.leafSize = c.L;
    spec.height = c.h;
    spec.surfaceOnly = c.surfaceOnly;
    spec.branchChance = c.branch;
    for (uint32_t seed = 1; seed <= 2; ++seed) {
      SCOPED_TRACE("R " + std::to_string(c.R) + " L " + std::to_string(c.L) + " h " + std::to_string(c.h));
      const Volume v = randomVolume(seed, spec);
      expectMatchesVoxelAt(v, denseStates(v));
    }
  }
}

// R = 1 and N = 256: the subtrees are filled in parallel.
TEST(Dense, DeepSingleRootMatchesVoxelAt) {
  RandomVolumeSpec spec;
  spec.rootGrid = 1;
  spec.leafSize = 8;
  spec.height = 5;
  spec.branchChance = 0.55;
  const Volume v = randomVolume(11, spec);
  ASSERT_GT(v.leafCount(), 0u);
  expectMatchesVoxelAt(v, denseStates(v), 5);
}

TEST(Dense, RefusesMoreThan1024) {
  const Volume v = emptyVolume(1, 8, 8); // N = 2048
  try {
    denseStates(v);
    ADD_FAILURE() << "accepted N = 2048";
  } catch (const Error& e) {
    EXPECT_EQ(e.kind(), ErrorKind::InvalidArgument);
  }
  const std::string path = tempPath("format_too_large.nrrd");
  std::remove(path.c_str());
  EXPECT_THROW(writeNrrd(v, path), Error);
  EXPECT_EQ(std::fopen(path.c_str(), "rb"), nullptr);
}

TEST(Dense, RealBuildCountsMatchStatistics) {
  BuildConfig config;
  config.resolution = 64;
  config.rootGrid = 2;
  config.leafSize = 16;
  Volume v;
  try {
    v = buildCpu(prepareMesh(icosphere(3, 1.0), config), BuildOptions{});
  } catch (const std::exception& e) {
    FAIL() << "the CPU builder failed: " << e.what();
  }
  const std::vector<uint8_t> dense = denseStates(v);
  uint64_t counts[3] = {0, 0, 0};
  for (uint8_t s : dense) {
    ASSERT_LE(s, 2);
    ++counts[s];
  }
  EXPECT_EQ(counts[2], v.stats.activeVoxels);
  EXPECT_EQ(counts[1], v.stats.insideVoxels);
  EXPECT_GT(counts[1], 0u);
  expectMatchesVoxelAt(v, dense);
}

// Parses "(a,b,c)" with strtod (exact for the shortest round-trip text).
std::vector<double> parseVector(const std::string& s) {
  std::vector<double> out;
  if (s.size() < 2 || s.front() != '(' || s.back() != ')') return out;
  std::stringstream in(s.substr(1, s.size() - 2));
  std::string item;
  while (std::getline(in, item, ',')) out.push_back(std::strtod(item.c_str(), nullptr));
  return out;
}

TEST(Dense, NrrdHeaderAndPayload) {
  const Volume v = knownVolume();
  const std::string path = tempPath("format_known.nrrd");
  writeNrrd(v, path);
  std::ifstream in(path, std::ios::binary);
  const std::string file((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  std::remove(path.c_str());

  const size_t end = file.find("\n\n");
  ASSERT_NE(end, std::string::npos);
  std::stringstream header(file.substr(0, end + 1));
  std::string line;
  ASSERT_TRUE(std::getline(header, line));
  EXPECT_EQ(line, "NRRD0004");
  std::map<std::string, std::string> fields;
  std::vector<std::string> order;
  while (std::getline(header, line)) {
    if (!line.empty() && line[0] == '#') continue;
    const size_t colon = line.find(": ");
    ASSERT_NE(colon, std::string::npos) << line;
    const std::string key = line.substr(0, colon);
    EXPECT_EQ(fields.count(key), 0u) << "repeated field " << key;
    fields[key] = line.substr(colon + 2);
    order.push_back(key);
  }
  EXPECT_EQ(fields["type"], "uint8");
  EXPECT_EQ(fields["dimension"], "3");
  EXPECT_EQ(fields["space dimension"], "3");
  EXPECT_EQ(fields.count("space"), 0u) << "\"space\" and \"space dimension\" are exclusive";
  EXPECT_EQ(fields["sizes"], "32 32 32");
  EXPECT_EQ(fields["kinds"], "domain domain domain");
  EXPECT_EQ(fields["endian"], "little");
  EXPECT_EQ(fields["encoding"], "raw");

  // Space directions: s along each axis; origin: the centre of voxel (0, 0, 0).
  std::stringstream dirs(fields["space directions"]);
  for (int a = 0; a < 3; ++a) {
    std::string d;
    ASSERT_TRUE(dirs >> d);
    const std::vector<double> vec = parseVector(d);
    ASSERT_EQ(vec.size(), 3u) << d;
    for (int b = 0; b < 3; ++b) EXPECT_EQ(vec[b], a == b ? v.grid.voxelSize : 0.0) << d;
  }
  const std::vector<double> origin = parseVector(fields["space origin"]);
  ASSERT_EQ(origin.size(), 3u);
  for (int a = 0; a < 3; ++a) EXPECT_EQ(origin[a], v.grid.origin[a] + 0.5 * v.grid.voxelSize);

  // Strict readers (teem) want "dimension" before per-axis fields and the
  // space dimension before the space vectors.
  auto pos = [&](const std::string& k) { return std::find(order.begin(), order.end(), k) - order.begin(); };
  EXPECT_LT(pos("dimension"), pos("sizes"));
  EXPECT_LT(pos("dimension"), pos("kinds"));
  EXPECT_LT(pos("space dimension"), pos("space directions"));
  EXPECT_LT(pos("space dimension"), pos("space origin"));

  const std::string payload = file.substr(end + 2);
  const std::vector<uint8_t> dense = denseStates(v);
  ASSERT_EQ(payload.size(), dense.size());
  EXPECT_TRUE(std::equal(dense.begin(), dense.end(), payload.begin(),
                         [](uint8_t a, char b) { return a == uint8_t(b); }));
}

} // namespace
} // namespace test
} // namespace hdt
