// .hdt files (docs/hdt-format.md): bit-exact round trips, the layout the spec
// describes, and a reader that refuses every corruption without crashing or
// allocating what the file cannot justify.
#include "hdt/builder.hpp"
#include "hdt/error.hpp"
#include "hdt/hdt_file.hpp"
#include "hdt/labels.hpp"
#include "hdt/mesh.hpp"
#include "hdt/transfer.hpp"
#include "support/format_volumes.hpp"
#include "support/shapes.hpp"

#include <gtest/gtest.h>
#include <tbb/global_control.h>

#if defined(HDT_TEST_HAVE_ZSTD)
#include <zstd.h>
#endif

#include <algorithm>
#include <atomic>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <fstream>
#include <functional>
#include <iterator>
#include <limits>
#include <new>
#include <thread>

// ---- allocation probe ----------------------------------------------------------------
// Records the largest single operator-new request while armed, to prove that
// forged counts are refused before anything is allocated from them. Replacing
// the global operator new affects all of hdt_tests; disarmed it costs one
// relaxed atomic load per allocation.
namespace {
std::atomic<bool> gProbeArmed{false};
std::atomic<size_t> gLargestRequest{0};
} // namespace

void* operator new(std::size_t size) {
  if (gProbeArmed.load(std::memory_order_relaxed)) {
    size_t seen = gLargestRequest.load(std::memory_order_relaxed);
    while (size > seen && !gLargestRequest.compare_exchange_weak(seen, size)) {
    }
  }
  if (void* p = std::malloc(size ? size : 1)) return p;
  throw std::bad_alloc();
}
void operator delete(void* p) noexcept { std::free(p); }
void operator delete(void* p, std::size_t) noexcept { std::free(p); }

namespace hdt {
namespace test {
namespace {

size_t largestAllocationDuring(const std::function<void()>& f) {
  gLargestRequest = 0;
  gProbeArmed = true;
  f();
  gProbeArmed = false;
  return gLargestRequest;
}

// Section indices in an HdtImage (kEnd: the end section of a file without
// optional sections).
enum { kGrid = 0, kStats = 1, kLevels = 2, kElements = 3, kLeaves = 4, kEnd = 5 };

HdtWriteOptions raw() {
  HdtWriteOptions o;
  o.compressLeaves = false;
  return o;
}
HdtWriteOptions compressed() { return HdtWriteOptions{}; } // zstd blocks, version 3
HdtWriteOptions oneFrame() { // one zstd frame, version 2
  HdtWriteOptions o;
  o.leafBlocks = false;
  return o;
}
// Every way the writer can store the leaf data.
std::vector<HdtWriteOptions> allEncodings() { return {raw(), oneFrame(), compressed()}; }

std::vector<uint8_t> bytesOf(const Volume& v, const HdtWriteOptions& o = raw()) { return serializeHdt(v, o); }

// Does this build compress (i.e. was it built with zstd)?
bool haveZstd() {
  static const bool have = [] {
    const std::vector<uint8_t> b = bytesOf(randomVolume(1, RandomVolumeSpec{}), compressed());
    return (getLe32(b, 8) & 1u) != 0;
  }();
  return have;
}

// "ACCEPTED", or the message of what deserializeHdt threw, marked when it was
// not an hdt::Error of kind BadInput naming the file.
std::string refusal(const uint8_t* data, size_t size) {
  try {
    deserializeHdt(data, size, "forged.hdt");
  } catch (const Error& e) {
    const std::string m = e.what();
    if (e.kind() != ErrorKind::BadInput) return "WRONG KIND: " + m;
    if (m.rfind("forged.hdt: ", 0) != 0) return "UNNAMED: " + m;
    return m;
  } catch (const std::exception& e) {
    return std::string("NOT AN hdt::Error: ") + e.what();
  }
  return "ACCEPTED";
}
std::string refusal(const std::vector<uint8_t>& b) { return refusal(b.data(), b.size()); }

bool refusedProperly(const std::string& m) {
  return m != "ACCEPTED" && m.rfind("WRONG KIND", 0) != 0 && m.rfind("UNNAMED", 0) != 0 &&
         m.rfind("NOT AN", 0) != 0;
}

#define EXPECT_REFUSED(bytes, fragment)                                                                      \
  do {                                                                                                       \
    const std::string m_ = refusal(bytes);                                                                   \
    EXPECT_TRUE(refusedProperly(m_) && m_.find(fragment) != std::string::npos)                               \
        << "expected a BadInput mentioning \"" << (fragment) << "\", got: " << m_;                           \
  } while (0)

// Forges a file from a valid one: edit the image, reassemble with fresh CRCs.
std::vector<uint8_t> forge(const std::vector<uint8_t>& valid, const std::function<void(HdtImage&)>& edit) {
  HdtImage image = parseHdtImage(valid);
  edit(image);
  return assembleHdtImage(image);
}

// A small volume with Branches at two levels and several leaves.
Volume smallVolume(bool surfaceOnly = false) {
  RandomVolumeSpec spec;
  spec.rootGrid = 2;
  spec.leafSize = 8;
  spec.height = 2;
  spec.branchChance = 0.6;
  spec.surfaceOnly = surfaceOnly;
  return randomVolume(7, spec);
}

// A smaller one for the byte-by-byte tests.
Volume tinyVolume() {
  RandomVolumeSpec spec; // R = 2, L = 8, h = 1
  return randomVolume(3, spec);
}

// Index of the n-th element with state s at level k (or at any level when k < 0).
uint64_t findElement(const Volume& v, ElementState s, int k, int n = 0) {
  for (uint64_t i = 0; i < v.elements.size(); ++i) {
    const bool levelOk = k < 0 || (i >= v.levelStart[size_t(k)] && i < v.levelStart[size_t(k) + 1]);
    if (levelOk && elementState(v.elements[i]) == s && n-- == 0) return i;
  }
  ADD_FAILURE() << "the test volume lacks the element it needs";
  return 0;
}

// ---- round trips ------------------------------------------------------------------

TEST(HdtFile, RoundTripsRandomVolumesBitExact) {
  struct Case {
    RandomVolumeSpec spec;
    const char* name;
  };
  std::vector<Case> cases;
  auto add = [&](int R, int L, int h, bool surfaceOnly, double branch, double boundary, const char* name) {
    RandomVolumeSpec s;
    s.rootGrid = R;
    s.leafSize = L;
    s.height = h;
    s.surfaceOnly = surfaceOnly;
    s.branchChance = branch;
    s.boundaryChance = boundary;
    cases.push_back({s, name});
  };
  add(2, 8, 1, false, 0.5, 0.5, "R2 L8 h1");
  add(1, 16, 2, false, 0.9, 0.7, "R1 L16 h2");
  add(3, 8, 2, true, 0.4, 0.6, "R3 L8 h2 surface-only");
  add(2, 32, 0, false, 0.0, 0.5, "R2 L32 h0 (root elements are the leaves)");
  add(1, 8, 4, false, 0.8, 0.9, "R1 L8 h4");
  add(4, 8, 0, false, 0.0, 0.05, "R4 L8 h0 sparse");
  add(2, 8, 3, false, 0.0, 0.5, "no Branch at all: levels 1.. empty");
  for (const Case& c : cases) {
    for (uint32_t seed = 1; seed <= 3; ++seed) {
      const Volume v = randomVolume(seed, c.spec);
      for (const HdtWriteOptions& o : allEncodings()) {
        const std::string what = std::string(c.name) + " seed " + std::to_string(seed) +
                                 (!o.compressLeaves ? " raw" : o.leafBlocks ? " blocks" : " one frame");
        const std::vector<uint8_t> bytes = serializeHdt(v, o);
        const Volume back = deserializeHdt(bytes.data(), bytes.size());
        expectSameVolume(v, back, what);
        EXPECT_TRUE(serializeHdt(back, o) == bytes) << what << ": re-serialising changed the bytes";
      }
    }
  }
}

TEST(HdtFile, RoundTripsEmptyVolumes) {
  for (int h : {0, 1, 3}) {
    const Volume v = emptyVolume(3, 16, h);
    for (const HdtWriteOptions& o : allEncodings()) {
      const std::vector<uint8_t> bytes = serializeHdt(v, o);
      expectSameVolume(v, deserializeHdt(bytes.data(), bytes.size()), "empty, h = " + std::to_string(h));
    }
  }
}

TEST(HdtFile, FileOnDiskEqualsSerializedBytes) {
  const Volume v = smallVolume();
  const std::string path = tempPath("format_roundtrip.hdt");
  for (const HdtWriteOptions& o : allEncodings()) {
    writeHdt(v, path, o);
    std::ifstream in(path, std::ios::binary);
    const std::vector<uint8_t> file((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
    EXPECT_TRUE(file == serializeHdt(v, o));
    expectSameVolume(v, readHdt(path), "file");
  }
  std::remove(path.c_str());
}

TEST(HdtFile, CompressionShrinksRedundantLeaves) {
  if (!haveZstd()) GTEST_SKIP() << "built without zstd";
  Volume v = smallVolume();
  for (uint32_t& w : v.leafWords) w = 0xAAAAAAAAu; // all Surface
  computeStructureStatistics(v);
  const std::vector<uint8_t> r = bytesOf(v, raw()), c = bytesOf(v, compressed());
  EXPECT_LT(c.size() * 4, r.size());
  expectSameVolume(v, deserializeHdt(c.data(), c.size()));
}

// Real builds, once the CPU builder is there: a closed sphere, an open
// hemisphere and a surface-only torus.
TEST(HdtFile, RoundTripsRealBuilds) {
  struct Case {
    TriangleMesh mesh;
    BuildConfig config;
    const char* name;
  };
  auto config = [](int N, int R, int L, bool surfaceOnly) {
    BuildConfig c;
    c.resolution = N;
    c.rootGrid = R;
    c.leafSize = L;
    c.surfaceOnly = surfaceOnly;
    return c;
  };
  const Case cases[] = {
      {icosphere(3, 1.0), config(64, 2, 16, false), "sphere N64"},
      {uvHemisphere(16, 32, 1.0), config(128, 4, 8, false), "open hemisphere N128"},
      {torus(1.0, 0.3, 48, 24), config(96, 3, 8, true), "surface-only torus N96"},
  };
  for (const Case& c : cases) {
    Volume v;
    try {
      v = buildCpu(prepareMesh(c.mesh, c.config), BuildOptions{});
    } catch (const std::exception& e) {
      FAIL() << c.name << ": the CPU builder failed: " << e.what();
    }
    ASSERT_GT(v.leafCount(), 0u) << c.name;
    for (const HdtWriteOptions& o : allEncodings()) {
      const std::vector<uint8_t> bytes = serializeHdt(v, o);
      expectSameVolume(v, deserializeHdt(bytes.data(), bytes.size()), c.name);
    }
  }
}

// ---- the layout of docs/hdt-format.md, checked independently ------------------------

// validateVolume: what the reader checks while reading, on a volume in memory.
TEST(ValidateVolume, AcceptsBuildsAndRefusesBrokenVolumes) {
  const Shape shape = sphereShape();
  BuildOptions options;
  options.backend = Backend::Cpu;
  const Volume good = buildCpu(prepareMesh(shape.mesh, shape.config(64, 2, 8, false)), options);
  ASSERT_GT(good.leafCount(), 0u);
  EXPECT_NO_THROW(validateVolume(good));
  auto expectRefused = [](const Volume& v, const char* what) {
    try {
      validateVolume(v);
      ADD_FAILURE() << what << ": accepted";
    } catch (const Error& e) {
      EXPECT_EQ(e.kind(), ErrorKind::BadInput) << what;
    }
  };
  Volume v = good;
  for (ElementWord& w : v.elements)
    if (elementState(w) == ElementState::Branch) {
      w = makeElement(ElementState::Branch, elementPayload(w) + 8);
      break;
    }
  expectRefused(v, "a Branch pointing past its children");
  v = good;
  v.leafWords[0] |= 3u; // state 3
  expectRefused(v, "an invalid voxel state");
  v = good;
  v.leafWords.pop_back();
  expectRefused(v, "a truncated leaf");
  v = good;
  v.stats.activeVoxels += 1;
  expectRefused(v, "statistics that disagree with the contents");
  v = good;
  v.grid.resolution += 1;
  expectRefused(v, "a resolution that is not R 2^h L");
}

TEST(HdtFile, LayoutFollowsTheSpec) {
  EXPECT_EQ(referenceCrc32(reinterpret_cast<const uint8_t*>("123456789"), 9), 0xCBF43926u);
  const Volume v = smallVolume();
  const std::vector<uint8_t> b = bytesOf(v, raw());
  ASSERT_GE(b.size(), 12u);
  EXPECT_EQ(b[0], 'H');
  EXPECT_EQ(b[1], 'D');
  EXPECT_EQ(b[2], 'T');
  EXPECT_EQ(b[3], 0);
  EXPECT_EQ(getLe32(b, 4), 2u);
  EXPECT_EQ(getLe32(b, 8), 0u);

  const HdtImage image = parseHdtImage(b);
  ASSERT_EQ(image.sections.size(), 6u);
  const HdtSectionImage& end = image.sections[kEnd];
  EXPECT_EQ(end.id, 6u);
  EXPECT_EQ(end.encoding, 0u);
  EXPECT_EQ(end.stored, 0u);
  EXPECT_EQ(end.raw, 0u);
  EXPECT_EQ(end.crc, 0u);
  for (size_t i = 0; i < 5; ++i) {
    const HdtSectionImage& s = image.sections[i];
    EXPECT_EQ(s.id, i + 1);
    EXPECT_EQ(s.encoding, 0u);
    EXPECT_EQ(s.raw, s.stored);
    EXPECT_EQ(s.crc, referenceCrc32(s.payload.data(), s.payload.size())) << "section " << s.id;
  }
  const std::vector<uint8_t>& grid = image.sections[kGrid].payload;
  ASSERT_EQ(grid.size(), 60u);
  EXPECT_EQ(getLe32(grid, 0), uint32_t(v.grid.resolution));
  EXPECT_EQ(getLe32(grid, 4), uint32_t(v.grid.rootGrid));
  EXPECT_EQ(getLe32(grid, 8), uint32_t(v.grid.leafSize));
  EXPECT_EQ(getLe32(grid, 12), uint32_t(v.grid.height));
  double origin0;
  const uint64_t bits = getLe64(grid, 16);
  std::memcpy(&origin0, &bits, 8);
  EXPECT_EQ(origin0, v.grid.origin[0]);
  EXPECT_EQ(getLe32(grid, 48), v.surfaceOnly ? 1u : 0u);
  EXPECT_EQ(getLe32(grid, 52), v.closedMesh ? 1u : 0u);
  EXPECT_EQ(getLe32(grid, 56), 1u); // parity

  const std::vector<uint8_t>& stats = image.sections[kStats].payload;
  ASSERT_EQ(stats.size(), 144u + v.stats.backend.size());
  EXPECT_EQ(getLe64(stats, 0), v.stats.triangles);
  EXPECT_EQ(getLe64(stats, 40), v.stats.activeVoxels);
  EXPECT_EQ(getLe64(stats, 120), v.stats.peakHostBytes);
  EXPECT_EQ(getLe32(stats, 136), uint32_t(v.stats.threads));
  EXPECT_EQ(getLe32(stats, 140), v.stats.backend.size());
  EXPECT_EQ(std::string(stats.begin() + 144, stats.end()), v.stats.backend);

  const std::vector<uint8_t>& levels = image.sections[kLevels].payload;
  ASSERT_EQ(levels.size(), 8 * v.levelStart.size());
  for (size_t k = 0; k < v.levelStart.size(); ++k) EXPECT_EQ(getLe64(levels, 8 * k), v.levelStart[k]);

  const std::vector<uint8_t>& elements = image.sections[kElements].payload;
  ASSERT_EQ(elements.size(), 4 * v.elements.size());
  for (size_t i = 0; i < v.elements.size(); ++i) EXPECT_EQ(getLe32(elements, 4 * i), v.elements[i]);

  const std::vector<uint8_t>& leaves = image.sections[kLeaves].payload;
  ASSERT_EQ(leaves.size(), 4 * v.leafWords.size());
  for (size_t i = 0; i < v.leafWords.size(); ++i) ASSERT_EQ(getLe32(leaves, 4 * i), v.leafWords[i]);

  if (haveZstd()) {
    for (const HdtWriteOptions& o : {oneFrame(), compressed()}) {
      const HdtImage c = parseHdtImage(bytesOf(v, o));
      ASSERT_EQ(c.sections.size(), 6u);
      EXPECT_EQ(getLe32(c.fileHeader, 4), o.leafBlocks ? 3u : 2u);
      EXPECT_EQ(getLe32(c.fileHeader, 8), 1u);
      EXPECT_EQ(c.sections[kLeaves].encoding, o.leafBlocks ? 2u : 1u);
      EXPECT_EQ(c.sections[kLeaves].raw, 4 * v.leafWords.size());
      for (size_t i = 0; i < 4; ++i) EXPECT_EQ(c.sections[i].payload, image.sections[i].payload);
    }
  }
}

// ---- corruption ---------------------------------------------------------------------

TEST(HdtFileCorrupt, TruncatedAtEveryOffset) {
  for (const HdtWriteOptions& o : allEncodings()) {
    const std::vector<uint8_t> b = bytesOf(tinyVolume(), o);
    for (size_t n = 0; n < b.size(); ++n) {
      const std::string m = refusal(b.data(), n);
      ASSERT_TRUE(refusedProperly(m)) << "truncated to " << n << " of " << b.size() << " bytes: " << m;
    }
    EXPECT_EQ(refusal(b), "ACCEPTED");
  }
}

TEST(HdtFileCorrupt, EveryByteFlipped) {
  for (const HdtWriteOptions& o : allEncodings()) {
    const std::vector<uint8_t> valid = bytesOf(tinyVolume(), o);
    std::vector<uint8_t> b = valid;
    for (size_t i = 0; i < b.size(); ++i) {
      for (uint8_t mask : {0x01, 0x10, 0x80, 0xFF}) {
        b[i] ^= mask;
        const std::string m = refusal(b);
        b[i] ^= mask;
        // Every byte is covered by a check: none may be changed unnoticed.
        ASSERT_TRUE(refusedProperly(m)) << "byte " << i << " ^ " << int(mask) << ": " << m;
      }
    }
  }
}

TEST(HdtFileCorrupt, BadMagicVersionAndFlags) {
  const std::vector<uint8_t> valid = bytesOf(smallVolume());
  for (int i = 0; i < 4; ++i) {
    std::vector<uint8_t> b = valid;
    b[size_t(i)] ^= 0x20;
    EXPECT_REFUSED(b, "bad magic");
  }
  for (uint32_t version : {0u, 4u, 0xFFFFFFFFu}) {
    std::vector<uint8_t> b = valid;
    putLe32(b, 4, version);
    EXPECT_REFUSED(b, "unsupported .hdt format version " + std::to_string(version));
  }
  for (uint32_t flags : {2u, 0x80000000u, 0xFFFFFFFEu}) {
    std::vector<uint8_t> b = valid;
    putLe32(b, 8, flags);
    EXPECT_REFUSED(b, "unknown flags");
  }
  std::vector<uint8_t> b = valid;
  putLe32(b, 8, 1); // says compressed; the leaf section is raw
  EXPECT_REFUSED(b, haveZstd() ? "compression flag disagrees" : "no zstd support");
  // Version 3 is version 2 with zstd-block leaves and nothing else: a raw or
  // one-frame file that says 3, or a block file that says 2, is refused.
  b = valid;
  putLe32(b, 4, 3);
  EXPECT_REFUSED(b, "version 3 stores the leaf data as zstd blocks");
  if (haveZstd()) {
    b = bytesOf(smallVolume(), oneFrame());
    putLe32(b, 4, 3);
    EXPECT_REFUSED(b, "encoding 1 in a version-3 file");
    b = bytesOf(smallVolume(), compressed());
    putLe32(b, 4, 2);
    EXPECT_REFUSED(b, "leaf data section: invalid encoding 2");
  }
  EXPECT_REFUSED(std::vector<uint8_t>{}, "too short");
  EXPECT_REFUSED(std::vector<uint8_t>(valid.begin(), valid.begin() + 12), "before the grid section header");
}

TEST(HdtFileCorrupt, ForgedCountsAreRefusedBeforeAllocating) {
  // N = 65536 with one Empty root: 15 levels, tiny file.
  const std::vector<uint8_t> base = bytesOf(emptyVolume(1, 8, 13));
  const size_t kSmall = 64 * 1024; // far below anything the forged counts ask for
  auto expectCheapRefusal = [&](const std::vector<uint8_t>& b, const std::string& fragment) {
    std::string m;
    const size_t largest = largestAllocationDuring([&] { m = refusal(b); });
    EXPECT_TRUE(refusedProperly(m) && m.find(fragment) != std::string::npos) << fragment << " / " << m;
    EXPECT_LT(largest, kSmall) << m;
  };
  // Level sizes 1, 8, 64, ..., 8^9 then 0: a consistent table for 153 million
  // elements (613 MB) in a file of a few hundred bytes.
  auto geometricLevels = [](HdtImage& im) {
    std::vector<uint8_t>& t = im.sections[kLevels].payload;
    uint64_t start = 0, size = 1;
    for (size_t k = 0; k < 15; ++k) {
      putLe64(t, 8 * k, start);
      start += size;
      size = k < 9 ? size * 8 : 0;
    }
  };
  const uint64_t forgedElements = (uint64_t(1) << 30) / 7; // (8^10 - 1) / 7
  expectCheapRefusal(forge(base, geometricLevels),
                     "elements section: 4 bytes, expected " + std::to_string(4 * forgedElements));
  expectCheapRefusal(forge(base,
                           [&](HdtImage& im) {
                             geometricLevels(im);
                             HdtSectionImage& e = im.sections[kElements];
                             e.keepHeader = true;
                             e.stored = e.raw = 4 * forgedElements;
                           }),
                     "remain in the file");
  // Element section claiming 2^62 bytes on its own.
  expectCheapRefusal(forge(base,
                           [](HdtImage& im) {
                             HdtSectionImage& e = im.sections[kElements];
                             e.keepHeader = true;
                             e.stored = e.raw = uint64_t(1) << 62;
                           }),
                     "remain in the file");
  // Level table claiming 2^40 elements.
  expectCheapRefusal(
      forge(base, [](HdtImage& im) { putLe64(im.sections[kLevels].payload, 8 * 14, uint64_t(1) << 40); }),
      "level table");
  // R = 8192 (N = 65536 at h = 0): R^3 root elements exceed the element limit.
  expectCheapRefusal(forge(base,
                           [](HdtImage& im) {
                             putLe32(im.sections[kGrid].payload, 4, 8192);
                             putLe32(im.sections[kGrid].payload, 12, 0);
                             std::vector<uint8_t>& t = im.sections[kLevels].payload;
                             t.assign(16, 0);
                             putLe64(t, 8, uint64_t(8192) * 8192 * 8192);
                           }),
                     "exceeds the element limit");
  // A backend name of 4 GiB.
  expectCheapRefusal(
      forge(base, [](HdtImage& im) { putLe32(im.sections[kStats].payload, 140, 0xFFFFFFFFu); }),
      "backend name of 4294967295 bytes");
  // Statistics section claiming a huge length.
  expectCheapRefusal(forge(base,
                           [](HdtImage& im) {
                             HdtSectionImage& s = im.sections[kStats];
                             s.keepHeader = true;
                             s.stored = s.raw = uint64_t(1) << 40;
                           }),
                     "statistics section");
  // Compressed leaf data claiming 1 TiB when the tree has a few leaves.
  const std::vector<uint8_t> leafy = bytesOf(smallVolume());
  expectCheapRefusal(forge(leafy,
                           [](HdtImage& im) {
                             putLe32(im.fileHeader, 8, 1);
                             HdtSectionImage& l = im.sections[kLeaves];
                             l.encoding = 1;
                             l.raw = uint64_t(1) << 40;
                           }),
                     haveZstd() ? "leaf data section: 1099511627776 bytes, expected" : "no zstd support");
}

TEST(HdtFileCorrupt, InconsistentTrees) {
  const Volume v = smallVolume();
  ASSERT_GE(v.leafCount(), 2u);
  const std::vector<uint8_t> valid = bytesOf(v);
  auto withElement = [&](uint64_t index, ElementWord w) {
    return forge(valid, [&](HdtImage& im) { putLe32(im.sections[kElements].payload, 4 * index, w); });
  };
  const int h = v.grid.height;

  const uint64_t branch = findElement(v, ElementState::Branch, 1);
  EXPECT_REFUSED(
      withElement(branch, makeElement(ElementState::Branch, elementPayload(v.elements[branch]) + 8)),
      "Branch points to");
  EXPECT_REFUSED(
      withElement(branch, makeElement(ElementState::Branch, elementPayload(v.elements[branch]) - 1)),
      "Branch points to");

  const uint64_t b0 = findElement(v, ElementState::Boundary, h, 0),
                 b1 = findElement(v, ElementState::Boundary, h, 1);
  EXPECT_REFUSED(forge(valid,
                       [&](HdtImage& im) {
                         putLe32(im.sections[kElements].payload, 4 * b0, v.elements[b1]);
                         putLe32(im.sections[kElements].payload, 4 * b1, v.elements[b0]);
                       }),
                 "Boundary points to leaf 1, expected 0");

  const uint64_t emptyRoot = findElement(v, ElementState::Empty, 0);
  EXPECT_REFUSED(withElement(emptyRoot, makeElement(ElementState::Boundary, 0)),
                 "Boundary element above the leaf level");
  const uint64_t emptyLeafLevel = findElement(v, ElementState::Empty, h);
  EXPECT_REFUSED(withElement(emptyLeafLevel, makeElement(ElementState::Branch, uint32_t(v.elements.size()))),
                 "Branch at the leaf level");
  EXPECT_REFUSED(withElement(emptyRoot, makeElement(ElementState::Empty, 5)), "nonzero payload");
  EXPECT_REFUSED(withElement(findElement(v, ElementState::Full, -1), makeElement(ElementState::Full, 1)),
                 "nonzero payload");

  // One more Branch at level 0, after the last one, pointing where its
  // children would go: level 1 is then 8 elements short.
  uint64_t rootBranches = 0, afterLast = 0;
  for (uint64_t i = 0; i < v.levelStart[1]; ++i)
    if (elementState(v.elements[i]) == ElementState::Branch) ++rootBranches, afterLast = i + 1;
  ASSERT_LT(afterLast, v.levelStart[1]) << "the test volume needs a root after its last Branch";
  EXPECT_REFUSED(
      withElement(afterLast, makeElement(ElementState::Branch, uint32_t(v.levelStart[1] + 8 * rootBranches))),
      "Branch elements but level 1 has");

  // Surface-only volumes hold no Inside state anywhere.
  const Volume so = smallVolume(true);
  const std::vector<uint8_t> soBytes = bytesOf(so);
  EXPECT_REFUSED(forge(soBytes,
                       [&](HdtImage& im) {
                         putLe32(im.sections[kElements].payload, 4 * findElement(so, ElementState::Empty, 0),
                                 makeElement(ElementState::Full, 0));
                       }),
                 "Full element in a surface-only volume");
  EXPECT_REFUSED(forge(soBytes,
                       [&](HdtImage& im) {
                         std::vector<uint8_t>& l = im.sections[kLeaves].payload;
                         putLe32(l, 12, (getLe32(l, 12) & ~3u) | 1u);
                       }),
                 "Inside voxels in a surface-only volume");
}

TEST(HdtFileCorrupt, LeafValueThree) {
  const Volume v = smallVolume();
  const std::vector<uint8_t> valid = bytesOf(v);
  const uint32_t perLeaf = leafWordCount(v.grid.leafSize);
  EXPECT_REFUSED(forge(valid,
                       [&](HdtImage& im) {
                         std::vector<uint8_t>& l = im.sections[kLeaves].payload;
                         const size_t word = perLeaf + 5; // leaf 1, word 5, voxel 7 of it
                         putLe32(l, 4 * word, getLe32(l, 4 * word) | (3u << 14));
                       }),
                 "leaf 1 has a voxel in the invalid state 3 (word 5)");
}

TEST(HdtFileCorrupt, GridLevelTableAndStatistics) {
  const Volume v = smallVolume();
  const std::vector<uint8_t> valid = bytesOf(v);
  auto gridU32 = [&](size_t at, uint32_t x) {
    return forge(valid, [&](HdtImage& im) { putLe32(im.sections[kGrid].payload, at, x); });
  };
  auto gridF64 = [&](size_t at, double x) {
    return forge(valid, [&](HdtImage& im) { putF64(im.sections[kGrid].payload, at, x); });
  };
  EXPECT_REFUSED(gridU32(0, uint32_t(v.grid.resolution) * 2), "is not R * 2^h * L");
  EXPECT_REFUSED(gridU32(4, 0), "root grid 0");
  EXPECT_REFUSED(gridU32(8, 12), "leaf size 12");
  EXPECT_REFUSED(gridU32(8, 16), "is not R * 2^h * L");
  EXPECT_REFUSED(gridU32(12, 17), "height 17");
  EXPECT_REFUSED(gridU32(12, 0xFFFFFFFFu), "height");
  EXPECT_REFUSED(gridU32(48, 2), "boolean");
  EXPECT_REFUSED(gridU32(52, 0x100), "boolean");
  EXPECT_REFUSED(gridF64(16, std::nan("")), "origin is not finite");
  EXPECT_REFUSED(gridF64(32, -std::numeric_limits<double>::infinity()), "origin is not finite");
  for (double s : {0.0, -1.0, std::numeric_limits<double>::infinity(), std::nan("")})
    EXPECT_REFUSED(gridF64(40, s), "voxel size");
  // N = 2 * 2^13 * 8 = 131072 > 65536, consistent otherwise (the level table length follows h).
  EXPECT_REFUSED(forge(valid,
                       [](HdtImage& im) {
                         putLe32(im.sections[kGrid].payload, 0, 131072);
                         putLe32(im.sections[kGrid].payload, 12, 13);
                       }),
                 "exceeds 65536");

  auto levels = [&](size_t k, uint64_t x) {
    return forge(valid, [&](HdtImage& im) { putLe64(im.sections[kLevels].payload, 8 * k, x); });
  };
  EXPECT_REFUSED(levels(0, 1), "level 0 must be");
  EXPECT_REFUSED(levels(1, 7), "level 0 must be");
  EXPECT_REFUSED(levels(2, v.levelStart[2] + 4), "not 8 per branch");
  EXPECT_REFUSED(levels(2, v.levelStart[1] - 8), "decreasing");
  EXPECT_REFUSED(levels(2, v.levelStart[2] + 8), "Branch elements but level 1 has");
  EXPECT_REFUSED(levels(3, v.levelStart[3] + 8), "elements section");

  auto stats = [&](const std::function<void(std::vector<uint8_t>&)>& edit) {
    return forge(valid, [&](HdtImage& im) { edit(im.sections[kStats].payload); });
  };
  const size_t u64Fields[] = {16, 24, 32, 40, 48, 64, 72};
  const char* names[] = {"tree elements", "leaf grids",     "leaf voxels", "active voxels",
                         "inside voxels", "topology bytes", "leaf bytes"};
  for (size_t i = 0; i < 7; ++i) {
    EXPECT_REFUSED(
        stats([&](std::vector<uint8_t>& s) { putLe64(s, u64Fields[i], getLe64(s, u64Fields[i]) + 1); }),
        std::string("statistics: ") + names[i]);
  }
  EXPECT_REFUSED(stats([](std::vector<uint8_t>& s) { putF64(s, 96, std::nan("")); }), "not finite");
  EXPECT_REFUSED(stats([](std::vector<uint8_t>& s) { putF64(s, 56, -1.0); }), "negative");
  EXPECT_REFUSED(stats([](std::vector<uint8_t>& s) { putLe32(s, 136, uint32_t(-3)); }),
                 "negative thread count");
  EXPECT_REFUSED(stats([](std::vector<uint8_t>& s) { s[144] = '\n'; }), "printable");
  EXPECT_REFUSED(stats([](std::vector<uint8_t>& s) {
                   s.resize(144 + 65, 'x');
                   putLe32(s, 140, 65);
                 }),
                 "statistics section: 209 bytes");
}

TEST(HdtFileCorrupt, ContainerStructure) {
  const std::vector<uint8_t> valid = bytesOf(smallVolume());
  std::vector<uint8_t> longer = valid;
  longer.push_back(0);
  EXPECT_REFUSED(longer, "1 bytes after the end section");

  EXPECT_REFUSED(forge(valid, [](HdtImage& im) { std::swap(im.sections[kGrid], im.sections[kStats]); }),
                 "expected the grid section (id 1) at byte 12, found id 2");
  EXPECT_REFUSED(forge(valid, [](HdtImage& im) { im.sections[kLevels].id = 9; }),
                 "expected the level table section");
  EXPECT_REFUSED(forge(valid, [](HdtImage& im) { im.sections.pop_back(); }),
                 "before the next optional or the end section header");
  EXPECT_REFUSED(forge(valid, [](HdtImage& im) { im.sections.erase(im.sections.begin() + kLeaves); }),
                 "expected the leaf data section (id 5)");
  EXPECT_REFUSED(forge(valid, [](HdtImage& im) { im.sections.push_back(im.sections.back()); }),
                 "bytes after the end");
  EXPECT_REFUSED(forge(valid, [](HdtImage& im) { im.sections[kElements].encoding = 1; }),
                 "elements section: invalid encoding 1");
  EXPECT_REFUSED(forge(valid, [](HdtImage& im) { im.sections[kLeaves].encoding = 2; }), "invalid encoding 2");
  EXPECT_REFUSED(forge(valid,
                       [](HdtImage& im) {
                         HdtSectionImage& s = im.sections[kGrid];
                         s.keepHeader = true;
                         s.raw = s.stored + 1;
                       }),
                 "raw section with");
  EXPECT_REFUSED(forge(valid,
                       [](HdtImage& im) {
                         HdtSectionImage& s = im.sections[kElements];
                         s.keepHeader = true;
                         s.payload[0] ^= 4;
                       }),
                 "elements section: CRC-32 mismatch");
  EXPECT_REFUSED(forge(valid, [](HdtImage& im) { im.sections[kGrid].payload.push_back(0); }),
                 "grid section: 61 bytes, expected 60");
}

TEST(HdtFileCorrupt, ZstdFrames) {
  if (!haveZstd()) GTEST_SKIP() << "built without zstd";
  const Volume v = smallVolume();
  const std::vector<uint8_t> valid = bytesOf(v, oneFrame());
  auto leaves = [&](const std::function<void(std::vector<uint8_t>&)>& edit) {
    return forge(valid, [&](HdtImage& im) { edit(im.sections[kLeaves].payload); });
  };
  EXPECT_REFUSED(leaves([](std::vector<uint8_t>& p) { p.push_back(0); }), "leaf data");
  EXPECT_REFUSED(leaves([](std::vector<uint8_t>& p) { p.pop_back(); }), "leaf data");
  EXPECT_REFUSED(leaves([](std::vector<uint8_t>& p) { p[0] ^= 1; }), "not a zstd frame");
  EXPECT_REFUSED(leaves([](std::vector<uint8_t>& p) { p.insert(p.end(), p.begin(), p.end()); }),
                 "not exactly one zstd frame");
  // A well-formed frame of the right size but other contents: caught by the checks after decoding.
  const std::vector<uint8_t> bad = forge(valid, [&](HdtImage& im) {
    Volume ok = v;
    std::fill(ok.leafWords.begin(), ok.leafWords.end(), 0xAAAAAAAAu);
    computeStructureStatistics(ok);
    im.sections[kLeaves].payload = parseHdtImage(bytesOf(ok, oneFrame())).sections[kLeaves].payload;
  });
  EXPECT_REFUSED(bad, "statistics: active voxels");
}

#if defined(HDT_TEST_HAVE_ZSTD)
// Issue 12, defect 5: a frame that does not state its content size was refused
// only after the decoded size had been allocated and zero-filled (2 GiB for a
// 1.1 MB file). The frame header is now checked first.
TEST(HdtFileCorrupt, FrameWithoutContentSizeIsRefusedBeforeAllocating) {
  if (!haveZstd()) GTEST_SKIP() << "built without zstd";
  RandomVolumeSpec spec;
  spec.leafSize = 32; // 8 KiB a leaf: the decoded size dwarfs the frame
  spec.boundaryChance = 0.9;
  const Volume v = randomVolume(5, spec);
  const size_t rawBytes = v.leafWords.size() * 4;
  ASSERT_GT(rawBytes, size_t(64) << 10);
  const std::vector<uint8_t> forged = forge(bytesOf(v, oneFrame()), [&](HdtImage& im) {
    std::vector<uint8_t> leBytes(rawBytes);
    for (size_t i = 0; i < v.leafWords.size(); ++i) putLe32(leBytes, 4 * i, v.leafWords[i]);
    ZSTD_CCtx* c = ZSTD_createCCtx();
    ZSTD_CCtx_setParameter(c, ZSTD_c_contentSizeFlag, 0);
    std::vector<uint8_t> frame(ZSTD_compressBound(rawBytes));
    const size_t n = ZSTD_compress2(c, frame.data(), frame.size(), leBytes.data(), leBytes.size());
    ZSTD_freeCCtx(c);
    ASSERT_FALSE(ZSTD_isError(n));
    frame.resize(n);
    ASSERT_EQ(ZSTD_getFrameContentSize(frame.data(), frame.size()), ZSTD_CONTENTSIZE_UNKNOWN);
    im.sections[kLeaves].payload = frame;
    im.sections[kLeaves].keepHeader = true; // raw size stays the tree's; stored and CRC follow the frame
    im.sections[kLeaves].stored = frame.size();
    im.sections[kLeaves].crc = referenceCrc32(frame.data(), frame.size());
  });
  std::string m;
  const size_t largest = largestAllocationDuring([&] { m = refusal(forged); });
  EXPECT_TRUE(refusedProperly(m) && m.find("does not state its size") != std::string::npos) << m;
  EXPECT_LT(largest, rawBytes / 2) << "allocated the decoded size before checking the frame: " << m;
}

// ---- version 3: the leaf data as zstd blocks (encoding 2) ---------------------------

// The payload of a leaf data section of encoding 2, as the spec lays it out.
struct BlockTable {
  uint32_t blockLog = 0;
  std::vector<std::vector<uint8_t>> frames;
};

BlockTable parseBlocks(const std::vector<uint8_t>& p) {
  BlockTable t;
  t.blockLog = getLe32(p, 0);
  const uint32_t n = getLe32(p, 4);
  size_t at = 8 + 8 * size_t(n);
  for (uint32_t i = 0; i < n; ++i) {
    const size_t length = size_t(getLe64(p, 8 + 8 * size_t(i)));
    t.frames.emplace_back(p.begin() + long(at), p.begin() + long(at + length));
    at += length;
  }
  EXPECT_EQ(at, p.size());
  return t;
}

std::vector<uint8_t> assembleBlocks(const BlockTable& t) {
  std::vector<uint8_t> p(8 + 8 * t.frames.size());
  putLe32(p, 0, t.blockLog);
  putLe32(p, 4, uint32_t(t.frames.size()));
  for (size_t i = 0; i < t.frames.size(); ++i) {
    putLe64(p, 8 + 8 * i, t.frames[i].size());
    p.insert(p.end(), t.frames[i].begin(), t.frames[i].end());
  }
  return p;
}

constexpr size_t kBlockBytes = size_t(1) << 21; // the writer's block size

// A volume whose leaf data spans several 2 MiB blocks, the last one partial.
Volume multiBlockVolume() {
  RandomVolumeSpec spec;
  spec.rootGrid = 6;
  spec.leafSize = 32;
  spec.boundaryChance = 0.9;
  Volume v = randomVolume(11, spec);
  // Mostly Outside with runs of Surface, as real leaves are: compressible.
  for (size_t i = 0; i < v.leafWords.size(); ++i) v.leafWords[i] = (i / 7) % 5 == 0 ? 0xAAAAAAAAu : 0u;
  computeStructureStatistics(v);
  return v;
}

std::vector<uint8_t> littleEndianLeaves(const Volume& v) {
  std::vector<uint8_t> le(v.leafWords.size() * 4);
  for (size_t i = 0; i < v.leafWords.size(); ++i) putLe32(le, 4 * i, v.leafWords[i]);
  return le;
}

TEST(HdtFileV3, LeafBlocksFollowTheSpec) {
  if (!haveZstd()) GTEST_SKIP() << "built without zstd";
  const Volume v = multiBlockVolume();
  const std::vector<uint8_t> le = littleEndianLeaves(v);
  ASSERT_GT(le.size(), 2 * kBlockBytes);
  ASSERT_NE(le.size() % kBlockBytes, 0u);
  const std::vector<uint8_t> bytes = bytesOf(v, compressed());
  EXPECT_EQ(getLe32(bytes, 4), 3u);
  EXPECT_EQ(getLe32(bytes, 8), 1u);
  const HdtImage image = parseHdtImage(bytes);
  const HdtSectionImage& s = image.sections[kLeaves];
  EXPECT_EQ(s.encoding, 2u);
  EXPECT_EQ(s.raw, le.size());
  EXPECT_EQ(s.crc, referenceCrc32(s.payload.data(), s.payload.size()));
  const BlockTable t = parseBlocks(s.payload);
  EXPECT_EQ(t.blockLog, 21u);
  ASSERT_EQ(t.frames.size(), (le.size() + kBlockBytes - 1) / kBlockBytes);
  for (size_t i = 0; i < t.frames.size(); ++i) {
    const size_t first = i * kBlockBytes, bytesInBlock = std::min(kBlockBytes, le.size() - first);
    const std::vector<uint8_t>& f = t.frames[i];
    EXPECT_EQ(ZSTD_getFrameContentSize(f.data(), f.size()), bytesInBlock) << "block " << i;
    EXPECT_EQ(ZSTD_findFrameCompressedSize(f.data(), f.size()), f.size()) << "block " << i;
    std::vector<uint8_t> decoded(bytesInBlock);
    ASSERT_EQ(ZSTD_decompress(decoded.data(), decoded.size(), f.data(), f.size()), bytesInBlock);
    EXPECT_TRUE(std::equal(decoded.begin(), decoded.end(), le.begin() + long(first))) << "block " << i;
  }
  EXPECT_LT(bytes.size() * 4, le.size()); // it compresses
  expectSameVolume(v, deserializeHdt(bytes.data(), bytes.size()), "blocks");
}

// A file longer than a write-back step (the writer starts the disk writes every
// 4 MiB): the same bytes as serialized, read back as the volume.
TEST(HdtFileV3, FileOfManyWriteBackStepsEqualsSerializedBytes) {
  const Volume v = multiBlockVolume();
  const std::string path = tempPath("write_back_steps.hdt");
  HdtWriteOptions raw;
  raw.compressLeaves = false;
  for (const HdtWriteOptions& o : {raw, compressed()}) {
    writeHdt(v, path, o);
    std::ifstream in(path, std::ios::binary);
    const std::vector<uint8_t> file((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
    EXPECT_TRUE(file == serializeHdt(v, o));
    expectSameVolume(v, readHdt(path), "file");
  }
  EXPECT_GT(v.leafWords.size() * 4, size_t(4) << 20) << "the raw file spans more than one step";
  std::remove(path.c_str());
}

TEST(HdtFileV3, BytesDoNotDependOnTheThreadCount) {
  if (!haveZstd()) GTEST_SKIP() << "built without zstd";
  const Volume v = multiBlockVolume();
  std::vector<uint8_t> single;
  {
    tbb::global_control c(tbb::global_control::max_allowed_parallelism, 1);
    single = bytesOf(v, compressed());
    expectSameVolume(v, deserializeHdt(single.data(), single.size()), "1 thread");
  }
  for (size_t threads : {2u, 3u, 8u}) {
    tbb::global_control c(tbb::global_control::max_allowed_parallelism, threads);
    EXPECT_TRUE(bytesOf(v, compressed()) == single) << threads << " threads";
  }
}

// The leaf blocks compressed as the leaf words arrive (HdtLeafEncoder, what
// the CUDA driver's copy back feeds) give the bytes of the writer on its own,
// whatever the pieces: one, block-aligned, odd sizes and repeats, one word
// short until the end; to memory and to a file, from another thread too.
TEST(HdtFileV3, StreamedLeafBlocksGiveTheSameBytes) {
  if (!haveZstd()) GTEST_SKIP() << "built without zstd";
  const Volume v = multiBlockVolume();
  const std::vector<uint8_t> plain = bytesOf(v, compressed());
  const size_t n = v.leafWords.size(), blockWords = kBlockBytes / 4;
  ASSERT_GT(n, 2 * blockWords);
  ASSERT_NE(n % blockWords, 0u);
  const std::vector<std::vector<size_t>> arrivals = {
      {n},
      {blockWords, 2 * blockWords, n},
      {1, 12345, 12345, blockWords - 1, blockWords + 1, 2 * blockWords + 7, n - 1, n - 1, n},
      {n / 3, 2 * n / 3, n},
  };
  for (size_t a = 0; a < arrivals.size(); ++a) {
    // The words land piece by piece in a volume that held zeros: a block
    // compressed before all its words are there would differ.
    Volume landing = v;
    std::fill(landing.leafWords.begin(), landing.leafWords.end(), 0u);
    HdtLeafEncoder streamed;
    std::thread feeder([&] { // the driver's copying threads, not the writer's
      streamed.begin(landing.leafWords.data(), n);
      size_t landed = 0;
      for (size_t count : arrivals[a]) {
        std::copy(v.leafWords.begin() + long(landed), v.leafWords.begin() + long(count),
                  landing.leafWords.begin() + long(landed));
        landed = std::max(landed, count);
        streamed.arrived(count);
        streamed.waitForBlocks(); // what is handed out is compressed now, before more words land
      }
    });
    feeder.join();
    EXPECT_TRUE(serializeHdt(landing, compressed(), &streamed) == plain) << "arrivals " << a;
    EXPECT_TRUE(streamed.usedByWriter()) << "arrivals " << a;
  }
  const std::string path = tempPath("format_streamed.hdt");
  HdtLeafEncoder streamed;
  streamed.begin(v.leafWords.data(), n);
  streamed.arrived(n / 2);
  streamed.arrived(n);
  writeHdt(v, path, compressed(), &streamed);
  EXPECT_TRUE(streamed.usedByWriter());
  std::ifstream in(path, std::ios::binary);
  EXPECT_TRUE(std::vector<uint8_t>((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>()) == plain);
  std::remove(path.c_str());
}

// Where the encoder does not cover the volume's leaves exactly with the
// writer's options, the writer compresses them itself: still the same bytes.
TEST(HdtFileV3, StreamedLeafBlocksNotCoveringTheVolumeAreNotUsed) {
  if (!haveZstd()) GTEST_SKIP() << "built without zstd";
  const Volume v = multiBlockVolume();
  const size_t n = v.leafWords.size();
  const Volume copy = v; // the same words elsewhere
  HdtWriteOptions otherLevel = compressed();
  otherLevel.zstdLevel = HdtWriteOptions{}.zstdLevel + 2; // the encoder's is the default
  struct Case {
    const char* what;
    const uint32_t* words;
    size_t count, arrived;
    HdtWriteOptions write;
  };
  const Case cases[] = {
      {"not all arrived", v.leafWords.data(), n, n - 1, compressed()},
      {"another volume's words", copy.leafWords.data(), n, n, compressed()},
      {"fewer words", v.leafWords.data(), n - 1, n - 1, compressed()},
      {"another level", v.leafWords.data(), n, n, otherLevel},
      {"one frame (version 2)", v.leafWords.data(), n, n, oneFrame()},
  };
  for (const Case& c : cases) {
    HdtLeafEncoder streamed;
    streamed.begin(c.words, c.count);
    streamed.arrived(c.arrived);
    EXPECT_TRUE(serializeHdt(v, c.write, &streamed) == serializeHdt(v, c.write)) << c.what;
    EXPECT_FALSE(streamed.usedByWriter()) << c.what;
  }
  // A build that failed after its words arrived abandons them (the driver's
  // volume is freed): nothing of them is used afterwards.
  HdtLeafEncoder streamed;
  streamed.begin(v.leafWords.data(), n);
  streamed.arrived(n);
  streamed.abandon();
  EXPECT_TRUE(serializeHdt(v, compressed(), &streamed) == serializeHdt(v, compressed()));
  EXPECT_FALSE(streamed.usedByWriter()) << "abandoned";
}

// Written as zstd blocks, the leaf words are counted by the tasks that
// compress them (whether streamed during the build or by the writer), not by
// the checker: a refused volume gets the same message either way.
TEST(HdtFileV3, RefusalsAreTheSameWhereTheBlocksCountTheLeaves) {
  if (!haveZstd()) GTEST_SKIP() << "built without zstd";
  const Volume good = multiBlockVolume();
  HdtWriteOptions raw;
  raw.compressLeaves = false;
  auto refusal = [](const Volume& v, const HdtWriteOptions& o, HdtLeafEncoder* streamed) -> std::string {
    try {
      serializeHdt(v, o, streamed);
    } catch (const Error& e) {
      EXPECT_EQ(e.kind(), ErrorKind::InvalidArgument) << e.what();
      return e.what();
    }
    return "accepted";
  };
  const struct {
    const char* fragment;
    std::function<void(Volume&)> edit;
  } cases[] = {
      {"invalid state 3 (word 2045)", [](Volume& v) { v.leafWords[v.leafWords.size() - 3] |= 3u; }}, // the last block
      {"invalid state 3 (word 0)", [](Volume& v) { v.leafWords[0] = 0xFFFFFFFFu; }},
      {"active voxels", [](Volume& v) { v.stats.activeVoxels += 1; }},
      {"inside voxels", [](Volume& v) { v.stats.insideVoxels -= 1; }},
  };
  for (const auto& c : cases) {
    Volume v = good;
    c.edit(v);
    const std::string checker = refusal(v, raw, nullptr);
    EXPECT_NE(checker.find(c.fragment), std::string::npos) << checker;
    EXPECT_EQ(refusal(v, compressed(), nullptr), checker);
    HdtLeafEncoder streamed;
    streamed.begin(v.leafWords.data(), v.leafWords.size());
    streamed.arrived(v.leafWords.size());
    EXPECT_EQ(refusal(v, compressed(), &streamed), checker);
    // To a file, the streamed frames are written as they are compressed,
    // before the verdict: still refused the same way, and no file is left.
    const std::string path = tempPath("streamed_refused.hdt");
    std::remove(path.c_str());
    auto fileRefusal = [&](const HdtWriteOptions& o, HdtLeafEncoder* s) -> std::string {
      try {
        writeHdt(v, path, o, s);
      } catch (const Error& e) {
        return e.what();
      }
      return "accepted";
    };
    HdtLeafEncoder toFile;
    toFile.begin(v.leafWords.data(), v.leafWords.size());
    toFile.arrived(v.leafWords.size());
    EXPECT_EQ(fileRefusal(compressed(), &toFile), fileRefusal(raw, nullptr));
    EXPECT_TRUE(toFile.usedByWriter()) << "the streaming writer took the blocks";
    EXPECT_EQ(std::fopen(path.c_str(), "rb"), nullptr);
  }
}

TEST(HdtFileCorrupt, ZstdBlocks) {
  if (!haveZstd()) GTEST_SKIP() << "built without zstd";
  const Volume v = multiBlockVolume();
  const std::vector<uint8_t> valid = bytesOf(v, compressed());
  const size_t rawBytes = v.leafWords.size() * 4;
  // Edits of the section's payload, or of its parsed blocks; CRCs recomputed.
  auto payload = [&](const std::function<void(std::vector<uint8_t>&)>& edit) {
    return forge(valid, [&](HdtImage& im) { edit(im.sections[kLeaves].payload); });
  };
  auto blocks = [&](const std::function<void(BlockTable&)>& edit) {
    return payload([&](std::vector<uint8_t>& p) {
      BlockTable t = parseBlocks(p);
      edit(t);
      p = assembleBlocks(t);
    });
  };
  ASSERT_EQ(refusal(valid), "ACCEPTED");
  EXPECT_REFUSED(payload([](std::vector<uint8_t>& p) { putLe32(p, 0, 15); }), "zstd block size 2^15 is outside");
  EXPECT_REFUSED(payload([](std::vector<uint8_t>& p) { putLe32(p, 0, 31); }), "zstd block size 2^31 is outside");
  EXPECT_REFUSED(payload([](std::vector<uint8_t>& p) { putLe32(p, 0, 22); }), "zstd blocks, expected");
  EXPECT_REFUSED(payload([](std::vector<uint8_t>& p) { putLe32(p, 4, getLe32(p, 4) + 1); }), "zstd blocks, expected");
  EXPECT_REFUSED(payload([](std::vector<uint8_t>& p) { p.resize(12); }), "does not fit");
  EXPECT_REFUSED(payload([](std::vector<uint8_t>& p) { p.resize(4); }), "block table is cut short");
  EXPECT_REFUSED(payload([](std::vector<uint8_t>& p) { p.push_back(0); }), "1 bytes after the last zstd block");
  EXPECT_REFUSED(payload([](std::vector<uint8_t>& p) { putLe64(p, 8, getLe64(p, 8) + 1); }),
                 "zstd block 0 is not exactly one zstd frame");
  EXPECT_REFUSED(payload([](std::vector<uint8_t>& p) { putLe64(p, 8, uint64_t(1) << 40); }), "runs past the section");
  EXPECT_REFUSED(blocks([](BlockTable& t) { std::swap(t.frames.front(), t.frames.back()); }),
                 "zstd block 0 holds");
  EXPECT_REFUSED(blocks([](BlockTable& t) { t.frames[1].insert(t.frames[1].end(), t.frames[1].begin(), t.frames[1].end()); }),
                 "zstd block 1 is not exactly one zstd frame");
  EXPECT_REFUSED(blocks([](BlockTable& t) { t.frames[1][0] ^= 1; }), "zstd block 1 is not a zstd frame");
  // A frame body that does not decode (its header intact): named by block.
  EXPECT_REFUSED(blocks([](BlockTable& t) {
                   std::vector<uint8_t>& f = t.frames[2];
                   std::fill(f.begin() + long(f.size() / 2), f.end(), uint8_t(0xFF));
                 }),
                 "leaf data");
  // Well-formed blocks of other contents: caught by the checks after decoding.
  Volume other = v;
  std::fill(other.leafWords.begin(), other.leafWords.end(), 0xAAAAAAAAu);
  computeStructureStatistics(other);
  EXPECT_REFUSED(forge(valid, [&](HdtImage& im) {
                   im.sections[kLeaves].payload = parseHdtImage(bytesOf(other, compressed())).sections[kLeaves].payload;
                 }),
                 "statistics: active voxels");

  // A block that does not state its size is refused before the decoded size is allocated.
  const std::vector<uint8_t> le = littleEndianLeaves(v);
  const std::vector<uint8_t> noSize = blocks([&](BlockTable& t) {
    ZSTD_CCtx* c = ZSTD_createCCtx();
    ZSTD_CCtx_setParameter(c, ZSTD_c_contentSizeFlag, 0);
    std::vector<uint8_t> frame(ZSTD_compressBound(kBlockBytes));
    const size_t n = ZSTD_compress2(c, frame.data(), frame.size(), le.data() + kBlockBytes, kBlockBytes);
    ZSTD_freeCCtx(c);
    ASSERT_FALSE(ZSTD_isError(n));
    frame.resize(n);
    t.frames[1] = frame;
  });
  std::string m;
  const size_t largest = largestAllocationDuring([&] { m = refusal(noSize); });
  EXPECT_TRUE(refusedProperly(m) && m.find("zstd block 1: the frame does not state its size") != std::string::npos) << m;
  EXPECT_LT(largest, rawBytes / 2) << "allocated the decoded size before checking the blocks: " << m;
}
#endif

// ---- the writer and the file entry points ------------------------------------------

TEST(HdtFileWrite, RefusesInconsistentVolumes) {
  auto expectInvalid = [](const Volume& v, const char* fragment) {
    try {
      serializeHdt(v);
      ADD_FAILURE() << "accepted: " << fragment;
    } catch (const Error& e) {
      EXPECT_EQ(e.kind(), ErrorKind::InvalidArgument) << e.what();
      EXPECT_NE(std::string(e.what()).find(fragment), std::string::npos) << e.what();
    }
  };
  const Volume good = smallVolume();
  Volume v = good;
  v.stats.activeVoxels += 1;
  expectInvalid(v, "active voxels");
  v = good;
  v.leafWords.pop_back();
  expectInvalid(v, "leaf words for");
  v = good;
  v.levelStart.pop_back();
  expectInvalid(v, "level table");
  v = good;
  v.grid.leafSize = 16;
  expectInvalid(v, "is not R * 2^h * L");
  v = good;
  v.stats.backend = std::string(65, 'x');
  expectInvalid(v, "backend");
  v = good;
  v.leafWords[0] = 0xFFFFFFFFu;
  expectInvalid(v, "invalid state 3");

  // Nothing is left on disk for a refused volume.
  const std::string path = tempPath("format_refused.hdt");
  std::remove(path.c_str());
  v = good;
  v.elements[findElement(good, ElementState::Branch, 0)] += 4; // payload + 1
  EXPECT_THROW(writeHdt(v, path), Error);
  EXPECT_EQ(std::fopen(path.c_str(), "rb"), nullptr);

  if (haveZstd()) {
    HdtWriteOptions o;
    o.zstdLevel = 1000;
    EXPECT_THROW(serializeHdt(good, o), Error);
  }
}

TEST(HdtFileRead, UnreadablePaths) {
  auto expectBadInput = [](const std::string& path, const char* fragment) {
    try {
      readHdt(path);
      ADD_FAILURE() << "read " << path;
    } catch (const Error& e) {
      EXPECT_EQ(e.kind(), ErrorKind::BadInput);
      const std::string m = e.what();
      EXPECT_EQ(m.rfind(path + ": ", 0), 0u) << m;
      EXPECT_NE(m.find(fragment), std::string::npos) << m;
    }
  };
  expectBadInput("/nonexistent/dir/x.hdt", "cannot open");
  expectBadInput(tempPath(""), "not a regular file");
  const std::string path = tempPath("format_truncated.hdt");
  {
    const std::vector<uint8_t> b = bytesOf(smallVolume());
    std::ofstream out(path, std::ios::binary);
    // Cut the end section and 3 bytes of the leaf data.
    out.write(reinterpret_cast<const char*>(b.data()), std::streamsize(b.size() - 28 - 3));
  }
  expectBadInput(path, "leaf data section");
  std::remove(path.c_str());
}


// ---- version 2: the inside test, optional sections, version 1 files ---------------

// The version-1 file of a volume, as docs/hdt-format.md describes it: version
// 1, a 56-byte grid section (no inside test), no end section.
std::vector<uint8_t> versionOneBytes(const Volume& v, const HdtWriteOptions& o = raw()) {
  return forge(bytesOf(v, o), [](HdtImage& im) {
    putLe32(im.fileHeader, 4, 1);
    im.sections[kGrid].payload.resize(56);
    im.sections.pop_back();
  });
}

// An optional section as a writer of a later format revision might add it.
HdtSectionImage optionalSection(uint32_t id, std::vector<uint8_t> payload) {
  HdtSectionImage s;
  s.id = id;
  s.payload = std::move(payload);
  return s;
}

TEST(HdtFileV2, ReadsVersionOneFilesAsParity) {
  for (const HdtWriteOptions& o : {raw(), oneFrame()}) {
    Volume v = smallVolume();
    v.insideTest = InsideTest::WindingNumber;
    const Volume back = deserializeHdt(versionOneBytes(v, o).data(), versionOneBytes(v, o).size());
    EXPECT_EQ(back.insideTest, InsideTest::Parity);
    v.insideTest = InsideTest::Parity;
    expectSameVolume(v, back, "version 1");
  }
  // Version 1 knows no optional sections and no end section.
  const std::vector<uint8_t> v1 = versionOneBytes(smallVolume());
  std::vector<uint8_t> withEnd = v1;
  withEnd.resize(withEnd.size() + 28, 0);
  putLe32(withEnd, v1.size(), 6);
  EXPECT_REFUSED(withEnd, "28 bytes after the end of the leaf data section");
  EXPECT_REFUSED(forge(v1, [](HdtImage& im) { im.sections[kGrid].payload.resize(60); }),
                 "grid section: 60 bytes, expected 56");
}

TEST(HdtFileV2, RecordsTheInsideTest) {
  for (InsideTest t : {InsideTest::Parity, InsideTest::WindingNumber}) {
    Volume v = smallVolume();
    v.insideTest = t;
    const std::vector<uint8_t> b = bytesOf(v);
    EXPECT_EQ(getLe32(parseHdtImage(b).sections[kGrid].payload, 56), uint32_t(t));
    EXPECT_EQ(deserializeHdt(b.data(), b.size()).insideTest, t);
  }
  const std::vector<uint8_t> valid = bytesOf(smallVolume());
  for (uint32_t t : {0u, 3u, 0x100u}) {
    EXPECT_REFUSED(forge(valid, [&](HdtImage& im) { putLe32(im.sections[kGrid].payload, 56, t); }),
                   "grid: inside test " + std::to_string(t));
  }
  Volume autoTest = smallVolume();
  autoTest.insideTest = InsideTest::Auto; // a build always records the test that ran
  EXPECT_THROW(bytesOf(autoTest), Error);
}

TEST(HdtFileV2, SkipsUnknownOptionalSectionsAndRefusesCriticalOnes) {
  const Volume v = smallVolume();
  const std::vector<uint8_t> valid = bytesOf(v);
  auto withSections = [&](std::vector<HdtSectionImage> extra) {
    return forge(valid, [&](HdtImage& im) {
      im.sections.insert(im.sections.begin() + kEnd, extra.begin(), extra.end());
    });
  };
  // Unknown, not critical: skipped (payload checksummed), the volume unchanged.
  const std::vector<uint8_t> skipped =
      withSections({optionalSection(1000, {1, 2, 3}), optionalSection(0x7FFFFFFF, {})});
  expectSameVolume(v, deserializeHdt(skipped.data(), skipped.size()), "unknown optional sections");
  HdtSectionImage zstdUnknown = optionalSection(1001, {9, 9});
  zstdUnknown.encoding = 1;
  zstdUnknown.raw = 12345; // the reader cannot know the decoded size: not checked
  zstdUnknown.keepHeader = true;
  zstdUnknown.stored = 2;
  const std::vector<uint8_t> zstdHeader = {0xE9, 0x03, 0, 0, 1, 0, 0, 0, 2, 0, 0, 0, 0, 0, 0, 0,
                                           0x39, 0x30, 0, 0, 0, 0, 0, 0, 9, 9}; // 24 header bytes, payload
  zstdUnknown.crc = referenceCrc32(zstdHeader.data(), zstdHeader.size());
  const std::vector<uint8_t> skippedZstd = withSections({zstdUnknown});
  expectSameVolume(v, deserializeHdt(skippedZstd.data(), skippedZstd.size()), "unknown zstd section");

  EXPECT_REFUSED(withSections({optionalSection(0x80000010u, {1})}), "marked critical");
  EXPECT_REFUSED(withSections({optionalSection(7, {})}), "expected an optional section (id 16 or more)");
  EXPECT_REFUSED(withSections({optionalSection(1, {})}), "expected an optional section");
  EXPECT_REFUSED(withSections({optionalSection(2000, {}), optionalSection(1000, {})}), "increasing id order");
  EXPECT_REFUSED(withSections({optionalSection(1000, {}), optionalSection(1000, {})}), "increasing id order");
  HdtSectionImage badCrc = optionalSection(1000, {1, 2, 3});
  badCrc.keepHeader = true;
  badCrc.stored = badCrc.raw = 3;
  badCrc.crc = 1;
  EXPECT_REFUSED(withSections({badCrc}), "optional section 1000: CRC-32 mismatch");
  HdtSectionImage badEncoding = optionalSection(1000, {});
  badEncoding.encoding = 2;
  EXPECT_REFUSED(withSections({badEncoding}), "optional section 1000: invalid encoding 2");
  HdtSectionImage tooLong = optionalSection(1000, {1});
  tooLong.keepHeader = true;
  tooLong.stored = tooLong.raw = 1000;
  EXPECT_REFUSED(withSections({tooLong}), "remain in the file");

  // The end section: all zero, last.
  for (size_t field : {4u, 8u, 16u, 24u}) {
    std::vector<uint8_t> b = valid;
    b[b.size() - 28 + field] = 1;
    EXPECT_REFUSED(b, "end section at byte");
  }
}

TEST(HdtFileV2, CorruptionOfOptionalSectionsIsCaught) {
  // Every byte of a file with a skipped optional section is covered by a check too.
  const std::vector<uint8_t> valid = forge(bytesOf(tinyVolume()), [](HdtImage& im) {
    im.sections.insert(im.sections.begin() + kEnd, optionalSection(1000, {1, 2, 3, 4, 5}));
  });
  ASSERT_EQ(refusal(valid), "ACCEPTED");
  std::vector<uint8_t> b = valid;
  for (size_t i = 0; i < b.size(); ++i) {
    for (uint8_t mask : {0x01, 0x80}) {
      b[i] ^= mask;
      const std::string m = refusal(b);
      b[i] ^= mask;
      ASSERT_TRUE(refusedProperly(m)) << "byte " << i << " ^ " << int(mask) << ": " << m;
    }
  }
  for (size_t n = 0; n < valid.size(); ++n) ASSERT_TRUE(refusedProperly(refusal(valid.data(), n))) << n;
}


// ---- part labels (optional sections 16, 17, 18, 21) -------------------------------------

Volume labelledVolume(uint32_t seed = 7) {
  Volume v = smallVolume();
  labelRandomly(v, seed);
  return v;
}

Volume tinyLabelledVolume() {
  Volume v = tinyVolume();
  labelRandomly(v, 5, 3);
  return v;
}

// Little-endian u16s, as sections 16 and 17 store labels.
std::vector<uint8_t> labelBytes(const std::vector<Label>& labels) {
  std::vector<uint8_t> b;
  for (Label l : labels) b.insert(b.end(), {uint8_t(l), uint8_t(l >> 8)});
  return b;
}

// Section 21 as the spec lays it out: u32 layout, palettes, indices, wide labels.
std::vector<uint8_t> compactVoxelSection(const LabelField& f, uint32_t layout = 2) {
  std::vector<uint8_t> b(4);
  putLe32(b, 0, layout);
  for (const LeafPalette& p : f.palettes)
    for (Label l : p.labels) b.insert(b.end(), {uint8_t(l), uint8_t(l >> 8)});
  for (uint32_t w : f.paletteIndices) b.insert(b.end(), {uint8_t(w), uint8_t(w >> 8), uint8_t(w >> 16), uint8_t(w >> 24)});
  for (Label l : f.wideLabels) b.insert(b.end(), {uint8_t(l), uint8_t(l >> 8)});
  return b;
}

size_t sectionIndex(const HdtImage& im, uint32_t id) {
  for (size_t i = 0; i < im.sections.size(); ++i)
    if (im.sections[i].id == id) return i;
  ADD_FAILURE() << "no section " << id;
  return 0;
}

// The file an older writer made: section 17 (16 bits a voxel, `voxels`: L^3
// labels per mixed leaf) right after 16, instead of section 21.
std::vector<uint8_t> withSixteenBitLabels(const std::vector<uint8_t>& valid, const std::vector<Label>& voxels,
                                          bool keepCompact = false) {
  return forge(valid, [&](HdtImage& im) {
    if (!keepCompact) im.sections.erase(im.sections.begin() + long(sectionIndex(im, 21)));
    HdtSectionImage old;
    old.id = 17;
    old.payload = labelBytes(voxels);
    im.sections.insert(im.sections.begin() + long(sectionIndex(im, 16)) + 1, old);
  });
}

TEST(HdtFileLabels, RoundTripBitExact) {
  for (const HdtWriteOptions& o : allEncodings()) {
    size_t paletteWords = 0, wideLabels = 0;
    for (uint32_t seed : {1u, 2u, 3u}) {
      Volume v = randomVolume(seed, RandomVolumeSpec{3, 8, 2, false, 0.5, 0.7, 0.3});
      const std::vector<Label> chosen = labelRandomly(v, seed, 3 + int(seed) * 3);
      paletteWords += v.labels.paletteIndices.size();
      wideLabels += v.labels.wideLabels.size();
      ASSERT_TRUE(unpackVoxelLabels(v) == chosen);
      const std::vector<uint8_t> b = bytesOf(v, o);
      const Volume back = deserializeHdt(b.data(), b.size());
      expectSameVolume(v, back, "labelled seed " + std::to_string(seed));
      EXPECT_TRUE(unpackVoxelLabels(back) == chosen);
    }
    EXPECT_GT(paletteWords, 0u) << "no palette leaf";
    EXPECT_GT(wideLabels, 0u) << "no wide leaf";
    Volume noNames = labelledVolume();
    noNames.labels.names.clear();
    const std::vector<uint8_t> b = bytesOf(noNames, o);
    EXPECT_EQ(parseHdtImage(b).sections.size(), 8u); // 5 required, labels 16 and 21, end
    expectSameVolume(noNames, deserializeHdt(b.data(), b.size()), "no names");
  }
}

// Files of the older writer (section 17, 16 bits a voxel) still read, and
// give the compact form of the same labels.
TEST(HdtFileLabels, SixteenBitSectionOfOlderFilesIsConverted) {
  for (uint32_t seed : {1u, 2u}) {
    Volume v = randomVolume(seed, RandomVolumeSpec{3, 8, 2, false, 0.5, 0.7, 0.3});
    const std::vector<Label> chosen = labelRandomly(v, seed);
    const std::vector<uint8_t> old = withSixteenBitLabels(bytesOf(v, raw()), chosen);
    EXPECT_EQ(parseHdtImage(old).sections[6].id, 17u);
    const Volume back = deserializeHdt(old.data(), old.size());
    expectSameVolume(v, back, "from section 17, seed " + std::to_string(seed));
    EXPECT_EQ(bytesOf(back, raw()), bytesOf(v, raw())) << "rewritten in the compact form";
  }
  const Volume v = labelledVolume();
  const std::vector<uint8_t> valid = bytesOf(v);
  std::vector<Label> voxels = unpackVoxelLabels(v);
  EXPECT_REFUSED(withSixteenBitLabels(valid, voxels, true), "both label voxels sections");
  voxels.pop_back();
  EXPECT_REFUSED(withSixteenBitLabels(valid, voxels), "label voxels section");
  voxels = unpackVoxelLabels(v);
  for (Label& l : voxels) l = l ? 1 : 0;
  EXPECT_REFUSED(withSixteenBitLabels(valid, voxels), "only one label");
}

TEST(HdtFileLabels, LayoutFollowsTheSpec) {
  const Volume v = labelledVolume();
  const HdtImage im = parseHdtImage(bytesOf(v, raw()));
  ASSERT_EQ(im.sections.size(), 9u);
  EXPECT_EQ(im.sections[5].id, 16u);
  EXPECT_EQ(im.sections[6].id, 18u);
  EXPECT_EQ(im.sections[7].id, 21u);
  EXPECT_EQ(im.sections[8].id, 6u);
  const std::vector<uint8_t>& elements = im.sections[5].payload;
  ASSERT_EQ(elements.size(), 2 * v.elements.size());
  for (size_t i = 0; i < v.elements.size(); ++i)
    ASSERT_EQ(uint32_t(elements[2 * i] | elements[2 * i + 1] << 8), v.labels.elementLabels[i]);
  const std::vector<uint8_t>& voxels = im.sections[7].payload;
  EXPECT_EQ(voxels, compactVoxelSection(v.labels));
  EXPECT_EQ(getLe32(voxels, 0), 2u); // the layout
  const std::vector<uint8_t>& names = im.sections[6].payload;
  EXPECT_EQ(getLe32(names, 0), 3u);
  EXPECT_EQ(getLe32(names, 4), 1u | (10u << 16));
  EXPECT_EQ(std::string(names.begin() + 8, names.begin() + 18), "first part");
  // The CRC covers the header's first 24 bytes, then the payload.
  const std::vector<uint8_t> b = bytesOf(v);
  const size_t at = hdtSectionBoundaries(b)[6]; // header of section 16
  std::vector<uint8_t> covered(b.begin() + long(at), b.begin() + long(at) + 24);
  covered.insert(covered.end(), elements.begin(), elements.end());
  EXPECT_EQ(im.sections[5].crc, referenceCrc32(covered.data(), covered.size()));
}

TEST(HdtFileLabels, EveryByteFlippedAndTruncated) {
  for (const HdtWriteOptions& o : allEncodings()) {
    const Volume v = tinyLabelledVolume();
    ASSERT_FALSE(v.labels.palettes.empty());
    const std::vector<uint8_t> valid = bytesOf(v, o);
    ASSERT_EQ(refusal(valid), "ACCEPTED");
    std::vector<uint8_t> b = valid;
    for (size_t i = 0; i < b.size(); ++i) {
      for (uint8_t mask : {0x01, 0x80}) {
        b[i] ^= mask;
        const std::string m = refusal(b);
        b[i] ^= mask;
        ASSERT_TRUE(refusedProperly(m)) << "byte " << i << " ^ " << int(mask) << ": " << m;
      }
    }
    for (size_t n = 0; n < valid.size(); ++n) ASSERT_TRUE(refusedProperly(refusal(valid.data(), n))) << n;
  }
}

TEST(HdtFileLabels, InconsistentLabelsAreRefused) {
  const Volume v = labelledVolume();
  const std::vector<uint8_t> valid = bytesOf(v, raw());
  // Edit the volume, write its label sections unchecked into the valid file.
  auto withLabels = [&](const std::function<void(LabelField&)>& edit, uint32_t layout = 2) {
    Volume bad = v;
    edit(bad.labels);
    return forge(valid, [&](HdtImage& im) {
      im.sections[5].payload = labelBytes(bad.labels.elementLabels);
      im.sections[7].payload = compactVoxelSection(bad.labels, layout);
    });
  };
  const uint64_t full = findElement(v, ElementState::Full, -1);
  const uint64_t empty = findElement(v, ElementState::Empty, -1);
  const uint64_t branch = findElement(v, ElementState::Branch, -1);
  EXPECT_REFUSED(withLabels([&](LabelField& f) { f.elementLabels[full] = 0; }), "Full element");
  EXPECT_REFUSED(withLabels([&](LabelField& f) { f.elementLabels[empty] = 3; }), "is Empty or Branch");
  EXPECT_REFUSED(withLabels([&](LabelField& f) { f.elementLabels[branch] = 3; }), "is Empty or Branch");
  EXPECT_REFUSED(withLabels([&](LabelField& f) { f.elementLabels.pop_back(); }), "label elements section");
  EXPECT_REFUSED(withLabels([](LabelField&) {}, 3), "layout 3");
  EXPECT_REFUSED(withLabels([&](LabelField& f) { f.paletteIndices.pop_back(); }), "compact label voxels section");
  EXPECT_REFUSED(withLabels([&](LabelField& f) { f.wideLabels.push_back(1); }), "compact label voxels section");
  EXPECT_REFUSED(withLabels([&](LabelField& f) { f.palettes.pop_back(); }), "compact label voxels section");
  // The first palette leaf and the first wide leaf.
  // A palette leaf with a free entry (2 or 3 labels); the first wide leaf.
  const auto firstOf = [&](bool wide) {
    for (size_t k = 0; k < v.labels.palettes.size(); ++k)
      if (v.labels.palettes[k].isWide() == wide && (wide || v.labels.palettes[k].labels[3] == 0)) return k;
    ADD_FAILURE() << "no " << (wide ? "wide" : "palette") << " leaf";
    return size_t(0);
  };
  const size_t p = firstOf(false), w = firstOf(true);
  const size_t W = leafWordCount(v.grid.leafSize), V = v.grid.leafVoxels();
  ASSERT_EQ(v.labels.mixedBlock[w], 0u); // the wide edits below change block 0
  EXPECT_REFUSED(withLabels([&](LabelField& f) { std::swap(f.palettes[p].labels[0], f.palettes[p].labels[1]); }),
                 "not ascending");
  EXPECT_REFUSED(withLabels([&](LabelField& f) { f.palettes[p].labels[3] = 65535; }), // no voxel has it
                 "label voxels: mixed leaf");
  EXPECT_REFUSED(withLabels([&](LabelField& f) {
                   f.palettes[p].labels[1] = 0; // one label left, and indices naming the emptied slot
                   f.palettes[p].labels[2] = 0;
                   f.palettes[p].labels[3] = 0;
                 }),
                 "label voxels: mixed leaf");
  EXPECT_REFUSED(withLabels([&](LabelField& f) {
                   for (size_t j = 0; j < W; ++j) f.paletteIndices[j] = 0xFFFFFFFFu; // index 3 on Outside voxels too
                 }),
                 "label voxels: mixed leaf");
  EXPECT_REFUSED(withLabels([&](LabelField& f) {
                   for (size_t j = 0; j < V; ++j) f.wideLabels[j] = f.wideLabels[j] ? Label(1 + j % 2) : 0;
                 }),
                 "4 labels or fewer");
  EXPECT_REFUSED(withLabels([&](LabelField& f) {
                   for (size_t j = 0; j < V; ++j) f.wideLabels[j] = Label(1 + j % 7); // labels on Outside voxels
                 }),
                 "(wide) has a label 0");

  // Sections: 18 and 21 need 16; 16 needs 17 or 21.
  EXPECT_REFUSED(forge(valid, [](HdtImage& im) { im.sections.erase(im.sections.begin() + 5); }),
                 "without the label elements section");
  EXPECT_REFUSED(forge(valid, [](HdtImage& im) { im.sections.erase(im.sections.begin() + 7); }),
                 "without the label voxels section");
  EXPECT_REFUSED(forge(valid, [](HdtImage& im) { std::swap(im.sections[6], im.sections[7]); }),
                 "increasing id order");
  EXPECT_REFUSED(forge(valid, [](HdtImage& im) { im.sections[5].encoding = 1; }),
                 "label elements section: invalid encoding 1");
  // Bounded before decoding: a stated length beyond 16 bits a voxel.
  EXPECT_REFUSED(forge(valid,
                       [](HdtImage& im) {
                         im.sections[7].keepHeader = true;
                         im.sections[7].encoding = 1;
                         im.sections[7].raw = uint64_t(1) << 40;
                       }),
                 "compact label voxels section: 1099511627776 bytes, expected");
  // Names.
  auto names = [&](const std::function<void(std::vector<uint8_t>&)>& edit) {
    return forge(valid, [&](HdtImage& im) { edit(im.sections[6].payload); });
  };
  EXPECT_REFUSED(names([](std::vector<uint8_t>& p) { p.push_back(0); }), "bytes after the last name");
  EXPECT_REFUSED(names([](std::vector<uint8_t>& p) { putLe32(p, 0, 4); }), "ends inside");
  EXPECT_REFUSED(names([](std::vector<uint8_t>& p) { putLe32(p, 4, 0u | (10u << 16)); }), "not increasing");
  EXPECT_REFUSED(names([](std::vector<uint8_t>& p) { p[8] = '\n'; }), "control character");
  EXPECT_REFUSED(names([](std::vector<uint8_t>& p) { putLe32(p, 4, 1u | (300u << 16)); }), "longer than 255");

  // The writer refuses what the reader would.
  Volume bad = v;
  bad.labels.elementLabels[full] = 0;
  EXPECT_THROW(bytesOf(bad), Error);
  bad = v;
  bad.labels.names[0] = "outside";
  EXPECT_THROW(bytesOf(bad), Error);
}

TEST(HdtFileLabels, UnlabelledReaderViewSkipsNothingItNeeds) {
  // A labelled file read as a version-2 file gives the same voxel states as the
  // unlabelled volume: labels only add.
  Volume v = labelledVolume();
  const std::vector<uint8_t> b = bytesOf(v);
  Volume back = deserializeHdt(b.data(), b.size());
  back.labels = LabelField{};
  v.labels = LabelField{};
  expectSameVolume(v, back, "states");
}


// ---- transferred arrays (sections 19 and 20) ------------------------------------------

// Gives a volume two arrays on its surface voxels: a scalar and a 3-vector
// with a NaN, values from the seed.
void addArrays(Volume& v, uint32_t seed) {
  const uint64_t surface = surfaceVoxelStart(v).back();
  VoxelArray scalar{"pressure", ArraySource::Point, 1, {}}, vector{"velocity", ArraySource::Cell, 3, {}};
  for (uint64_t i = 0; i < surface; ++i) scalar.values.push_back(float(seed) + 0.25f * float(i));
  for (uint64_t i = 0; i < 3 * surface; ++i) vector.values.push_back(i == 1 ? std::nanf("") : -float(i) / 7.0f);
  v.arrays = {scalar, vector};
}

void expectSameArrays(const Volume& a, const Volume& b, const std::string& context) {
  ASSERT_EQ(a.arrays.size(), b.arrays.size()) << context;
  for (size_t k = 0; k < a.arrays.size(); ++k) {
    EXPECT_EQ(a.arrays[k].name, b.arrays[k].name) << context;
    EXPECT_EQ(a.arrays[k].source, b.arrays[k].source) << context;
    EXPECT_EQ(a.arrays[k].components, b.arrays[k].components) << context;
    ASSERT_EQ(a.arrays[k].values.size(), b.arrays[k].values.size()) << context;
    EXPECT_EQ(std::memcmp(a.arrays[k].values.data(), b.arrays[k].values.data(), a.arrays[k].values.size() * 4), 0)
        << context;
  }
}

Volume tinyVolumeWithArrays() {
  Volume v = tinyVolume();
  addArrays(v, 3);
  return v;
}

TEST(HdtFileArrays, RoundTripBitExact) {
  for (const HdtWriteOptions& o : {raw(), compressed()}) {
    for (bool labelled : {false, true}) {
      Volume v = smallVolume();
      if (labelled) labelRandomly(v, 4);
      addArrays(v, 2);
      ASSERT_GT(v.arrays[0].values.size(), 0u);
      const std::vector<uint8_t> b = bytesOf(v, o);
      const Volume back = deserializeHdt(b.data(), b.size());
      expectSameVolume(v, back, "arrays");
      expectSameArrays(v, back, labelled ? "labelled" : "unlabelled");
      EXPECT_EQ(bytesOf(back, o), b);
    }
  }
}

TEST(HdtFileArrays, LayoutFollowsTheSpec) {
  const Volume v = tinyVolumeWithArrays();
  const HdtImage im = parseHdtImage(bytesOf(v));
  ASSERT_EQ(im.sections.size(), 8u); // 5 required, 19, 20, end
  EXPECT_EQ(im.sections[5].id, 19u);
  EXPECT_EQ(im.sections[6].id, 20u);
  const std::vector<uint8_t>& dir = im.sections[5].payload;
  EXPECT_EQ(getLe32(dir, 0), 2u);
  EXPECT_EQ(getLe32(dir, 4), 8u);
  EXPECT_EQ(std::string(dir.begin() + 8, dir.begin() + 16), "pressure");
  EXPECT_EQ(getLe32(dir, 16), 0u); // point
  EXPECT_EQ(getLe32(dir, 20), 1u); // components
  EXPECT_EQ(getLe32(dir, 24), 8u);
  EXPECT_EQ(std::string(dir.begin() + 28, dir.begin() + 36), "velocity");
  EXPECT_EQ(getLe32(dir, 36), 1u); // cell
  EXPECT_EQ(getLe32(dir, 40), 3u);
  EXPECT_EQ(dir.size(), 44u);
  const std::vector<uint8_t>& values = im.sections[6].payload;
  ASSERT_EQ(values.size(), 4 * (v.arrays[0].values.size() + v.arrays[1].values.size()));
  float second;
  std::memcpy(&second, values.data() + 4, 4);
  EXPECT_EQ(second, v.arrays[0].values[1]);
  // The CRC covers the header's first 24 bytes, then the payload.
  const std::vector<uint8_t> b = bytesOf(v);
  const size_t at = hdtSectionBoundaries(b)[7]; // header of section 20
  std::vector<uint8_t> covered(b.begin() + long(at), b.begin() + long(at) + 24);
  covered.insert(covered.end(), values.begin(), values.end());
  EXPECT_EQ(im.sections[6].crc, referenceCrc32(covered.data(), covered.size()));
}

TEST(HdtFileArrays, EveryByteFlippedAndTruncated) {
  for (const HdtWriteOptions& o : {raw(), compressed()}) {
    const std::vector<uint8_t> valid = bytesOf(tinyVolumeWithArrays(), o);
    ASSERT_EQ(refusal(valid), "ACCEPTED");
    std::vector<uint8_t> b = valid;
    // From the header of section 19 on (the bytes before are the other tests'),
    // every 16th byte of the float values (all alike, and many).
    const std::vector<size_t> at = hdtSectionBoundaries(valid);
    const size_t first = at[6], values = at[7] + 28, end = at[8];
    auto sampled = [&](size_t i) { return i < values || i >= end || (i - values) % 16 == 0; };
    for (size_t i = first; i < b.size(); ++i) {
      if (!sampled(i)) continue;
      for (uint8_t mask : {0x01, 0x80}) {
        b[i] ^= mask;
        const std::string m = refusal(b);
        b[i] ^= mask;
        ASSERT_TRUE(refusedProperly(m)) << "byte " << i << " ^ " << int(mask) << ": " << m;
      }
    }
    for (size_t n = first; n < valid.size(); ++n)
      if (sampled(n)) ASSERT_TRUE(refusedProperly(refusal(valid.data(), n))) << n;
  }
}

TEST(HdtFileArrays, InconsistentArraysAreRefused) {
  const Volume v = smallVolume();
  Volume withArrays = v;
  addArrays(withArrays, 1);
  const std::vector<uint8_t> valid = bytesOf(withArrays);
  auto directory = [&](const std::function<void(std::vector<uint8_t>&)>& edit) {
    return forge(valid, [&](HdtImage& im) { edit(im.sections[5].payload); });
  };
  EXPECT_REFUSED(directory([](std::vector<uint8_t>& p) { putLe32(p, 0, 0); }), "0 arrays");
  EXPECT_REFUSED(directory([](std::vector<uint8_t>& p) { putLe32(p, 0, 257); }), "257 arrays");
  EXPECT_REFUSED(directory([](std::vector<uint8_t>& p) { putLe32(p, 0, 3); }), "ends inside an entry");
  EXPECT_REFUSED(directory([](std::vector<uint8_t>& p) { p.push_back(0); }), "bytes after the last entry");
  EXPECT_REFUSED(directory([](std::vector<uint8_t>& p) { putLe32(p, 4, 0); }), "a name of 0 bytes");
  EXPECT_REFUSED(directory([](std::vector<uint8_t>& p) { putLe32(p, 16, 2); }), "unknown source 2");
  EXPECT_REFUSED(directory([](std::vector<uint8_t>& p) { putLe32(p, 20, 0); }), "0 components");
  EXPECT_REFUSED(directory([](std::vector<uint8_t>& p) { putLe32(p, 20, 65); }), "65 components");
  EXPECT_REFUSED(directory([](std::vector<uint8_t>& p) { std::copy(p.begin() + 8, p.begin() + 16, p.begin() + 28); }),
                 "appears twice");
  // A component more than the values section holds.
  EXPECT_REFUSED(directory([](std::vector<uint8_t>& p) { putLe32(p, 20, 2); }), "array values section");
  EXPECT_REFUSED(forge(valid, [](HdtImage& im) { im.sections[6].payload.resize(im.sections[6].payload.size() - 4); }),
                 "array values section");
  EXPECT_REFUSED(forge(valid, [](HdtImage& im) { im.sections.erase(im.sections.begin() + 5); }),
                 "without the array directory section");
  EXPECT_REFUSED(forge(valid, [](HdtImage& im) { im.sections.erase(im.sections.begin() + 6); }),
                 "without the array values section");
  EXPECT_REFUSED(forge(valid, [](HdtImage& im) { im.sections[6].encoding = 1; }),
                 "array values section: invalid encoding 1");
  EXPECT_REFUSED(forge(valid, [](HdtImage& im) { std::swap(im.sections[5], im.sections[6]); }),
                 "without the array directory section");
  // The writer refuses what the reader would.
  Volume bad = withArrays;
  bad.arrays[1].values.pop_back();
  EXPECT_THROW(bytesOf(bad), Error);
  bad = withArrays;
  bad.arrays[1].name = "pressure";
  EXPECT_THROW(bytesOf(bad), Error);
  bad = withArrays;
  bad.arrays[0].components = 0;
  EXPECT_THROW(bytesOf(bad), Error);
}

TEST(HdtFileArrays, ForgedSizesAreRefusedBeforeAllocating) {
  Volume v = smallVolume();
  addArrays(v, 1);
  const std::vector<uint8_t> valid = bytesOf(v);
  // 256 arrays of 64 components: the values section would be 16384 floats a
  // surface voxel; the file holds far less, so nothing that large is allocated.
  std::vector<uint8_t> forged = forge(valid, [](HdtImage& im) {
    std::vector<uint8_t> dir(4);
    putLe32(dir, 0, 256);
    for (int k = 0; k < 256; ++k) {
      const std::string name = "a" + std::to_string(k);
      const size_t at = dir.size();
      dir.resize(at + 4 + name.size() + 8);
      putLe32(dir, at, uint32_t(name.size()));
      std::memcpy(dir.data() + at + 4, name.data(), name.size());
      putLe32(dir, at + 4 + name.size(), 0);
      putLe32(dir, at + 8 + name.size(), 64);
    }
    im.sections[5].payload = dir;
  });
  size_t largest = 0;
  largest = largestAllocationDuring([&] { EXPECT_REFUSED(forged, "array values section"); });
  EXPECT_LT(largest, valid.size() + (size_t(1) << 20));
}
} // namespace
} // namespace test
} // namespace hdt
