// Helpers for the file-format and dense-export tests: small valid volumes made
// by hand (no builder involved), volume comparison, a temporary directory, and
// a test-side view of the .hdt container (written from docs/hdt-format.md, not
// from the library's code) for forging files.
#pragma once

#include "hdt/volume.hpp"

#include <cstdint>
#include <string>
#include <vector>

namespace hdt {
namespace test {

struct RandomVolumeSpec {
  int rootGrid = 2;
  int leafSize = 8;
  int height = 1;
  bool surfaceOnly = false;
  double branchChance = 0.5;   // per element above the leaf level
  double boundaryChance = 0.5; // per element at the leaf level
  double fullChance = 0.3;     // per remaining element (never in surface-only volumes)
};

// A valid volume with a random tree and random leaf contents (states 0, 1, 2;
// no 1 when surface-only), statistics computed, deterministic in `seed`.
Volume randomVolume(uint32_t seed, const RandomVolumeSpec& spec);

// Gives a volume random part labels (hdt/label_field.hpp rules): Full
// elements a label 1..labels, leaves one label or (when they have two
// non-Outside voxels) per-voxel labels, a few names. Deterministic in `seed`.
// Returns the mixed leaves' labels as chosen, L^3 per mixed leaf in leaf
// order (the reference for the compact storage, and .hdt section 17's layout).
std::vector<Label> labelRandomly(Volume& volume, uint32_t seed, int labels = 5);

// An otherwise empty volume of the given shape: the R^3 root elements Empty.
Volume emptyVolume(int rootGrid, int leafSize, int height);

// Every field equal, floating point bit for bit (EXPECTs with a context string).
void expectSameVolume(const Volume& expected, const Volume& actual, const std::string& context = "");

// Directory for test output: $HDT_TEST_TMPDIR or GoogleTest's TempDir().
std::string tempPath(const std::string& fileName);

// ---- the .hdt container, as the spec describes it --------------------------------

uint32_t referenceCrc32(const uint8_t* data, size_t size); // bitwise CRC-32 (zlib's)

struct HdtSectionImage {
  uint32_t id = 0, encoding = 0;
  uint64_t stored = 0, raw = 0;
  uint32_t crc = 0;
  std::vector<uint8_t> payload;
  // assemble() recomputes stored, raw (for raw sections) and crc from the
  // payload unless told to keep the header as it is (to forge lengths).
  bool keepHeader = false;
};

struct HdtImage {
  std::vector<uint8_t> fileHeader; // 12 bytes
  std::vector<HdtSectionImage> sections;
};

// Splits a well-formed file; fails the test (ADD_FAILURE) and returns what it
// has if the bytes do not parse.
HdtImage parseHdtImage(const std::vector<uint8_t>& bytes);
std::vector<uint8_t> assembleHdtImage(const HdtImage& image);

// Byte offsets of every section header and the end of the file, for sampling.
std::vector<size_t> hdtSectionBoundaries(const std::vector<uint8_t>& bytes);

// Little-endian field access in a byte vector.
uint32_t getLe32(const std::vector<uint8_t>& b, size_t at);
uint64_t getLe64(const std::vector<uint8_t>& b, size_t at);
void putLe32(std::vector<uint8_t>& b, size_t at, uint32_t v);
void putLe64(std::vector<uint8_t>& b, size_t at, uint64_t v);
void putF64(std::vector<uint8_t>& b, size_t at, double v);

} // namespace test
} // namespace hdt
