// The .hdt reader's section headers and required sections (hdt_file_read.hpp).
#include "hdt_file_read.hpp"

#include "hdt_file_checks.hpp"
#include "hdt_file_zstd.hpp"

#include "hdt/error.hpp"

#include <array>
#include <cstdio>
#include <cstring>

namespace hdt::hdt_file_detail {

RawSectionHeader readRawSectionHeader(Source& in, const std::string& before) {
  RawSectionHeader h;
  h.at = in.position();
  if (in.remaining() < kSectionHeaderBytes) {
    invalid("the file ends at byte " + str(h.at + in.remaining()) + ", before the " + before +
            " section header is complete");
  }
  uint8_t bytes[kSectionHeaderBytes];
  in.read(bytes, kSectionHeaderBytes);
  ByteReader r(bytes, kSectionHeaderBytes);
  h.id = r.u32();
  h.encoding = r.u32();
  h.stored = r.u64();
  h.raw = r.u64();
  h.crc = r.u32();
  return h;
}

SectionHeader checkSectionHeader(const RawSectionHeader& raw, Section id, const std::string& name,
                                 Encoding compressed, const Source& in) {
  SectionHeader h{id, Encoding::Raw, raw.stored, raw.raw, raw.crc};
  if (raw.encoding != uint32_t(Encoding::Raw) && raw.encoding <= uint32_t(compressed)) {
    h.encoding = Encoding(raw.encoding);
  } else if (raw.encoding != uint32_t(Encoding::Raw)) {
    invalid(name + " section: invalid encoding " + str(raw.encoding));
  }
  if (h.stored > in.remaining()) {
    invalid(name + " section: " + str(h.stored) + " bytes stored but only " + str(in.remaining()) +
            " remain in the file (truncated?)");
  }
  if (h.encoding == Encoding::Raw && h.raw != h.stored) {
    invalid(name + " section: raw section with " + str(h.stored) + " bytes stored but " + str(h.raw) +
            " decoded");
  }
  return h;
}

// Rule 5: checked before the payload is read.
void expectRawBytes(const SectionHeader& h, uint64_t expected) {
  if (h.raw != expected) {
    invalid(std::string(sectionName(h.id)) + " section: " + str(h.raw) + " bytes, expected " + str(expected));
  }
}

// Rule 6.
void checkCrc(const SectionHeader& h, uint32_t actual) {
  if (actual != h.crc) {
    char msg[128];
    std::snprintf(msg, sizeof msg, " section: CRC-32 mismatch (stored %08x, computed %08x)", h.crc, actual);
    invalid(sectionName(h.id) + std::string(msg));
  }
}

namespace {

// Rule 4: the header is complete, expected, and its payload is in the file.
SectionHeader readSectionHeader(Source& in, Section expected, Encoding compressed = Encoding::Raw) {
  const std::string name = sectionName(expected);
  const RawSectionHeader raw = readRawSectionHeader(in, name);
  if (raw.id != uint32_t(expected)) {
    invalid("expected the " + name + " section (id " + str(uint32_t(expected)) + ") at byte " + str(raw.at) +
            ", found id " + str(raw.id));
  }
  return checkSectionHeader(raw, expected, name, compressed, in);
}

// A small, already length-checked section: its bytes, CRC verified.
std::vector<uint8_t> readSmallSection(Source& in, const SectionHeader& h) {
  std::vector<uint8_t> bytes(size_t(h.stored));
  in.read(bytes.data(), bytes.size());
  checkCrc(h, crc32Of(bytes.data(), bytes.size()));
  return bytes;
}

// Words of a raw section, straight into `words` (already sized to h.stored / 4).
template <class Words> void readWordSection(Source& in, const SectionHeader& h, Words& words) {
  in.read(words.data(), size_t(h.stored));
  checkCrc(h, crc32Of(words.data(), size_t(h.stored)));
  littleEndianToHost(words.data(), words.size());
}

// The file header's fields (rules 1-3 checked).
struct FileHeader {
  uint32_t version = 0, flags = 0;
};

FileHeader readFileHeader(Source& in) {
  uint8_t header[kFileHeaderBytes];
  if (in.remaining() < kFileHeaderBytes)
    invalid("too short for an .hdt file (" + str(in.remaining()) + " bytes)");
  in.read(header, kFileHeaderBytes);
  if (std::memcmp(header, kMagic, 4) != 0) invalid("not an .hdt file (bad magic)");
  ByteReader hr(header + 4, kFileHeaderBytes - 4);
  FileHeader file;
  file.version = hr.u32();
  file.flags = hr.u32();
  if (file.version < kOldestVersion || file.version > kVersion) {
    invalid("unsupported .hdt format version " + str(file.version) + " (this reader supports " +
            str(kOldestVersion) + " to " + str(kVersion) + ")");
  }
  if (file.flags & ~kFlagLeafZstd) invalid("unknown flags " + str(file.flags) + " in the file header");
#if !defined(HDT_HAVE_ZSTD)
  if (file.flags & kFlagLeafZstd) {
    invalid("the leaf data is zstd-compressed but this build of HDT has no zstd support "
            "(rebuild with libzstd, or write the file without compression)");
  }
#endif
  return file;
}

// Rules 8-10: the grid and the volume's flags.
void readGrid(Source& in, uint32_t version, Volume& v) {
  const SectionHeader h = readSectionHeader(in, Section::Grid);
  expectRawBytes(h, version == 1 ? kGridBytesV1 : kGridBytes);
  const std::vector<uint8_t> bytes = readSmallSection(in, h);
  ByteReader r(bytes.data(), bytes.size());
  const int64_t N = r.u32(), R = r.u32(), L = r.u32(), height = r.u32();
  std::array<double, 3> origin;
  for (double& o : origin) o = r.f64();
  const double voxelSize = r.f64();
  const uint32_t surfaceOnly = r.u32(), closedMesh = r.u32();
  // Version 1 predates the choice: its volumes were classified by parity.
  const uint32_t insideTest = version == 1 ? uint32_t(InsideTest::Parity) : r.u32();
  checkGrid(N, R, L, height, origin, voxelSize);
  if (surfaceOnly > 1 || closedMesh > 1) invalid("grid: a boolean flag is neither 0 nor 1");
  checkInsideTest(insideTest);
  v.insideTest = InsideTest(insideTest);
  GridSpec& g = v.grid;
  g.resolution = int(N);
  g.rootGrid = int(R);
  g.leafSize = int(L);
  g.height = int(height);
  g.origin = origin;
  g.voxelSize = voxelSize;
  v.surfaceOnly = surfaceOnly == 1;
  v.closedMesh = closedMesh == 1;
}

// Rule 11; rule 12 once the contents are known (readVolume).
void readStatistics(Source& in, Statistics& s) {
  const SectionHeader h = readSectionHeader(in, Section::Statistics);
  if (h.raw < kStatsFixedBytes || h.raw > kStatsFixedBytes + kMaxBackendLength) {
    invalid("statistics section: " + str(h.raw) + " bytes, expected " + str(kStatsFixedBytes) + " to " +
            str(kStatsFixedBytes + kMaxBackendLength));
  }
  const std::vector<uint8_t> bytes = readSmallSection(in, h);
  ByteReader r(bytes.data(), bytes.size());
  for (uint64_t* x : {&s.triangles, &s.degenerateTriangles, &s.treeElements, &s.leafGrids, &s.leafVoxels,
                      &s.activeVoxels, &s.insideVoxels})
    *x = r.u64();
  s.paperBitsPerActiveVoxel = r.f64();
  s.topologyBytes = r.u64();
  s.leafBytes = r.u64();
  for (double* t : {&s.time.mapping, &s.time.branching, &s.time.leaf, &s.time.classify, &s.time.total})
    *t = r.f64();
  s.peakHostBytes = r.u64();
  s.peakDeviceBytes = r.u64();
  s.threads = r.i32();
  const uint32_t length = r.u32();
  if (length != bytes.size() - kStatsFixedBytes) {
    invalid("statistics section: backend name of " + str(length) + " bytes in a section of " +
            str(bytes.size()));
  }
  s.backend.assign(reinterpret_cast<const char*>(r.bytes(length)), length);
  checkStatisticsFields(s);
}

// Rule 13.
void readLevelTable(Source& in, Volume& v) {
  const SectionHeader h = readSectionHeader(in, Section::LevelTable);
  expectRawBytes(h, (uint64_t(v.grid.height) + 2) * 8);
  const std::vector<uint8_t> bytes = readSmallSection(in, h);
  ByteReader r(bytes.data(), bytes.size());
  v.levelStart.resize(size_t(v.grid.height) + 2);
  for (uint64_t& x : v.levelStart) x = r.u64();
  checkLevelTable(v.levelStart, v.grid);
}

// Rules 14-17. The count is at most 2^30 - 1 and the section is in the file.
TreeCounts readElements(Source& in, Volume& v) {
  const SectionHeader h = readSectionHeader(in, Section::Elements);
  expectRawBytes(h, v.levelStart.back() * 4);
  v.elements.resize(toSize(v.levelStart.back()));
  readWordSection(in, h, v.elements);
  return checkElements(v.elements, v.levelStart, v.grid, v.surfaceOnly);
}

#if defined(HDT_HAVE_ZSTD)
// Compressed leaf data (encoding 1 or 2) into `v.leafWords` (`words` of them).
// The stored bytes are in the file; the decoded size is allocated only after
// the checksum and the frame headers agree with it.
void decodeLeafData(Source& in, const SectionHeader& h, uint64_t words, Volume& v) {
  std::vector<uint8_t> scratch;
  const uint8_t* stored = in.view(size_t(h.stored), scratch);
  checkCrc(h, crc32Of(stored, size_t(h.stored)));
  uint8_t* leafBytes = nullptr;
  if (h.encoding == Encoding::ZstdBlocks) {
    const zstd_blocks::Layout layout = checkLeafBlocks(stored, size_t(h.stored), h.raw);
    v.leafWords.resize(toSize(words));
    leafBytes = reinterpret_cast<uint8_t*>(v.leafWords.data());
    decompressLeafBlocks(stored, layout, leafBytes, size_t(h.raw));
  } else {
    checkLeafFrame(stored, size_t(h.stored), size_t(h.raw));
    v.leafWords.resize(toSize(words));
    leafBytes = reinterpret_cast<uint8_t*>(v.leafWords.data());
    decompressLeaves(stored, size_t(h.stored), leafBytes, size_t(h.raw));
  }
  littleEndianToHost(v.leafWords.data(), v.leafWords.size());
}
#endif

// Rule 18 (rule 19 with the statistics, readVolume). Its size follows from
// the Boundary elements counted, at most 8 KiB for each 4-byte element read.
void readLeafData(Source& in, const FileHeader& file, uint64_t leaves, Volume& v) {
  const bool blocksVersion = file.version >= kFirstBlocksVersion;
  const SectionHeader h =
      readSectionHeader(in, Section::LeafData, blocksVersion ? Encoding::ZstdBlocks : Encoding::Zstd);
  if (blocksVersion && h.encoding != Encoding::ZstdBlocks) {
    invalid("leaf data section: encoding " + str(uint32_t(h.encoding)) + " in a version-" + str(file.version) +
            " file (version 3 stores the leaf data as zstd blocks, encoding 2)");
  }
  if (((file.flags & kFlagLeafZstd) != 0) != isCompressed(h.encoding)) {
    invalid("the file header's compression flag disagrees with the leaf data section");
  }
  const uint64_t words = leaves * leafWordCount(v.grid.leafSize);
  expectRawBytes(h, words * 4);
  if (h.encoding == Encoding::Raw) {
    v.leafWords.resize(toSize(words)); // the section is in the file: bounded by its size
    readWordSection(in, h, v.leafWords);
    return;
  }
#if defined(HDT_HAVE_ZSTD)
  decodeLeafData(in, h, words, v);
#endif
}

// What follows the leaf data: nothing in version 1; the optional sections
// and the end section from version 2 on.
void readAfterLeafData(Source& in, uint32_t version, Volume& v) {
  if (version == 1) {
    if (in.remaining() != 0) invalid(str(in.remaining()) + " bytes after the end of the leaf data section");
    return;
  }
  readOptionalSections(in, v);
}

} // namespace

Volume readVolume(Source& in) {
  Volume v;
  const FileHeader file = readFileHeader(in);
  readGrid(in, file.version, v);
  readStatistics(in, v.stats);
  readLevelTable(in, v);
  const TreeCounts tree = readElements(in, v);
  readLeafData(in, file, tree.leaves, v);
  readAfterLeafData(in, file.version, v);
  checkStructure(v.stats, v, tree, checkLeaves(v.leafWords, v.grid.leafSize, v.surfaceOnly));
  return v;
}

} // namespace hdt::hdt_file_detail
