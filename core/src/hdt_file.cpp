// The .hdt file format (docs/hdt-format.md): writer and validating reader.
//
// The reader checks in file order, and every check that bounds a later
// allocation comes before it: section lengths against the bytes left in the
// file, the element count against the element section, the leaf data against
// the number of Boundary elements. A violated rule throws Invalid, which the
// entry points turn into hdt::Error naming the file.
//
// The writer runs the same checks on the volume first (it must never produce a
// file the reader refuses), computes every section header, then writes; the
// bulk (elements, leaf words) goes from the volume's own arrays to the output
// without an intermediate copy on little-endian hosts, or through zstd.
#include "hdt/hdt_file.hpp"

#include "hdt/atomic_file.hpp"
#include "hdt_file_checks.hpp"
#include "hdt_file_encode.hpp"
#include "hdt_file_format.hpp"
#include "hdt_file_write.hpp"
#include "hdt_file_zstd.hpp"
#include "hdt_leaf_encoder.hpp"
#include "zstd_blocks.hpp"

#include "hdt/error.hpp"
#include "hdt/labels.hpp"
#include "hdt/lattice.hpp"
#include "hdt/transfer.hpp"

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>
#include <tbb/parallel_reduce.h>
#include <zlib.h>
#if defined(HDT_HAVE_ZSTD)
#include <zstd.h>
#endif

#include <fcntl.h>
#include <sys/stat.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <exception>
#include <memory>
#include <new>
#include <stdexcept>
#include <thread>

namespace hdt {
using namespace hdt_file_detail;
namespace {

// ---- reading ------------------------------------------------------------------------

class Source {
public:
  explicit Source(uint64_t size) : size_(size) {}
  virtual ~Source() = default;
  uint64_t position() const { return pos_; }
  uint64_t remaining() const { return size_ - pos_; }
  // The next `n` bytes (n <= remaining()) into `dst`.
  void read(void* dst, size_t n) {
    doRead(dst, n);
    pos_ += n;
  }
  // The next `n` bytes (n <= remaining()), valid until the next call; they
  // may be copied into `scratch` (a file) or not (memory).
  const uint8_t* view(size_t n, std::vector<uint8_t>& scratch) {
    const uint8_t* p = doView(n, scratch);
    pos_ += n;
    return p;
  }

protected:
  virtual void doRead(void* dst, size_t n) = 0;
  virtual const uint8_t* doView(size_t n, std::vector<uint8_t>& scratch) = 0;
  uint64_t size_;
  uint64_t pos_ = 0;
};

class MemorySource final : public Source {
public:
  MemorySource(const uint8_t* data, size_t size) : Source(size), data_(data) {}

private:
  void doRead(void* dst, size_t n) override {
    if (n) std::memcpy(dst, data_ + pos_, n);
  }
  const uint8_t* doView(size_t, std::vector<uint8_t>&) override { return data_ + pos_; }
  const uint8_t* data_;
};

class FileSource final : public Source {
public:
  FileSource(std::FILE* f, uint64_t size) : Source(size), f_(f) {}

private:
  void doRead(void* dst, size_t n) override {
    if (n && std::fread(dst, 1, n, f_) != n) {
      invalid(std::string("read error at byte ") + str(pos_) +
              (std::ferror(f_) ? ": " + std::string(std::strerror(errno)) : ": the file shrank"));
    }
  }
  const uint8_t* doView(size_t n, std::vector<uint8_t>& scratch) override {
    scratch.resize(n);
    doRead(scratch.data(), n);
    return scratch.data();
  }
  std::FILE* f_;
};

struct SectionHeader {
  Section id;
  Encoding encoding;
  uint64_t stored, raw;
  uint32_t crc;
};

// The 28 bytes of a section header, not yet checked; `before` names the
// section expected there, for the message when the file ends first.
struct RawSectionHeader {
  uint64_t at = 0; // file offset of the header
  uint32_t id = 0, encoding = 0;
  uint64_t stored = 0, raw = 0;
  uint32_t crc = 0;
};

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

// Rule 4 for a header whose id is known: an allowed encoding, the payload in
// the file, raw == stored when raw.
// `compressed`: the highest compressed encoding the section may have (Raw:
// none; Zstd; ZstdBlocks includes Zstd).
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

// An optional section this reader does not know and may skip: its payload is
// checksummed in bounded chunks and dropped.
void skipSection(Source& in, const RawSectionHeader& raw) {
  const std::string name = "optional section " + str(raw.id);
  if (raw.encoding != uint32_t(Encoding::Raw) && raw.encoding != uint32_t(Encoding::Zstd)) {
    invalid(name + ": invalid encoding " + str(raw.encoding));
  }
  if (raw.stored > in.remaining()) {
    invalid(name + ": " + str(raw.stored) + " bytes stored but only " + str(in.remaining()) +
            " remain in the file (truncated?)");
  }
  if (raw.encoding == uint32_t(Encoding::Raw) && raw.raw != raw.stored) {
    invalid(name + ": raw section with " + str(raw.stored) + " bytes stored but " + str(raw.raw) + " decoded");
  }
  std::vector<uint8_t> scratch;
  uint32_t crc = optionalSectionCrcSeed(raw.id, raw.encoding, raw.stored, raw.raw);
  for (uint64_t left = raw.stored; left > 0;) {
    const size_t n = size_t(std::min<uint64_t>(left, kSkipChunkBytes));
    crc = crc32Update(crc, in.view(n, scratch), n);
    left -= n;
  }
  if (crc != raw.crc) invalid(name + ": CRC-32 mismatch");
}

// Rule 6 for an optional section: the CRC covers the header's first 24 bytes.
void checkOptionalCrc(const SectionHeader& h, const uint8_t* stored) {
  const uint32_t seed = optionalSectionCrcSeed(uint32_t(h.id), uint32_t(h.encoding), h.stored, h.raw);
  checkCrc(h, static_cast<uint32_t>(crc32_combine(seed, crc32Of(stored, size_t(h.stored)), z_off_t(h.stored))));
}

// An optional section holding an array of T (raw, or zstd when allowed), its
// raw length already checked; decoded into `out`.
template <class T, class A> void readOptionalArray(Source& in, const SectionHeader& h, std::vector<T, A>& out) {
  const std::string what = sectionName(h.id);
  if (h.encoding == Encoding::Raw) {
    out.resize(size_t(h.raw) / sizeof(T)); // the section is in the file: bounded by its size
    in.read(out.data(), size_t(h.stored));
    checkOptionalCrc(h, reinterpret_cast<const uint8_t*>(out.data()));
  } else {
    std::vector<uint8_t> scratch;
    const uint8_t* stored = in.view(size_t(h.stored), scratch); // in the file: bounded by its size
    checkOptionalCrc(h, stored);
#if defined(HDT_HAVE_ZSTD)
    checkLeafFrame(stored, size_t(h.stored), size_t(h.raw), what);
    out.resize(size_t(h.raw) / sizeof(T));
    decompressLeaves(stored, size_t(h.stored), reinterpret_cast<uint8_t*>(out.data()), size_t(h.raw), what);
#else
    invalid(what + " section: zstd-compressed but this build of HDT has no zstd support");
#endif
  }
  littleEndianToHost(out.data(), out.size());
}

std::map<Label, std::string> decodeLabelNames(const uint8_t* bytes, size_t size) {
  ByteReader r(bytes, size);
  if (size < 4) invalid("label names section: shorter than its count");
  const uint32_t count = r.u32();
  std::map<Label, std::string> names;
  size_t at = 4;
  uint32_t previous = 0;
  for (uint32_t i = 0; i < count; ++i) {
    if (size - at < 4) invalid("label names section: ends inside entry " + str(i));
    const uint32_t packed = r.u32();
    const uint32_t label = packed & 0xFFFFu, length = packed >> 16;
    at += 4;
    if (label <= previous) invalid("label names section: labels are not increasing from 1 (label " + str(label) + ")");
    if (length > kMaxLabelNameLength) invalid("label names section: a name longer than 255 bytes");
    if (size - at < length) invalid("label names section: ends inside the name of label " + str(label));
    names[Label(label)].assign(reinterpret_cast<const char*>(r.bytes(length)), length);
    at += length;
    previous = label;
  }
  if (at != size) invalid("label names section: " + str(size - at) + " bytes after the last name");
  checkLabelNames(names);
  return names;
}

// memcpy for arrays that may be empty (an empty vector's data() may be null).
void copyBytes(void* to, const void* from, size_t n) {
  if (n) std::memcpy(to, from, n);
}

// Section 21's payload (compactLabelVoxelBytes), decoded: the palettes
// first, which say how many index words and wide labels must follow.
void decodeCompactLabelVoxels(const uint8_t* bytes, size_t size, Volume& v, size_t mixed) {
  LabelField& f = v.labels;
  ByteReader r(bytes, size);
  const uint32_t layout = r.u32();
  if (layout != kCompactLabelLayout)
    invalid("compact label voxels section: layout " + str(layout) + ", this reader knows layout 2");
  if ((size - 4) / sizeof(LeafPalette) < mixed)
    invalid("compact label voxels section: " + str(size) + " bytes cannot hold " + str(mixed) + " palettes");
  f.palettes.resize(mixed);
  copyBytes(f.palettes.data(), bytes + 4, mixed * sizeof(LeafPalette));
  littleEndianToHost(reinterpret_cast<Label*>(f.palettes.data()), mixed * kPaletteSize);
  size_t wide = 0;
  for (const LeafPalette& p : f.palettes) wide += p.isWide();
  const size_t words = (mixed - wide) * leafWordCount(v.grid.leafSize), wideLabels = wide * v.grid.leafVoxels();
  const size_t head = 4 + mixed * sizeof(LeafPalette);
  if (size != head + words * 4 + wideLabels * 2)
    invalid("compact label voxels section: " + str(size) + " bytes, but its palettes call for " +
            str(head + words * 4 + wideLabels * 2));
  f.paletteIndices.resize(words);
  copyBytes(f.paletteIndices.data(), bytes + head, words * 4);
  littleEndianToHost(f.paletteIndices.data(), words);
  f.wideLabels.resize(wideLabels);
  copyBytes(f.wideLabels.data(), bytes + head + words * 4, wideLabels * 2);
  littleEndianToHost(f.wideLabels.data(), wideLabels);
}

// The part-label sections (16, 17, 18, 21); `mixed` receives the mixed leaves.
void readLabelSection(Source& in, const RawSectionHeader& raw, Volume& v, std::vector<uint64_t>& mixed) {
  const Section id = Section(raw.id);
  const bool voxels = id == Section::LabelVoxels || id == Section::CompactLabelVoxels;
  const SectionHeader h = checkSectionHeader(raw, id, sectionName(id), voxels ? Encoding::Zstd : Encoding::Raw, in);
  LabelField& f = v.labels;
  if (id != Section::LabelElements && f.empty())
    invalid(std::string(sectionName(id)) + " section without the label elements section");
  const uint64_t V = v.grid.leafVoxels();
  switch (id) {
  case Section::LabelElements:
    expectRawBytes(h, uint64_t(v.elements.size()) * sizeof(Label));
    readOptionalArray(in, h, f.elementLabels);
    mixed = checkLabelElements(f.elementLabels, v.elements);
    break;
  case Section::LabelVoxels: { // the 16-bit layout of older files: checked, then converted
    expectRawBytes(h, mixed.size() * V * sizeof(Label)); // at most 8x the leaf data
    std::vector<Label> labels;
    readOptionalArray(in, h, labels);
    checkSixteenBitVoxelLabels(v, mixed, labels);
    packVoxelLabels(v, labels.data());
    break;
  }
  case Section::CompactLabelVoxels: {
    // Bounded before decoding: the palettes, and at most 16 bits a voxel.
    const uint64_t least = 4 + mixed.size() * sizeof(LeafPalette), most = least + mixed.size() * V * sizeof(Label);
    if (h.raw < least || h.raw > most)
      invalid("compact label voxels section: " + str(h.raw) + " bytes, expected " + str(least) + " to " + str(most));
    std::vector<uint8_t> bytes;
    readOptionalArray(in, h, bytes);
    decodeCompactLabelVoxels(bytes.data(), bytes.size(), v, mixed.size());
    bytes = {};
    indexMixedLeaves(v);
    checkLabelVoxels(v, mixed);
    break;
  }
  default: {
    // 65535 names of 255 bytes at most, each with a 4-byte head.
    if (h.raw > 4 + 65535 * (4 + kMaxLabelNameLength)) invalid("label names section: too long");
    std::vector<uint8_t> scratch;
    const uint8_t* bytes = in.view(size_t(h.stored), scratch);
    checkOptionalCrc(h, bytes);
    f.names = decodeLabelNames(bytes, size_t(h.stored));
    break;
  }
  }
}

// Section 19's contents (encodeArrayDirectory): arrays with names, sources
// and components, values still empty.
std::vector<VoxelArray> decodeArrayDirectory(const uint8_t* bytes, size_t size) {
  const std::string what = "array directory section: ";
  if (size < 4) invalid(what + "shorter than its count");
  ByteReader r(bytes, size);
  const uint32_t count = r.u32();
  if (count == 0 || count > kMaxVoxelArrays) invalid(what + str(count) + " arrays (1 to 256)");
  std::vector<VoxelArray> arrays(count);
  size_t at = 4;
  for (VoxelArray& a : arrays) {
    if (size - at < 4) invalid(what + "ends inside an entry");
    const uint32_t length = r.u32();
    at += 4;
    if (length == 0 || length > kMaxArrayNameLength) invalid(what + "a name of " + str(length) + " bytes (1 to 255)");
    if (size - at < size_t(length) + 8) invalid(what + "ends inside an entry");
    a.name.assign(reinterpret_cast<const char*>(r.bytes(length)), length);
    const uint32_t source = r.u32(), components = r.u32();
    at += size_t(length) + 8;
    if (source > uint32_t(ArraySource::Cell)) invalid(what + "array '" + a.name + "': unknown source " + str(source));
    if (components < 1 || components > kMaxArrayComponents)
      invalid(what + "array '" + a.name + "': " + str(components) + " components (1 to 64)");
    a.source = ArraySource(source);
    a.components = components;
    for (const VoxelArray& b : arrays) {
      if (&b == &a) break;
      if (b.name == a.name) invalid(what + "array '" + a.name + "' appears twice");
    }
  }
  if (at != size) invalid(what + str(size - at) + " bytes after the last entry");
  return arrays;
}

// The transferred-array sections (19, 20). The values' size follows from
// the directory and the surface voxels of the leaf data already read (at most
// 64 * 256 floats per surface voxel), and raw encoding keeps it within the file.
void readArraySection(Source& in, const RawSectionHeader& raw, Volume& v) {
  const Section id = Section(raw.id);
  const SectionHeader h = checkSectionHeader(raw, id, sectionName(id), Encoding::Raw, in);
  if (id == Section::ArrayDirectory) {
    if (h.raw > 4 + kMaxVoxelArrays * (12 + kMaxArrayNameLength)) invalid("array directory section: too long");
    std::vector<uint8_t> scratch;
    const uint8_t* bytes = in.view(size_t(h.stored), scratch);
    checkOptionalCrc(h, bytes);
    v.arrays = decodeArrayDirectory(bytes, size_t(h.stored));
    return;
  }
  if (v.arrays.empty()) invalid("array values section without the array directory section");
  uint64_t surface = 0;
  for (uint32_t w : v.leafWords) surface += planeCount(w, kSurfacePlane);
  uint64_t expected = 0;
  for (const VoxelArray& a : v.arrays) expected += surface * a.components * sizeof(float);
  expectRawBytes(h, expected);
  uint32_t crc = optionalSectionCrcSeed(raw.id, raw.encoding, raw.stored, raw.raw);
  for (VoxelArray& a : v.arrays) {
    a.values.resize(size_t(surface * a.components));
    in.read(a.values.data(), a.values.size() * sizeof(float));
    crc = crc32Update(crc, a.values.data(), a.values.size() * sizeof(float));
    littleEndianToHost(a.values.data(), a.values.size());
  }
  checkCrc(h, crc);
}

// Version 2, after the leaf data: optional sections in increasing id order,
// then the end section (docs/hdt-format.md, "Optional sections").
void readOptionalSections(Source& in, Volume& v) {
  uint32_t previous = 0;
  std::vector<uint64_t> mixed;
  bool labelVoxels = false, arrayValues = false;
  for (;;) {
    const RawSectionHeader raw = readRawSectionHeader(in, "next optional or the end");
    if (raw.id == uint32_t(Section::End)) {
      if (raw.encoding != 0 || raw.stored != 0 || raw.raw != 0 || raw.crc != 0) {
        invalid("end section at byte " + str(raw.at) + ": encoding, lengths and CRC must be 0");
      }
      break;
    }
    if (raw.id < kFirstOptionalSection) {
      invalid("section id " + str(raw.id) + " at byte " + str(raw.at) +
              ": expected an optional section (id 16 or more) or the end section (id 6)");
    }
    if (raw.id <= previous) {
      invalid("optional section " + str(raw.id) + " at byte " + str(raw.at) + " follows section " +
              str(previous) + ": optional sections appear once each, in increasing id order");
    }
    previous = raw.id;
    const bool voxelSection = raw.id == uint32_t(Section::LabelVoxels) || raw.id == uint32_t(Section::CompactLabelVoxels);
    if ((raw.id >= uint32_t(Section::LabelElements) && raw.id <= uint32_t(Section::LabelNames)) || voxelSection) {
      if (voxelSection && labelVoxels) invalid("both label voxels sections (17 and 21)");
      readLabelSection(in, raw, v, mixed);
      labelVoxels = labelVoxels || voxelSection;
      continue;
    }
    if (raw.id == uint32_t(Section::ArrayDirectory) || raw.id == uint32_t(Section::ArrayValues)) {
      readArraySection(in, raw, v);
      arrayValues = arrayValues || raw.id == uint32_t(Section::ArrayValues);
      continue;
    }
    if (raw.id & kCriticalSectionBit) {
      invalid("optional section " + str(raw.id) + " at byte " + str(raw.at) +
              " is marked critical and this reader does not know it");
    }
    skipSection(in, raw);
  }
  if (in.remaining() != 0) invalid(str(in.remaining()) + " bytes after the end section");
  if (!v.labels.empty() && !labelVoxels)
    invalid("label elements section without the label voxels section (17 or 21)");
  if (!v.arrays.empty() && !arrayValues) invalid("array directory section without the array values section");
  indexMixedLeaves(v);
}

Volume readVolume(Source& in) {
  Volume v;
  GridSpec& g = v.grid;

  // File header (rules 1-3).
  uint8_t header[kFileHeaderBytes];
  if (in.remaining() < kFileHeaderBytes)
    invalid("too short for an .hdt file (" + str(in.remaining()) + " bytes)");
  in.read(header, kFileHeaderBytes);
  if (std::memcmp(header, kMagic, 4) != 0) invalid("not an .hdt file (bad magic)");
  ByteReader hr(header + 4, kFileHeaderBytes - 4);
  const uint32_t version = hr.u32(), flags = hr.u32();
  if (version < kOldestVersion || version > kVersion) {
    invalid("unsupported .hdt format version " + str(version) + " (this reader supports " +
            str(kOldestVersion) + " to " + str(kVersion) + ")");
  }
  if (flags & ~kFlagLeafZstd) invalid("unknown flags " + str(flags) + " in the file header");
#if !defined(HDT_HAVE_ZSTD)
  if (flags & kFlagLeafZstd) {
    invalid("the leaf data is zstd-compressed but this build of HDT has no zstd support "
            "(rebuild with libzstd, or write the file without compression)");
  }
#endif

  // Grid (rules 8-10).
  {
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
    g.resolution = int(N);
    g.rootGrid = int(R);
    g.leafSize = int(L);
    g.height = int(height);
    g.origin = origin;
    g.voxelSize = voxelSize;
    v.surfaceOnly = surfaceOnly == 1;
    v.closedMesh = closedMesh == 1;
  }

  // Statistics (rule 11; rule 12 once the contents are known).
  {
    const SectionHeader h = readSectionHeader(in, Section::Statistics);
    if (h.raw < kStatsFixedBytes || h.raw > kStatsFixedBytes + kMaxBackendLength) {
      invalid("statistics section: " + str(h.raw) + " bytes, expected " + str(kStatsFixedBytes) + " to " +
              str(kStatsFixedBytes + kMaxBackendLength));
    }
    const std::vector<uint8_t> bytes = readSmallSection(in, h);
    ByteReader r(bytes.data(), bytes.size());
    Statistics& s = v.stats;
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

  // Level table (rule 13).
  {
    const SectionHeader h = readSectionHeader(in, Section::LevelTable);
    expectRawBytes(h, (uint64_t(g.height) + 2) * 8);
    const std::vector<uint8_t> bytes = readSmallSection(in, h);
    ByteReader r(bytes.data(), bytes.size());
    v.levelStart.resize(size_t(g.height) + 2);
    for (uint64_t& x : v.levelStart) x = r.u64();
    checkLevelTable(v.levelStart, g);
  }

  // Elements (rules 14-17). The count is at most 2^30 - 1 and the section is in the file.
  TreeCounts tree;
  {
    const SectionHeader h = readSectionHeader(in, Section::Elements);
    expectRawBytes(h, v.levelStart.back() * 4);
    v.elements.resize(toSize(v.levelStart.back()));
    readWordSection(in, h, v.elements);
    tree = checkElements(v.elements, v.levelStart, g, v.surfaceOnly);
  }

  // Leaf data (rules 18-19). Its size follows from the Boundary elements just
  // counted, at most 8 KiB for each 4-byte element read.
  {
    const SectionHeader h = readSectionHeader(
        in, Section::LeafData, version >= kFirstBlocksVersion ? Encoding::ZstdBlocks : Encoding::Zstd);
    if (version >= kFirstBlocksVersion && h.encoding != Encoding::ZstdBlocks) {
      invalid("leaf data section: encoding " + str(uint32_t(h.encoding)) + " in a version-" + str(version) +
              " file (version 3 stores the leaf data as zstd blocks, encoding 2)");
    }
    if (((flags & kFlagLeafZstd) != 0) != isCompressed(h.encoding)) {
      invalid("the file header's compression flag disagrees with the leaf data section");
    }
    const uint64_t words = tree.leaves * leafWordCount(g.leafSize);
    expectRawBytes(h, words * 4);
    if (h.encoding == Encoding::Raw) {
      v.leafWords.resize(toSize(words)); // the section is in the file: bounded by its size
      readWordSection(in, h, v.leafWords);
    } else {
#if defined(HDT_HAVE_ZSTD)
      // The stored bytes are in the file; the decoded size is allocated only
      // after the checksum and the frame header agree with it.
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
#endif
    }
  }
  if (version == 1) {
    if (in.remaining() != 0) invalid(str(in.remaining()) + " bytes after the end of the leaf data section");
  } else {
    readOptionalSections(in, v);
  }

  checkStructure(v.stats, v, tree, checkLeaves(v.leafWords, g.leafSize, v.surfaceOnly));
  return v;
}

} // namespace

namespace {

Volume readNamed(Source& in, const std::string& name) {
  try {
    return readVolume(in);
  } catch (const Invalid& e) {
    throw Error(ErrorKind::BadInput, name + ": " + e.what());
  } catch (const std::bad_alloc&) {
    throw Error(ErrorKind::OutOfResources, name + ": not enough memory to load the volume");
  }
}

struct FileClose {
  void operator()(std::FILE* f) const { std::fclose(f); }
};

} // namespace

std::vector<uint8_t> serializeHdt(const Volume& volume, const HdtWriteOptions& options, HdtLeafEncoder* streamed) {
  const std::string name = "<memory>";
  const EncodedVolume e = prepare(volume, options, name, streamed);
  std::vector<uint8_t> bytes;
  try {
    bytes.reserve(toSize(encodedSize(e, volume)));
    VectorSink sink(bytes);
    emit(e, volume, sink);
  } catch (const std::bad_alloc&) {
    throw Error(ErrorKind::OutOfResources, name + ": out of memory while serializing the volume");
  }
  return bytes;
}

void writeHdt(const Volume& volume, AtomicFile& out, const HdtWriteOptions& options, HdtLeafEncoder* streamed) {
  if (writeStreaming(volume, out.stream(), out.path(), options, streamed)) return;
  const EncodedVolume e = prepare(volume, options, out.path(), streamed);
  FileSink sink(out.stream(), out.path());
  emit(e, volume, sink);
}

void writeHdt(const Volume& volume, const std::string& path, const HdtWriteOptions& options,
              HdtLeafEncoder* streamed) {
  // The bytes go to a temporary file renamed over `path` only once complete
  // (atomic_file.hpp): a refused volume leaves no file behind.
#if defined(HDT_HAVE_ZSTD)
  if (streamed && streamingLeafBlocks(*streamed, volume.leafWords, options)) {
    AtomicFile out(path);
    writeStreaming(volume, out.stream(), path, options, streamed);
    out.commit();
    return;
  }
#endif
  // Encode first, then create the file.
  const EncodedVolume e = prepare(volume, options, path, streamed);
  AtomicFile out(path);
  FileSink sink(out.stream(), path);
  emit(e, volume, sink);
  out.commit();
}

Volume deserializeHdt(const uint8_t* data, size_t size, const std::string& name) {
  if (data == nullptr && size != 0) throw Error(ErrorKind::InvalidArgument, name + ": null data");
  MemorySource in(data, size);
  return readNamed(in, name);
}

Volume readHdt(const std::string& path) {
  std::unique_ptr<std::FILE, FileClose> f(std::fopen(path.c_str(), "rb"));
  if (!f) throw Error(ErrorKind::BadInput, path + ": cannot open: " + std::strerror(errno));
  struct stat st;
  if (fstat(fileno(f.get()), &st) != 0 || !S_ISREG(st.st_mode)) {
    throw Error(ErrorKind::BadInput, path + ": not a regular file");
  }
  FileSource in(f.get(), uint64_t(st.st_size));
  return readNamed(in, path);
}

} // namespace hdt
