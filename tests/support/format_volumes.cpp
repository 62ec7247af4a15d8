#include "support/format_volumes.hpp"

#include "hdt/labels.hpp"

#include <gtest/gtest.h>

#include <algorithm>
#include <cstdlib>
#include <cstring>
#include <random>

namespace hdt {
namespace test {

Volume randomVolume(uint32_t seed, const RandomVolumeSpec& spec) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> unit(0.0, 1.0);
  Volume v;
  GridSpec& g = v.grid;
  g.rootGrid = spec.rootGrid;
  g.leafSize = spec.leafSize;
  g.height = spec.height;
  g.resolution = (spec.rootGrid << spec.height) * spec.leafSize;
  g.origin = {unit(rng) * 20 - 10, unit(rng) * 20 - 10, -unit(rng) * 1e-3};
  g.voxelSize = 0.01 + unit(rng);
  v.surfaceOnly = spec.surfaceOnly;
  v.closedMesh = unit(rng) < 0.5;

  // Level by level, as types.hpp lays it out: the children of the Branches of
  // level k are level k + 1, 8 per Branch, in the order of their parents.
  uint64_t count = uint64_t(g.rootGrid) * g.rootGrid * g.rootGrid;
  uint32_t leaves = 0;
  for (int k = 0; k <= g.height; ++k) {
    v.levelStart.push_back(v.elements.size());
    const uint64_t next = v.elements.size() + count;
    uint64_t branches = 0;
    for (uint64_t i = 0; i < count; ++i) {
      const double r = unit(rng);
      if (k < g.height && r < spec.branchChance) {
        v.elements.push_back(makeElement(ElementState::Branch, uint32_t(next + 8 * branches++)));
      } else if (k == g.height && r < spec.boundaryChance) {
        v.elements.push_back(makeElement(ElementState::Boundary, leaves++));
      } else if (!spec.surfaceOnly && unit(rng) < spec.fullChance) {
        v.elements.push_back(makeElement(ElementState::Full, 0));
      } else {
        v.elements.push_back(makeElement(ElementState::Empty, 0));
      }
    }
    count = 8 * branches;
  }
  v.levelStart.push_back(v.elements.size());

  const uint32_t words = leafWordCount(g.leafSize);
  v.leafWords.resize(size_t(leaves) * words);
  for (uint32_t& w : v.leafWords) {
    w = 0;
    for (int i = 0; i < 16; ++i) {
      uint32_t state = rng() % 3; // Outside, Inside, Surface
      if (spec.surfaceOnly && state == 1) state = 2;
      w |= state << (2 * i);
    }
  }
  computeStructureStatistics(v);
  Statistics& s = v.stats;
  s.triangles = rng() % 100000;
  s.degenerateTriangles = rng() % 10;
  s.time = PhaseTimes{unit(rng), unit(rng) * 10, unit(rng) * 100, 0.0, 123.456};
  s.peakHostBytes = (uint64_t(rng()) << 20) | rng();
  s.peakDeviceBytes = rng() % 2 ? 0 : uint64_t(rng()) << 8;
  s.backend = rng() % 2 ? "cpu" : "cuda";
  s.threads = int(rng() % 64);
  return v;
}

std::vector<Label> labelRandomly(Volume& v, uint32_t seed, int labels) {
  std::mt19937 rng(seed);
  auto label = [&] { return Label(1 + rng() % uint32_t(labels)); };
  LabelField& f = v.labels;
  f = LabelField{};
  f.elementLabels.assign(v.elements.size(), 0);
  std::vector<Label> mixedVoxels; // L^3 per mixed leaf, in leaf order
  const int L = v.grid.leafSize;
  const size_t voxels = size_t(L) * L * L;
  for (size_t i = 0; i < v.elements.size(); ++i) {
    const ElementWord w = v.elements[i];
    if (elementState(w) == ElementState::Full) f.elementLabels[i] = label();
    if (elementState(w) != ElementState::Boundary) continue;
    const uint32_t* leaf = v.leaf(elementPayload(w));
    std::vector<size_t> occupied;
    for (size_t j = 0; j < voxels; ++j)
      if ((leaf[j / 16] >> (2 * (j % 16))) & 3u) occupied.push_back(j);
    if (occupied.size() < 2 || rng() % 2) {
      f.elementLabels[i] = label();
      continue;
    }
    // The leaf's labels: `span` (2 to `labels`) consecutive ones from base + 1,
    // so that leaves of 2 to 4 labels (palette leaves) and of 5 or more
    // (wide leaves, when labels > 4) both occur.
    const uint32_t span = 2 + rng() % uint32_t(std::max(1, labels - 1));
    const uint32_t base = rng() % (uint32_t(labels) - span + 1);
    std::vector<Label> block(voxels, 0);
    for (size_t j : occupied) block[j] = Label(1 + base + rng() % span);
    block[occupied[0]] = Label(1 + base); // at least two labels
    block[occupied[1]] = Label(2 + base);
    mixedVoxels.insert(mixedVoxels.end(), block.begin(), block.end());
  }
  f.names = {{1, "first part"}, {Label(labels), "last"}, {65535, "unused \xc3\xa9"}};
  packVoxelLabels(v, mixedVoxels.data());
  return mixedVoxels;
}

Volume emptyVolume(int rootGrid, int leafSize, int height) {
  Volume v;
  v.grid.rootGrid = rootGrid;
  v.grid.leafSize = leafSize;
  v.grid.height = height;
  v.grid.resolution = (rootGrid << height) * leafSize;
  v.grid.origin = {0, 0, 0};
  v.grid.voxelSize = 1;
  const uint64_t roots = uint64_t(rootGrid) * rootGrid * rootGrid;
  v.elements.assign(roots, makeElement(ElementState::Empty, 0));
  v.levelStart.assign(size_t(height) + 2, roots);
  v.levelStart[0] = 0;
  computeStructureStatistics(v);
  v.stats.backend = "cpu";
  return v;
}

namespace {
bool sameBits(double a, double b) { return std::memcmp(&a, &b, sizeof a) == 0; }
} // namespace

void expectSameVolume(const Volume& e, const Volume& a, const std::string& context) {
  SCOPED_TRACE(context);
  EXPECT_EQ(e.grid.resolution, a.grid.resolution);
  EXPECT_EQ(e.grid.rootGrid, a.grid.rootGrid);
  EXPECT_EQ(e.grid.leafSize, a.grid.leafSize);
  EXPECT_EQ(e.grid.height, a.grid.height);
  for (int i = 0; i < 3; ++i) EXPECT_TRUE(sameBits(e.grid.origin[i], a.grid.origin[i])) << "origin " << i;
  EXPECT_TRUE(sameBits(e.grid.voxelSize, a.grid.voxelSize));
  EXPECT_EQ(e.surfaceOnly, a.surfaceOnly);
  EXPECT_EQ(e.closedMesh, a.closedMesh);
  EXPECT_TRUE(e.elements == a.elements) << "elements differ";
  EXPECT_EQ(e.levelStart, a.levelStart);
  EXPECT_TRUE(e.leafWords == a.leafWords) << "leaf words differ";
  EXPECT_EQ(e.insideTest, a.insideTest);
  EXPECT_TRUE(e.labels.elementLabels == a.labels.elementLabels) << "element labels differ";
  EXPECT_TRUE(e.labels.palettes == a.labels.palettes) << "palettes differ";
  EXPECT_TRUE(e.labels.paletteIndices == a.labels.paletteIndices) << "palette indices differ";
  EXPECT_TRUE(e.labels.wideLabels == a.labels.wideLabels) << "wide labels differ";
  EXPECT_TRUE(e.labels.mixedIndex == a.labels.mixedIndex && e.labels.mixedBlock == a.labels.mixedBlock)
      << "mixed-leaf index differs";
  EXPECT_EQ(e.labels.names, a.labels.names);

  const Statistics &x = e.stats, &y = a.stats;
  EXPECT_EQ(x.triangles, y.triangles);
  EXPECT_EQ(x.degenerateTriangles, y.degenerateTriangles);
  EXPECT_EQ(x.treeElements, y.treeElements);
  EXPECT_EQ(x.leafGrids, y.leafGrids);
  EXPECT_EQ(x.leafVoxels, y.leafVoxels);
  EXPECT_EQ(x.activeVoxels, y.activeVoxels);
  EXPECT_EQ(x.insideVoxels, y.insideVoxels);
  EXPECT_TRUE(sameBits(x.paperBitsPerActiveVoxel, y.paperBitsPerActiveVoxel));
  EXPECT_EQ(x.topologyBytes, y.topologyBytes);
  EXPECT_EQ(x.leafBytes, y.leafBytes);
  EXPECT_TRUE(sameBits(x.time.mapping, y.time.mapping));
  EXPECT_TRUE(sameBits(x.time.branching, y.time.branching));
  EXPECT_TRUE(sameBits(x.time.leaf, y.time.leaf));
  EXPECT_TRUE(sameBits(x.time.classify, y.time.classify));
  EXPECT_TRUE(sameBits(x.time.total, y.time.total));
  EXPECT_EQ(x.peakHostBytes, y.peakHostBytes);
  EXPECT_EQ(x.peakDeviceBytes, y.peakDeviceBytes);
  EXPECT_EQ(x.backend, y.backend);
  EXPECT_EQ(x.threads, y.threads);
}

std::string tempPath(const std::string& fileName) {
  const char* dir = std::getenv("HDT_TEST_TMPDIR");
  std::string d = dir && *dir ? dir : ::testing::TempDir();
  if (!d.empty() && d.back() != '/') d += '/';
  return d + fileName;
}

// ---- container -------------------------------------------------------------------

uint32_t referenceCrc32(const uint8_t* data, size_t size) {
  uint32_t crc = 0xFFFFFFFFu;
  for (size_t i = 0; i < size; ++i) {
    crc ^= data[i];
    for (int k = 0; k < 8; ++k) crc = (crc >> 1) ^ (0xEDB88320u & (0u - (crc & 1u)));
  }
  return ~crc;
}

uint32_t getLe32(const std::vector<uint8_t>& b, size_t at) {
  uint32_t v = 0;
  for (int i = 0; i < 4; ++i) v |= uint32_t(b.at(at + i)) << (8 * i);
  return v;
}
uint64_t getLe64(const std::vector<uint8_t>& b, size_t at) {
  return uint64_t(getLe32(b, at)) | (uint64_t(getLe32(b, at + 4)) << 32);
}
void putLe32(std::vector<uint8_t>& b, size_t at, uint32_t v) {
  for (int i = 0; i < 4; ++i) b.at(at + i) = uint8_t(v >> (8 * i));
}
void putLe64(std::vector<uint8_t>& b, size_t at, uint64_t v) {
  putLe32(b, at, uint32_t(v));
  putLe32(b, at + 4, uint32_t(v >> 32));
}
void putF64(std::vector<uint8_t>& b, size_t at, double v) {
  uint64_t bits;
  std::memcpy(&bits, &v, 8);
  putLe64(b, at, bits);
}

namespace {
constexpr size_t kHeader = 12, kSectionHeader = 28;
}

HdtImage parseHdtImage(const std::vector<uint8_t>& bytes) {
  HdtImage image;
  if (bytes.size() < kHeader) {
    ADD_FAILURE() << "file shorter than its header";
    return image;
  }
  image.fileHeader.assign(bytes.begin(), bytes.begin() + kHeader);
  size_t at = kHeader;
  while (at < bytes.size()) {
    if (bytes.size() - at < kSectionHeader) {
      ADD_FAILURE() << "truncated section header at " << at;
      return image;
    }
    HdtSectionImage s;
    s.id = getLe32(bytes, at);
    s.encoding = getLe32(bytes, at + 4);
    s.stored = getLe64(bytes, at + 8);
    s.raw = getLe64(bytes, at + 16);
    s.crc = getLe32(bytes, at + 24);
    at += kSectionHeader;
    if (s.stored > bytes.size() - at) {
      ADD_FAILURE() << "section " << s.id << " runs past the end";
      return image;
    }
    s.payload.assign(bytes.begin() + at, bytes.begin() + at + s.stored);
    at += s.stored;
    image.sections.push_back(std::move(s));
  }
  return image;
}

std::vector<uint8_t> assembleHdtImage(const HdtImage& image) {
  std::vector<uint8_t> out = image.fileHeader;
  for (const HdtSectionImage& s : image.sections) {
    const size_t at = out.size();
    out.resize(at + kSectionHeader);
    uint64_t stored = s.stored, raw = s.raw;
    uint32_t crc = s.crc;
    if (!s.keepHeader) {
      stored = s.payload.size();
      if (s.encoding == 0) raw = stored;
    }
    putLe32(out, at, s.id);
    putLe32(out, at + 4, s.encoding);
    putLe64(out, at + 8, stored);
    putLe64(out, at + 16, raw);
    out.insert(out.end(), s.payload.begin(), s.payload.end());
    if (!s.keepHeader) {
      // Optional sections (id >= 16): the CRC covers the header's first 24 bytes, then the payload.
      std::vector<uint8_t> covered;
      if (s.id >= 16) covered.assign(out.begin() + at, out.begin() + at + 24);
      covered.insert(covered.end(), s.payload.begin(), s.payload.end());
      crc = referenceCrc32(covered.data(), covered.size());
    }
    putLe32(out, at + 24, crc);
  }
  return out;
}

std::vector<size_t> hdtSectionBoundaries(const std::vector<uint8_t>& bytes) {
  std::vector<size_t> at{0, kHeader};
  size_t p = kHeader;
  while (p + kSectionHeader <= bytes.size()) {
    p += kSectionHeader + size_t(getLe64(bytes, p + 8));
    at.push_back(p);
  }
  return at;
}

} // namespace test
} // namespace hdt
